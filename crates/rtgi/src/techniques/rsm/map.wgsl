// Reflective shadow map (Dachsbacher & Stamminger 2005): the scene rendered from one light view with
// multiple render targets holding, per texel, the world position of the first surface the light reaches,
// its normal, and the light it reflects. Layouts: see `rsm.wgsl`.

#import common/scene.wgsl
#import common/lights.wgsl

@group(1) @binding(0) var<uniform> rsm_view: RsmView;

struct VertexOut {
    @builtin(position) clip: vec4f,
    @location(0) world: vec3f,
    @location(1) normal: vec3f,
    @location(2) tangent: vec4f,
    @location(3) uv: vec2f,
    @location(4) @interpolate(flat) material: u32,
}

@vertex
fn vs_main(
    @location(0) position: vec3f,
    @location(1) material_flags: u32,
    @location(2) normal_oct: u32,
    @location(3) tangent_oct: u32,
    @location(4) uv: vec2f,
) -> VertexOut {
    let v = Vertex(position, material_flags, normal_oct, tangent_oct, uv);
    var out: VertexOut;
    out.clip = rsm_view.view_proj * vec4f(position, 1.0);
    out.world = position;
    out.normal = vertex_normal(v);
    out.tangent = vertex_tangent(v);
    out.uv = uv;
    out.material = vertex_material(v);
    return out;
}

struct RsmOut {
    @location(0) position: vec4f,
    @location(1) normal: vec4f,
    @location(2) intensity: vec4f,
}

@fragment
fn fs_main(in: VertexOut) -> RsmOut {
    let m = materials[in.material];
    let s = material_at(m, in.uv, 0.0);
    if m.alpha_cutoff >= 0.0 && s.alpha < m.alpha_cutoff {
        discard;
    }
    let light = lights[rsm_view.light];
    let inc = light_incidence(light, in.world);
    // Both normals face the light (rtgi shades both sides of every surface).
    var ng = normalize(cross(dpdx(in.world), dpdy(in.world)));
    if dot(ng, inc.direction) < 0.0 {
        ng = -ng;
    }
    var n = normalize(in.normal);
    if dot(n, ng) < 0.0 {
        n = -n;
    }
    n = perturb_normal(m, n, in.tangent, in.uv, 0.0);
    // Cross-section of the texel's beam at the surface: texel² for orthographic views; for perspective
    // views the texel's solid angle (texel² · cos³ of the angle to the view axis) times distance².
    var area = rsm_view.texel * rsm_view.texel;
    if rsm_view.orthographic == 0u {
        let ndc = in.clip.xy / rsm_view.size * 2.0 - 1.0;
        let t = ndc * (0.5 * rsm_view.texel * rsm_view.size);
        let cos2 = 1.0 / (1.0 + dot(t, t));
        area *= cos2 * sqrt(cos2) * inc.distance * inc.distance;
    }
    // All the light through the texel lands on the surface; a Lambertian reflector re-emits the fraction
    // `albedo` of it with radiant intensity Φ/π along its normal (RSM treats every reflector as diffuse).
    let flux = inc.irradiance * area * s.base_color * (1.0 - s.metallic);
    var out: RsmOut;
    out.position = vec4f(in.world, area);
    out.normal = vec4f(n, 1.0);
    out.intensity = vec4f(flux * INV_PI, 1.0);
    return out;
}
