// Reflective shadow map (Dachsbacher & Stamminger 2005): the scene rendered from one light view with
// multiple render targets holding, per texel, the world position of the first surface the light reaches,
// its normal, and the light it reflects. Layouts: see `rsm.wgsl`.

#import common/raster.wgsl
#import common/lights.wgsl

@group(1) @binding(0) var<uniform> rsm_view: RsmView;

@vertex
fn vs_main(
    @location(0) position: vec3f,
    @location(1) material_flags: u32,
    @location(2) normal_oct: u32,
    @location(3) tangent_oct: u32,
    @location(4) uv: vec2f,
) -> SceneVertexOut {
    return scene_vertex(rsm_view.view_proj, Vertex(position, material_flags, normal_oct, tangent_oct, uv));
}

struct RsmOut {
    @location(0) position: vec4f,
    @location(1) normal: vec4f,
    @location(2) intensity: vec4f,
}

@fragment
fn fs_main(in: SceneVertexOut) -> RsmOut {
    let m = materials[in.material];
    let s = material_at(m, in.uv, 0.0);
    if m.alpha_cutoff >= 0.0 && s.alpha < m.alpha_cutoff {
        discard;
    }
    let light = lights[rsm_view.light];
    let inc = light_incidence(light, in.world);
    // Both normals face the light.
    let n = fragment_normals(in, m, inc.direction, 0.0).shading;
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
