// Wavelet PRT (composed after shade.wgsl): the point's irradiance, interpolated from its vertices'
// (wavelet_lighting.wgsl: each vertex's kept transfer terms dotted with the frame's kept lighting),
// times the diffuse lobe's reflectance / π.

@group(2) @binding(3) var<storage, read> vertex_irradiance: array<vec4f>;

fn environment_light(s: GSurface, p: TrianglePoint) -> vec3f {
    let irradiance = p.weights.x * vertex_irradiance[p.vertices.x].rgb
        + p.weights.y * vertex_irradiance[p.vertices.y].rgb
        + p.weights.z * vertex_irradiance[p.vertices.z].rgb;
    let diffuse = brdf_lobe_weights(s.material, saturate(dot(s.normal, s.view))).diffuse;
    return diffuse * INV_PI * irradiance;
}
