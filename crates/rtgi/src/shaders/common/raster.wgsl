// The vertex stage and fragment normals shared by the raster passes that draw the whole scene with its
// materials (G-buffer, reflective shadow maps): one place that decodes vertices and orients normals.

#import common/scene.wgsl

struct SceneVertexOut {
    @builtin(position) clip: vec4f,
    @location(0) world: vec3f,
    @location(1) normal: vec3f,
    @location(2) tangent: vec4f,
    @location(3) uv: vec2f,
    @location(4) @interpolate(flat) material: u32,
}

fn scene_vertex(view_proj: mat4x4f, v: Vertex) -> SceneVertexOut {
    var out: SceneVertexOut;
    out.clip = view_proj * vec4f(v.position, 1.0);
    out.world = v.position;
    out.normal = vertex_normal(v);
    out.tangent = vertex_tangent(v);
    out.uv = v.uv;
    out.material = vertex_material(v);
    return out;
}

struct FragmentNormals {
    geometric: vec3f,
    // Interpolated, normal-mapped, on the geometric normal's side.
    shading: vec3f,
}

// Both normals of a fragment turned towards `towards` (the viewer, or the light): rtgi shades both sides
// of every surface. The geometric normal comes from screen-space derivatives of the position.
fn fragment_normals(in: SceneVertexOut, m: Material, towards: vec3f, lod: f32) -> FragmentNormals {
    var r: FragmentNormals;
    r.geometric = normalize(cross(dpdx(in.world), dpdy(in.world)));
    if dot(r.geometric, towards) < 0.0 {
        r.geometric = -r.geometric;
    }
    var n = normalize(in.normal);
    if dot(n, r.geometric) < 0.0 {
        n = -n;
    }
    r.shading = perturb_normal(m, n, in.tangent, in.uv, lod);
    return r;
}
