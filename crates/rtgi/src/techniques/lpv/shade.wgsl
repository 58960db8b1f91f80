// (Storage buffers are declared read_write: all LPV passes share one bind group layout.)
// Camera pixels (prepended: volume.wgsl): this frame's direct light (accumulated while nothing moves, by
// the `direct` pass) plus the diffuse light of the accumulated volume. The receiver samples it half a
// cell along its normal (against light from behind its own surface), trilinearly between cell centres;
// a cell of intensity I radiates L = I / s² (s its edge), and the irradiance is the SH product of L
// with the clamped cosine about −n (light travelling towards the surface). The finest cascade that
// holds the point with a margin of a cell answers, blended into the next coarser over BLEND_CELLS
// cells towards its border; the coarsest (the whole scene) answers the rest.

@group(2) @binding(5) var<storage, read_write> accumulated: array<vec4f>;
@group(2) @binding(9) var direct: texture_2d<f32>;
@group(2) @binding(10) var output: texture_storage_2d<rgba32float, write>;

fn sample_light(cascade: u32, g: vec3f) -> CellLight {
    let u = clamp(g - 0.5, vec3f(0.0), vec3f(f32(GRID - 1u)));
    let base = min(floor(u), vec3f(f32(GRID - 2u)));
    let f = u - base;
    let b = vec3u(base);
    var c = CellLight(vec4f(0.0), vec4f(0.0), vec4f(0.0));
    for (var k = 0u; k < 8u; k++) {
        let corner = vec3u(k & 1u, (k >> 1u) & 1u, k >> 2u);
        let w = select(1.0 - f, f, corner == vec3u(1u));
        let weight = w.x * w.y * w.z;
        let i = cell_index(cascade, b + corner);
        c.r += accumulated[3u * i] * weight;
        c.g += accumulated[3u * i + 1u] * weight;
        c.b += accumulated[3u * i + 2u] * weight;
    }
    return c;
}

fn volume_irradiance(cascade: u32, g: vec3f, n: vec3f) -> vec3f {
    let s = cell_size(cascade);
    let lobe = sh4_cosine_lobe(-n) / (s * s);
    let c = sample_light(cascade, g);
    return max(vec3f(dot(c.r, lobe), dot(c.g, lobe), dot(c.b, lobe)), vec3f(0.0));
}

fn lpv_irradiance(p: vec3f, geometric_normal: vec3f, n: vec3f) -> vec3f {
    var e = vec3f(0.0);
    var remaining = 1.0;
    for (var k = 0u; k < lpv.cascade_count; k++) {
        let g = grid_position(k, p + 0.5 * cell_size(k) * geometric_normal);
        var w = 1.0;
        if k + 1u < lpv.cascade_count {
            let margin = min(min(g.x, min(g.y, g.z)), f32(GRID) - max(g.x, max(g.y, g.z)));
            w = saturate((margin - 1.0) / BLEND_CELLS);
        }
        if w > 0.0 {
            e += remaining * w * volume_irradiance(k, g, n);
            remaining *= 1.0 - w;
        }
        if remaining <= 0.0 {
            break;
        }
    }
    return e;
}

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if any(id.xy >= frame.size) {
        return;
    }
    var radiance = textureLoad(direct, id.xy, 0).rgb;
    let s = load_gsurface(id.xy);
    if s.valid {
        let diffuse = brdf_lobe_weights(s.material, dot(s.normal, s.view)).diffuse;
        radiance += diffuse * INV_PI * lpv_irradiance(s.position, s.geometric_normal, s.normal);
    }
    textureStore(output, id.xy, vec4f(radiance, 1.0));
}
