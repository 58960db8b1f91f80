// Texture-space footprints of primary rays: the ray differentials of one pixel's step in x and in y
// (Igehy 1999) carried to the hit triangle's plane and turned into texture-coordinate steps through the
// barycentric differentials. The ray-cast G-buffer picks mip levels with them, the glints technique
// the texels a pixel covers.

#import common/scene.wgsl
#import common/frame_uniforms.wgsl

// d(uv)/dx and d(uv)/dy (columns, texture-coordinate units per pixel) of the primary ray through
// framebuffer point `xy` (direction `dir`) that hits `triangle` at distance `t`; zero for a ray
// grazing the triangle's plane or a degenerate triangle.
fn primary_uv_differentials(triangle: u32, xy: vec2f, dir: vec3f, t: f32) -> mat2x2f {
    let v = triangle_vertices(triangle);
    let e1 = v[1].position - v[0].position;
    let e2 = v[2].position - v[0].position;
    let n = cross(e1, e2);
    let dn = dot(dir, n);
    let g11 = dot(e1, e1);
    let g12 = dot(e1, e2);
    let g22 = dot(e2, e2);
    let det = g11 * g22 - g12 * g12;
    var j = mat2x2f(vec2f(0.0), vec2f(0.0));
    if abs(dn) < 1e-30 || det < 1e-30 {
        return j;
    }
    let duv1 = v[1].uv - v[0].uv;
    let duv2 = v[2].uv - v[0].uv;
    for (var axis = 0u; axis < 2u; axis++) {
        let step = select(vec2f(0.0, 1.0), vec2f(1.0, 0.0), axis == 0u);
        let dd = primary_ray_through(xy + step) - dir;
        // The neighbouring ray's hit on the plane, to first order.
        let dp = t * (dd - dir * (dot(dd, n) / dn));
        let b1 = dot(e1, dp);
        let b2 = dot(e2, dp);
        j[axis] = ((g22 * b1 - g12 * b2) * duv1 + (g11 * b2 - g12 * b1) * duv2) / det;
    }
    return j;
}
