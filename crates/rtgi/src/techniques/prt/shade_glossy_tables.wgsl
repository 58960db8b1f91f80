// glossy_lobe = ggx (composed after shade_glossy.wgsl, the BRDF tables' lookup.wgsl and shading.wgsl):
// the transferred radiance integrated against rtgi's whole BRDF (diffuse and GGX lobes) in the view
// direction through the SH BRDF tables, as env-harmonics integrates the unshadowed environment.

@group(2) @binding(4) var<storage, read> rotation_x90: array<f32>;
@group(2) @binding(5) var<storage, read> brdf_tables: array<f32>;
@group(2) @binding(6) var<storage, read> vertex_instances: array<u32>;

fn environment_light(s: GSurface, p: TrianglePoint) -> vec3f {
    return harmonic_shading(glossy_surface(s, p), shape.order);
}
