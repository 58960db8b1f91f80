// Glossy PRT (composed after shade.wgsl): the point's transferred radiance L' (glossy.wgsl: each
// vertex's transfer matrix times the environment's SH), interpolated from its triangle's vertices, as
// `incident_sh` for the lobes composed after this file: shade_glossy_tables.wgsl (glossy_lobe = ggx)
// or shade_glossy_phong.wgsl (glossy_lobe = phong).

// Per vertex, order² coefficients of transferred radiance (rgb).
@group(2) @binding(3) var<storage, read> transferred: array<vec4f>;

// The point being shaded, for incident_sh.
var<private> shaded: TrianglePoint;

fn incident_sh(k: u32) -> vec3f {
    let count = shape.order * shape.order;
    let p = shaded;
    return p.weights.x * transferred[p.vertices.x * count + k].rgb
        + p.weights.y * transferred[p.vertices.y * count + k].rgb
        + p.weights.z * transferred[p.vertices.z * count + k].rgb;
}
