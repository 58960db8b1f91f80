// Pixel clusters: the screen-space half of the dual hierarchy. The thesis clusters pixels in a
// kd-tree and shades a cluster once when it is smaller than the filter extent P = ρ / max s_p that its
// frequency analysis predicts; here the pixel hierarchy is the quadtree of each 8×8 tile (squares of
// 8², 4², 2² and 1 pixel), and a square is one cluster when all its pixels show the same translucent
// mesh and its side is at most P. Each cluster becomes one job: one tree traversal from its mean
// position, whose result all its pixels share.
//
// s_p (Eqs. 57–59): the outgoing radiance's bandwidth B_s (space) and B_θ(θ_o) (angle, from the
// Fresnel transmittance) carried to the camera: B_a = B_θ + d (B_s + k B_θ) / cos θ_o, and
// s_p = 2 B_a · (angle of a pixel). The curvature k is estimated from the G-buffer's neighbours.

#import common/frame.wgsl

const SIDE: u32 = 8u;

var<workgroup> tile_key: array<u32, 64>;
var<workgroup> tile_rate: array<f32, 64>;
var<workgroup> tile_position: array<vec3f, 64>;
var<workgroup> tile_job: array<u32, 64>;

// The mesh (+1) a pixel shows when its material is translucent, else 0.
fn translucent_key(pixel: vec2u, s: GSurface) -> u32 {
    if !s.valid || media[s.material_index].translucent == 0u {
        return 0u;
    }
    return textureLoad(gb_instance, vec2i(pixel), 0).r;
}

// |Δn| / |Δp| towards the neighbours of the same mesh: the surface's curvature (1/m) where the
// G-buffer resolves it.
fn curvature(pixel: vec2u, s: GSurface, key: u32) -> f32 {
    var k = 0.0;
    let offsets = array<vec2i, 4>(vec2i(1, 0), vec2i(-1, 0), vec2i(0, 1), vec2i(0, -1));
    for (var i = 0; i < 4; i++) {
        let q = vec2i(pixel) + offsets[i];
        if any(q < vec2i(0)) || any(q >= vec2i(frame.size)) {
            continue;
        }
        let t = load_gsurface(vec2u(q));
        if translucent_key(vec2u(q), t) != key {
            continue;
        }
        let dp = length(t.position - s.position);
        if dp > 0.0 {
            k = max(k, length(t.normal - s.normal) / dp);
        }
    }
    return k;
}

// s_p of a translucent pixel: samples per pixel its multiply-scattered radiance needs.
fn sampling_rate(pixel: vec2u, s: GSurface, key: u32) -> f32 {
    let medium = media[s.material_index];
    let cos_o = max(dot(s.normal, s.view), 0.05);
    let theta = acos(saturate(dot(s.normal, s.view)));
    let bin = min(u32(theta / (0.5 * PI) * f32(ANGULAR_BINS)), ANGULAR_BINS - 1u);
    let b_theta = angular_bandwidth[s.material_index * ANGULAR_BINS + bin];
    let k = curvature(pixel, s, key);
    let b_a = b_theta + s.distance * (medium.spatial_bandwidth + k * b_theta) / cos_o;
    let c = vec2f(pixel) + 0.5;
    let d0 = primary_ray_through(c);
    let pixel_angle = max(
        length(primary_ray_through(c + vec2f(1.0, 0.0)) - d0),
        length(primary_ray_through(c + vec2f(0.0, 1.0)) - d0),
    );
    return 2.0 * b_a * pixel_angle;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(local_invocation_id) local: vec3u) {
    let inside = id.x < frame.size.x && id.y < frame.size.y;
    let me = local.y * SIDE + local.x;
    var key = 0u;
    var rate = 0.0;
    var position = vec3f(0.0);
    if inside {
        let s = load_gsurface(id.xy);
        key = translucent_key(id.xy, s);
        if key != 0u {
            // The rate only shapes clusters: without them (ρ = 0, the single tree) it is not needed.
            if RHO > 0.0 {
                rate = sampling_rate(id.xy, s, key);
            }
            position = s.position;
            atomicAdd(&counters[COUNTER_PIXELS], 1u);
        }
    }
    tile_key[me] = key;
    tile_rate[me] = rate;
    tile_position[me] = position;
    workgroupBarrier();

    // The largest aligned square holding this pixel that may be one cluster. Every pixel of a square
    // reads the same values, so all of them agree and the squares partition the tile.
    var side = 1u;
    if key != 0u && RHO > 0.0 {
        for (var l = SIDE; l > 1u; l /= 2u) {
            let origin = (local.xy / l) * l;
            var uniform_square = true;
            var max_rate = 0.0;
            for (var y = 0u; y < l; y++) {
                for (var x = 0u; x < l; x++) {
                    let j = (origin.y + y) * SIDE + origin.x + x;
                    uniform_square = uniform_square && tile_key[j] == key;
                    max_rate = max(max_rate, tile_rate[j]);
                }
            }
            if uniform_square && f32(l) * max_rate <= RHO {
                side = l;
                break;
            }
        }
    }
    let origin = (local.xy / side) * side;
    if key != 0u && all(local.xy == origin) {
        var sum = vec3f(0.0);
        for (var y = 0u; y < side; y++) {
            for (var x = 0u; x < side; x++) {
                sum += tile_position[(origin.y + y) * SIDE + origin.x + x];
            }
        }
        let center = sum / f32(side * side);
        var radius = 0.0;
        for (var y = 0u; y < side; y++) {
            for (var x = 0u; x < side; x++) {
                radius = max(radius, length(tile_position[(origin.y + y) * SIDE + origin.x + x] - center));
            }
        }
        let job = atomicAdd(&counters[COUNTER_JOBS], 1u);
        let s = load_gsurface(id.xy);
        jobs[job] = ClusterJob(center, radius, key - 1u, s.material_index, side * side, 0u);
        tile_job[me] = job;
    }
    workgroupBarrier();
    if inside {
        pixel_job[id.y * frame.size.x + id.x] = select(NO_JOB, tile_job[origin.y * SIDE + origin.x], key != 0u);
    }
}
