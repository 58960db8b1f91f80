// Glossy PRT (composed after shade.wgsl, the BRDF tables' lookup.wgsl and shading.wgsl): the point's
// transferred radiance L' (glossy.wgsl: each vertex's transfer matrix times the environment's SH),
// interpolated from its triangle's vertices, integrated against rtgi's whole BRDF (diffuse and GGX
// lobes) in the view direction through the SH BRDF tables, as env-harmonics integrates the unshadowed
// environment.

// Per vertex, order² coefficients of transferred radiance (rgb).
@group(2) @binding(3) var<storage, read> transferred: array<vec4f>;
@group(2) @binding(4) var<storage, read> rotation_x90: array<f32>;
@group(2) @binding(5) var<storage, read> brdf_tables: array<f32>;

// The point being shaded, for incident_sh.
var<private> shaded: TrianglePoint;

fn incident_sh(k: u32) -> vec3f {
    let count = shape.order * shape.order;
    let p = shaded;
    return p.weights.x * transferred[p.vertices.x * count + k].rgb
        + p.weights.y * transferred[p.vertices.y * count + k].rgb
        + p.weights.z * transferred[p.vertices.z * count + k].rgb;
}

fn environment_light(s: GSurface, p: TrianglePoint) -> vec3f {
    shaded = p;
    return harmonic_shading(s, shape.order);
}
