// Discontinuity filter (Keller 1998; Wald et al. 2002): a box of WINDOW_X × WINDOW_Y pixels around each
// pixel — exactly one interleaving cell, so a smooth region sees every VPL set once — that averages only
// the neighbours lying on the same surface as the centre. The data are VEC4S packed half-float vec4s per
// pixel (irradiance, SH coefficients, ...), row-major.
//
// Same surface: the neighbour lies within DEPTH_THRESHOLD × (distance to the camera) of the centre's
// tangent plane (geometric normal, so normal maps do not break it), has the same material when
// MATERIAL_TEST, and a shading normal within acos(NORMAL_COS) of the centre's (NORMAL_COS <= -1 turns
// the normal test off).

#import common/frame.wgsl

@group(2) @binding(0) var<storage, read> filter_input: array<vec2u>;
@group(2) @binding(1) var<storage, read_write> filter_output: array<vec2u>;

struct FilterKey {
    valid: bool,
    position: vec3f,
    geometric_normal: vec3f,
    normal: vec3f,
    distance: f32,
    material: u32,
}

fn filter_key(pixel: vec2i) -> FilterKey {
    var k: FilterKey;
    k.distance = textureLoad(gb_distance, pixel, 0).r;
    k.valid = k.distance > 0.0;
    if !k.valid {
        return k;
    }
    k.position = frame.camera_position + primary_ray_direction(vec2u(pixel)) * k.distance;
    let nrm = textureLoad(gb_normal, pixel, 0);
    k.normal = oct_decode(nrm.xy);
    k.geometric_normal = oct_decode(nrm.zw);
    k.material = textureLoad(gb_material, pixel, 0).x;
    return k;
}

fn same_surface(c: FilterKey, q: FilterKey) -> bool {
    if !q.valid {
        return false;
    }
    if abs(dot(c.geometric_normal, q.position - c.position)) > DEPTH_THRESHOLD * c.distance {
        return false;
    }
    if MATERIAL_TEST && c.material != q.material {
        return false;
    }
    return dot(c.normal, q.normal) >= NORMAL_COS;
}

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let size = frame.size;
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let base = (id.y * size.x + id.x) * VEC4S;
    let centre = filter_key(vec2i(id.xy));
    if !centre.valid {
        for (var k = 0u; k < VEC4S; k++) {
            filter_output[base + k] = filter_input[base + k];
        }
        return;
    }
    var sum: array<vec4f, VEC4S>;
    var count = 0.0;
    let lo = vec2i(id.xy) - vec2i(i32((WINDOW_X - 1u) / 2u), i32((WINDOW_Y - 1u) / 2u));
    for (var dy = 0; dy < i32(WINDOW_Y); dy++) {
        for (var dx = 0; dx < i32(WINDOW_X); dx++) {
            let q = lo + vec2i(dx, dy);
            if any(q < vec2i(0)) || any(q >= vec2i(size)) {
                continue;
            }
            if !same_surface(centre, filter_key(q)) {
                continue;
            }
            let qbase = (u32(q.y) * size.x + u32(q.x)) * VEC4S;
            for (var k = 0u; k < VEC4S; k++) {
                sum[k] += unpack_half4(filter_input[qbase + k]);
            }
            count += 1.0;
        }
    }
    // The centre always passes its own test, so count >= 1.
    for (var k = 0u; k < VEC4S; k++) {
        filter_output[base + k] = pack_half4(sum[k] / count);
    }
}
