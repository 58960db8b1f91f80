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
// The tile with a one-pixel border, for the curvature's neighbours.
const HALO: u32 = 10u;

var<workgroup> halo_key: array<u32, 100>;
var<workgroup> halo_position: array<vec3f, 100>;
var<workgroup> halo_normal: array<vec3f, 100>;
var<workgroup> tile_key: array<u32, 64>;
var<workgroup> tile_rate: array<f32, 64>;
var<workgroup> tile_position: array<vec3f, 64>;
var<workgroup> tile_normal: array<vec3f, 64>;
var<workgroup> tile_job: array<u32, 64>;
// Per square of side 2, 4 and 8 of the tile: the mesh key all its pixels share (0 if they differ or
// are not translucent) and their largest s_p.
var<workgroup> square_key: array<u32, 21>;
var<workgroup> square_rate: array<f32, 21>;
// The angle one pixel spans at the tile's centre (it changes little over a tile).
var<workgroup> tile_pixel_angle: f32;

// The mesh (+1) a pixel shows when its material is translucent, else 0.
fn translucent_key(pixel: vec2u, s: GSurface) -> u32 {
    if !s.valid || !is_translucent(s.material_index) {
        return 0u;
    }
    return textureLoad(gb_instance, vec2i(pixel), 0).r;
}

// |Δn| / |Δp| towards the four neighbours of the same mesh: the surface's curvature (1/m) where the
// G-buffer resolves it.
fn curvature(local: vec2u, s: GSurface, key: u32) -> f32 {
    var k = 0.0;
    let at = (local.y + 1u) * HALO + local.x + 1u;
    for (var i = 0u; i < 4u; i++) {
        let j = array<u32, 4>(at + 1u, at - 1u, at + HALO, at - HALO)[i];
        if halo_key[j] != key {
            continue;
        }
        let dp = length(halo_position[j] - s.position);
        if dp > 0.0 {
            k = max(k, length(halo_normal[j] - s.normal) / dp);
        }
    }
    return k;
}

// s_p of a translucent pixel: samples per pixel its multiply-scattered radiance needs.
fn sampling_rate(local: vec2u, s: GSurface, key: u32) -> f32 {
    let medium = media[s.material_index];
    let cos_o = max(dot(s.normal, s.view), 0.05);
    let theta = acos(saturate(dot(s.normal, s.view)));
    let bin = min(u32(theta / (0.5 * PI) * f32(ANGULAR_BINS)), ANGULAR_BINS - 1u);
    let b_theta = angular_bandwidth[s.material_index * ANGULAR_BINS + bin];
    let k = curvature(local, s, key);
    let b_a = b_theta + s.distance * (medium.spatial_bandwidth + k * b_theta) / cos_o;
    return 2.0 * b_a * tile_pixel_angle;
}

// Square `q` from its four quarters' keys and largest rates.
fn merge_square(q: u32, keys: array<u32, 4>, rates: array<f32, 4>) {
    var key = keys[0];
    for (var i = 1u; i < 4u; i++) {
        key = select(0u, key, keys[i] == key);
    }
    square_key[q] = key;
    square_rate[q] = max(max(rates[0], rates[1]), max(rates[2], rates[3]));
}

@compute @workgroup_size(8, 8)
fn main(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_id) local: vec3u,
    @builtin(workgroup_id) group: vec3u,
) {
    let inside = id.x < frame.size.x && id.y < frame.size.y;
    let me = local.y * SIDE + local.x;
    // The tile and its border into shared memory (100 pixels, two per thread at most).
    if RHO > 0.0 {
        if me == 0u {
            let c = vec2f(group.xy * SIDE) + 0.5 * f32(SIDE);
            let d0 = primary_ray_through(c);
            tile_pixel_angle = max(
                length(primary_ray_through(c + vec2f(1.0, 0.0)) - d0),
                length(primary_ray_through(c + vec2f(0.0, 1.0)) - d0),
            );
        }
        for (var h = me; h < HALO * HALO; h += SIDE * SIDE) {
            let q = vec2i(group.xy * SIDE) - 1 + vec2i(i32(h % HALO), i32(h / HALO));
            var key = 0u;
            if all(q >= vec2i(0)) && all(q < vec2i(frame.size)) {
                let t = load_gsurface(vec2u(q));
                key = translucent_key(vec2u(q), t);
                halo_position[h] = t.position;
                halo_normal[h] = t.normal;
            }
            halo_key[h] = key;
        }
    }
    workgroupBarrier();
    var key = 0u;
    var rate = 0.0;
    var position = vec3f(0.0);
    var normal = vec3f(0.0);
    var material = 0u;
    if inside {
        let s = load_gsurface(id.xy);
        key = translucent_key(id.xy, s);
        material = s.material_index;
        if key != 0u {
            // The rate only shapes clusters: without them (ρ = 0, the single tree) it is not needed.
            if RHO > 0.0 {
                rate = sampling_rate(local.xy, s, key);
            }
            position = s.position;
            normal = s.normal;
            atomicAdd(&counters[COUNTER_PIXELS], 1u);
        }
    }
    tile_key[me] = key;
    tile_rate[me] = rate;
    tile_position[me] = position;
    tile_normal[me] = normal;
    workgroupBarrier();

    // The squares' shared keys and largest rates, bottom-up: 16 of side 2 (indices 0..15), 4 of side 4
    // (16..19), the tile (20).
    if me < 16u {
        let o = (me / 4u) * 2u * SIDE + (me % 4u) * 2u;
        let j = array<u32, 4>(o, o + 1u, o + SIDE, o + SIDE + 1u);
        merge_square(
            me,
            array<u32, 4>(tile_key[j[0]], tile_key[j[1]], tile_key[j[2]], tile_key[j[3]]),
            array<f32, 4>(tile_rate[j[0]], tile_rate[j[1]], tile_rate[j[2]], tile_rate[j[3]]),
        );
    }
    workgroupBarrier();
    if me < 4u {
        let o = (me / 2u) * 8u + (me % 2u) * 2u;
        let j = array<u32, 4>(o, o + 1u, o + 4u, o + 5u);
        merge_square(
            16u + me,
            array<u32, 4>(square_key[j[0]], square_key[j[1]], square_key[j[2]], square_key[j[3]]),
            array<f32, 4>(square_rate[j[0]], square_rate[j[1]], square_rate[j[2]], square_rate[j[3]]),
        );
    }
    workgroupBarrier();
    if me == 0u {
        merge_square(
            20u,
            array<u32, 4>(square_key[16], square_key[17], square_key[18], square_key[19]),
            array<f32, 4>(square_rate[16], square_rate[17], square_rate[18], square_rate[19]),
        );
    }
    workgroupBarrier();

    // The largest aligned square holding this pixel that may be one cluster: all its pixels show this
    // mesh and its side is at most ρ / max s_p. The squares partition the tile.
    var side = 1u;
    if key != 0u && RHO > 0.0 {
        let squares = array<u32, 3>(20u, 16u + (local.y / 4u) * 2u + local.x / 4u, (local.y / 2u) * 4u + local.x / 2u);
        for (var i = 0u; i < 3u; i++) {
            let l = SIDE >> i;
            if square_key[squares[i]] == key && f32(l) * square_rate[squares[i]] <= RHO {
                side = l;
                break;
            }
        }
    }
    let origin = (local.xy / side) * side;
    if key != 0u && all(local.xy == origin) {
        var sum = vec3f(0.0);
        var normals = vec3f(0.0);
        for (var y = 0u; y < side; y++) {
            for (var x = 0u; x < side; x++) {
                sum += tile_position[(origin.y + y) * SIDE + origin.x + x];
                normals += tile_normal[(origin.y + y) * SIDE + origin.x + x];
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
        // (Opposite normals cancel only where a thin sheet shows both faces in one square.)
        let first = tile_normal[origin.y * SIDE + origin.x];
        let mean_normal = select(first, normalize(normals), dot(normals, normals) > 1e-6);
        jobs[job] = ClusterJob(center, radius, mean_normal, key - 1u, material, side * side, 0u, 0u);
        tile_job[me] = job;
    }
    workgroupBarrier();
    if inside {
        pixel_job[id.y * frame.size.x + id.x] = select(NO_JOB, tile_job[origin.y * SIDE + origin.x], key != 0u);
    }
}
