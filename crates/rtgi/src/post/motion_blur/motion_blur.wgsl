// Non-linear motion blur as a scatter of curves (seed 003, article 1; report
// ../shared/research/003-distribution-effects-ddgi.md §1). Every moving pixel becomes a quadratic
// Bézier through where its surface is on screen at the shutter's opening, now and at its closing; the
// curve is drawn as a line strip of SEGMENTS lines whose fragments add the pixel's radiance, weighted by
// a Gaussian of the curve parameter, into an accumulation target (rgb: Σ w·c, a: Σ w); the resolve
// divides, with a constant weight for the pixel's own radiance:
//   c' = (A + w_b c) / (α + w_b).
// There is no geometry shader in WebGPU, so the vertex shader does the geometry shader's work: vertex
// v of the draw is end v % 2 of segment (v / 2) % SEGMENTS of moving pixel v / (2 SEGMENTS), and
// evaluates that pixel's curve itself (a few matrix products; no buffer of curves at 48 bytes a pixel).
// Only moving pixels are drawn: `count_moving`, `offset_tiles` and `list_moving` list them in pixel
// order within tiles and tiles in order (so the blending order, and the image, is the same on every
// run) and write the indirect draw's vertex count.

#import common/frame.wgsl
#import common/random.wgsl

struct MotionBlurUniforms {
    // View-projections at the shutter's opening (s = 0) and closing (s = 1); s = ½ is the frame's.
    open_view_proj: mat4x4f,
    close_view_proj: mat4x4f,
    // Pixels whose surface moves less than this many pixels towards both ends are not scattered.
    min_motion: f32,
    // σ of the Gaussian weight over the curve parameter s ∈ [0, 1] (centred at ½).
    sigma: f32,
    // w_b: the weight of each pixel's own, unblurred radiance in the resolve.
    background_weight: f32,
    // A curve fragment is hidden where it lies farther than the visible surface by more than this
    // fraction of the surface's view depth.
    depth_tolerance: f32,
}

@group(2) @binding(0) var<uniform> blur: MotionBlurUniforms;
// Per mesh m: [2m] maps its world position now to the shutter's opening, [2m + 1] to its closing.
@group(2) @binding(1) var<storage, read> mesh_shutter: array<mat4x4f>;
// The technique's radiance of the frame: what the curves carry and what the resolve keeps.
@group(2) @binding(2) var radiance: texture_2d<f32>;
// The resolve's inputs and output.
@group(2) @binding(3) var accumulated: texture_2d<f32>;
@group(2) @binding(4) var blurred: texture_storage_2d<rgba32float, write>;
// Per TILE×TILE tile: its moving pixels (count_moving), then the first list index of them (offset_tiles).
@group(2) @binding(5) var<storage, read_write> tile_moving: array<u32>;
// The moving pixels' indices (y · width + x), tile by tile.
@group(2) @binding(6) var<storage, read_write> moving_pixels: array<u32>;
// The curves' indirect draw: vertex count, instance count, first vertex, first instance.
@group(2) @binding(7) var<storage, read_write> draw_args: array<u32, 4>;
// `moving_pixels` again, read-only: vertex shaders may not bind writable storage.
@group(2) @binding(8) var<storage, read> curve_pixels: array<u32>;

// View depth standing in for "infinitely far" (the environment): finite, so that it interpolates.
const FAR = 1e30;

// A point of a pixel's path on screen: framebuffer position (pixels, y down) and view depth.
struct ScreenPoint {
    xy: vec2f,
    depth: f32,
}

// The control points B0, B1, B2 of a pixel's curve, and whether it moves enough to be drawn.
struct Curve {
    b0: ScreenPoint,
    b1: ScreenPoint,
    b2: ScreenPoint,
    moves: bool,
}

// `point` (homogeneous world position, w = 0 for a direction) on screen through `view_proj`; `fallback`
// where it is behind that camera.
fn on_screen(view_proj: mat4x4f, point: vec4f, fallback: ScreenPoint) -> ScreenPoint {
    let clip = view_proj * point;
    if clip.w <= 1e-6 {
        return fallback;
    }
    return ScreenPoint(clip_to_pixel(clip), select(clip.w, FAR, point.w == 0.0));
}

// B0 = p(open), B2 = p(close) and B1 = 2 p(now) − (p(open) + p(close)) / 2, so that B(½) = p(now)
// (the thesis prints B1 = p(0) − (p(−1) − p(1)) / 2, which misses it; see the report's errata).
fn pixel_curve(pixel: vec2u) -> Curve {
    let p = vec2i(pixel);
    let hit = textureLoad(gb_distance, p, 0).r;
    let dir = primary_ray_direction(pixel);
    var now = ScreenPoint(vec2f(pixel) + 0.5 + frame.jitter, FAR);
    var open = vec4f(dir, 0.0);
    var close = open;
    if hit > 0.0 {
        let world = vec4f(frame.camera_position + hit * dir, 1.0);
        now.depth = (frame.view_proj * world).w;
        let mesh = textureLoad(gb_instance, p, 0).r - 1u;
        open = mesh_shutter[2u * mesh] * world;
        close = mesh_shutter[2u * mesh + 1u] * world;
    }
    let b0 = on_screen(blur.open_view_proj, open, now);
    let b2 = on_screen(blur.close_view_proj, close, now);
    let moved = max(distance(b0.xy, now.xy), distance(b2.xy, now.xy));
    let b1 = ScreenPoint(2.0 * now.xy - 0.5 * (b0.xy + b2.xy), 2.0 * now.depth - 0.5 * (b0.depth + b2.depth));
    return Curve(b0, b1, b2, moved >= blur.min_motion);
}

// B(s) = (1 − s)² B0 + 2 (1 − s) s B1 + s² B2 (the thesis's Eq. 37 prints (1 − s²) for the first
// weight).
fn curve_at(c: Curve, s: f32) -> ScreenPoint {
    let w = vec3f((1.0 - s) * (1.0 - s), 2.0 * (1.0 - s) * s, s * s);
    return ScreenPoint(
        w.x * c.b0.xy + w.y * c.b1.xy + w.z * c.b2.xy,
        w.x * c.b0.depth + w.y * c.b1.depth + w.z * c.b2.depth,
    );
}

struct CurveVertex {
    @builtin(position) clip: vec4f,
    // The pixel whose radiance the curve carries (index y · width + x).
    @location(0) @interpolate(flat) source: u32,
    // Curve parameter and view depth: linear in screen space, as the curve was cut into segments there.
    @location(1) @interpolate(linear) s: f32,
    @location(2) @interpolate(linear) depth: f32,
    // What every fragment's weight is multiplied by: 1 (the paper), or with COVERAGE one over the
    // curve's fragment count.
    @location(3) @interpolate(flat) scale: f32,
}

// About how many fragments the curve's lines cover: each line rasterises to about its longer axis's
// extent in pixels.
fn fragments_along(c: Curve) -> f32 {
    var count = 0.0;
    var previous = c.b0.xy;
    for (var k = 1u; k <= SEGMENTS; k++) {
        let next = curve_at(c, f32(k) / f32(SEGMENTS)).xy;
        let d = abs(next - previous);
        count += max(d.x, d.y);
        previous = next;
    }
    return max(count, 1.0);
}

@vertex
fn vs_curve(@builtin(vertex_index) v: u32) -> CurveVertex {
    let per_pixel = 2u * SEGMENTS;
    let source = curve_pixels[v / per_pixel];
    let k = v % per_pixel;
    let s = f32(k / 2u + k % 2u) / f32(SEGMENTS);
    let pixel = vec2u(source % frame.size.x, source / frame.size.x);
    let curve = pixel_curve(pixel);
    if !curve.moves {
        // Outside the clip volume: the segment is dropped before rasterisation.
        return CurveVertex(vec4f(2.0, 2.0, 2.0, 1.0), source, s, FAR, 0.0);
    }
    let b = curve_at(curve, s);
    let size = vec2f(frame.size);
    let ndc = vec2f(b.xy.x / size.x * 2.0 - 1.0, 1.0 - b.xy.y / size.y * 2.0);
    let scale = select(1.0, 1.0 / fragments_along(curve), COVERAGE == 1u);
    return CurveVertex(vec4f(ndc, 0.5, 1.0), source, s, b.depth, scale);
}

@fragment
fn fs_curve(in: CurveVertex) -> @location(0) vec4f {
    // Static occluders hide the curves that pass behind them (the paper's depth test, depth write off).
    let target_pixel = vec2u(in.clip.xy);
    let hit = textureLoad(gb_distance, vec2i(target_pixel), 0).r;
    if hit > 0.0 {
        let surface = vec4f(frame.camera_position + hit * primary_ray_direction(target_pixel), 1.0);
        let depth = (frame.view_proj * surface).w;
        if in.depth > depth * (1.0 + blur.depth_tolerance) {
            discard;
        }
    }
    let source = vec2i(vec2u(in.source % frame.size.x, in.source / frame.size.x));
    let c = textureLoad(radiance, source, 0).rgb;
    let x = (in.s - 0.5) / blur.sigma;
    let w = exp(-0.5 * x * x) * in.scale;
    return vec4f(c * w, w);
}

// Whether the pixel of thread `id` exists and its curve is drawn.
fn pixel_moves(id: vec3u) -> bool {
    return all(id.xy < frame.size) && pixel_curve(id.xy).moves;
}

fn tile_index(workgroup: vec3u) -> u32 {
    return workgroup.y * ((frame.size.x + TILE - 1u) / TILE) + workgroup.x;
}

var<workgroup> tile_count: atomic<u32>;

@compute @workgroup_size(TILE, TILE)
fn count_moving(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) local: u32,
    @builtin(workgroup_id) workgroup: vec3u,
) {
    if local == 0u {
        atomicStore(&tile_count, 0u);
    }
    workgroupBarrier();
    if pixel_moves(id) {
        atomicAdd(&tile_count, 1u);
    }
    workgroupBarrier();
    if local == 0u {
        tile_moving[tile_index(workgroup)] = atomicLoad(&tile_count);
    }
}

const SCAN_THREADS = 256u;
var<workgroup> chunk_sums: array<u32, SCAN_THREADS>;

// One workgroup: every tile's count becomes the list index of its first moving pixel (an exclusive
// prefix sum, each thread over a contiguous chunk of tiles), and the total sizes the draw.
@compute @workgroup_size(SCAN_THREADS)
fn offset_tiles(@builtin(local_invocation_index) local: u32) {
    let tiles = arrayLength(&tile_moving);
    let chunk = (tiles + SCAN_THREADS - 1u) / SCAN_THREADS;
    let first = min(local * chunk, tiles);
    let end = min(first + chunk, tiles);
    var sum = 0u;
    for (var t = first; t < end; t++) {
        sum += tile_moving[t];
    }
    chunk_sums[local] = sum;
    workgroupBarrier();
    var offset = 0u;
    for (var i = 0u; i < local; i++) {
        offset += chunk_sums[i];
    }
    for (var t = first; t < end; t++) {
        let count = tile_moving[t];
        tile_moving[t] = offset;
        offset += count;
    }
    if local == SCAN_THREADS - 1u {
        draw_args[0] = offset * 2u * SEGMENTS;
        draw_args[1] = 1u;
        draw_args[2] = 0u;
        draw_args[3] = 0u;
    }
}

var<workgroup> tile_flags: array<u32, TILE * TILE>;

@compute @workgroup_size(TILE, TILE)
fn list_moving(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) local: u32,
    @builtin(workgroup_id) workgroup: vec3u,
) {
    let moves = pixel_moves(id);
    tile_flags[local] = u32(moves);
    workgroupBarrier();
    if !moves {
        return;
    }
    var before = 0u;
    for (var i = 0u; i < local; i++) {
        before += tile_flags[i];
    }
    moving_pixels[tile_moving[tile_index(workgroup)] + before] = id.y * frame.size.x + id.x;
}

// The CPU/GPU twin test's window into `pixel_curve`: every pixel's control points (tests only).
@group(2) @binding(9) var<storage, read_write> exported_curves: array<vec4f>;

@compute @workgroup_size(TILE, TILE)
fn export_curves(@builtin(global_invocation_id) id: vec3u) {
    if any(id.xy >= frame.size) {
        return;
    }
    let c = pixel_curve(id.xy);
    let i = 2u * (id.y * frame.size.x + id.x);
    exported_curves[i] = vec4f(c.b0.xy, c.b2.xy);
    exported_curves[i + 1u] = vec4f(c.b1.xy, c.b0.depth, select(0.0, 1.0, c.moves));
}

@compute @workgroup_size(TILE, TILE)
fn resolve(@builtin(global_invocation_id) id: vec3u) {
    if any(id.xy >= frame.size) {
        return;
    }
    let p = vec2i(id.xy);
    let a = textureLoad(accumulated, p, 0);
    let c = textureLoad(radiance, p, 0).rgb;
    let wb = blur.background_weight;
    // Where no curve arrived the pixel keeps its radiance exactly (w_b c / w_b need not round to c).
    textureStore(blurred, p, vec4f(select((a.rgb + wb * c) / (a.a + wb), c, a.a == 0.0), 1.0));
}

// ---------------------------------------------------------------------------------------------------
// The linear baseline the paper compares with: a gather along one straight motion vector per pixel,
// McGuire et al. 2012 ("A Reconstruction Filter for Plausible Motion Blur"): per-pixel half-shutter
// velocity v = (B2 − B0) / 2 clamped to MAX_RADIUS pixels, the largest velocity of every MAX_RADIUS²
// tile and of its 3×3 neighbourhood, then SAMPLES taps along the neighbourhood's velocity, each weighted
// by soft depth comparisons, cones (the tap or the pixel blurring over the other) and cylinders (both
// moving alike).

// Per pixel: velocity (xy, pixels over half the shutter) and view depth (z).
@group(2) @binding(10) var velocity_out: texture_storage_2d<rgba32float, write>;
@group(2) @binding(11) var velocity: texture_2d<f32>;
// Per MAX_RADIUS² tile: its largest velocity, then the largest of its 3×3 neighbourhood.
@group(2) @binding(12) var<storage, read_write> tile_max: array<vec2f>;
@group(2) @binding(13) var<storage, read_write> neighbour_max: array<vec2f>;

fn clamp_length(v: vec2f, limit: f32) -> vec2f {
    let l = length(v);
    return select(v, v * (limit / l), l > limit);
}

@compute @workgroup_size(TILE, TILE)
fn linear_velocity(@builtin(global_invocation_id) id: vec3u) {
    if any(id.xy >= frame.size) {
        return;
    }
    let c = pixel_curve(id.xy);
    let v = select(vec2f(0.0), clamp_length(0.5 * (c.b2.xy - c.b0.xy), f32(MAX_RADIUS)), c.moves);
    // The frame's depth: B1's is 2 d(now) − (d(open) + d(close)) / 2, so d(now) is their mean.
    let depth = 0.5 * c.b1.depth + 0.25 * (c.b0.depth + c.b2.depth);
    textureStore(velocity_out, id.xy, vec4f(v, depth, 0.0));
}

fn tiles() -> vec2u {
    return (frame.size + MAX_RADIUS - 1u) / MAX_RADIUS;
}

fn longer(a: vec2f, b: vec2f) -> vec2f {
    return select(a, b, dot(b, b) > dot(a, a));
}

@compute @workgroup_size(TILE, TILE)
fn linear_tile_max(@builtin(global_invocation_id) id: vec3u) {
    let n = tiles();
    if any(id.xy >= n) {
        return;
    }
    var best = vec2f(0.0);
    let first = id.xy * MAX_RADIUS;
    let end = min(first + MAX_RADIUS, frame.size);
    for (var y = first.y; y < end.y; y++) {
        for (var x = first.x; x < end.x; x++) {
            best = longer(best, textureLoad(velocity, vec2u(x, y), 0).xy);
        }
    }
    tile_max[id.y * n.x + id.x] = best;
}

@compute @workgroup_size(TILE, TILE)
fn linear_neighbour_max(@builtin(global_invocation_id) id: vec3u) {
    let n = tiles();
    if any(id.xy >= n) {
        return;
    }
    var best = vec2f(0.0);
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let t = vec2i(id.xy) + vec2i(dx, dy);
            if all(t >= vec2i(0)) && all(vec2u(t) < n) {
                best = longer(best, tile_max[u32(t.y) * n.x + u32(t.x)]);
            }
        }
    }
    neighbour_max[id.y * n.x + id.x] = best;
}

// How far a depth may lie behind another and still count as level with it (view-depth fraction).
const SOFT_DEPTH = 0.01;

// 1 where `a` is nearer than `b`, falling to 0 over SOFT_DEPTH of their depth.
fn nearer(a: f32, b: f32) -> f32 {
    return clamp(1.0 - (a - b) / (SOFT_DEPTH * min(a, b)), 0.0, 1.0);
}

fn cone(distance_xy: f32, speed: f32) -> f32 {
    return clamp(1.0 - distance_xy / max(speed, 1e-3), 0.0, 1.0);
}

fn cylinder(distance_xy: f32, speed: f32) -> f32 {
    return 1.0 - smoothstep(0.95 * speed, 1.05 * speed, distance_xy);
}

@compute @workgroup_size(TILE, TILE)
fn linear_gather(@builtin(global_invocation_id) id: vec3u) {
    if any(id.xy >= frame.size) {
        return;
    }
    let p = vec2i(id.xy);
    let centre = textureLoad(radiance, p, 0).rgb;
    let t = id.xy / MAX_RADIUS;
    let vn = neighbour_max[t.y * tiles().x + t.x];
    if length(vn) < 0.5 {
        textureStore(blurred, p, vec4f(centre, 1.0));
        return;
    }
    let vx = textureLoad(velocity, p, 0);
    let speed_x = max(length(vx.xy), 0.5);
    var weight = 1.0 / speed_x;
    var sum = centre * weight;
    // A fixed per-pixel offset of the taps (the paper's jitter), the same every frame.
    let jitter = u32_to_unit(hash2(id.x, id.y)) - 0.5;
    let size = vec2i(frame.size);
    for (var i = 0u; i < SAMPLES; i++) {
        let s = mix(-1.0, 1.0, (f32(i) + jitter + 1.0) / f32(SAMPLES + 1u));
        let q = clamp(vec2i(round(vec2f(p) + vn * s)), vec2i(0), size - 1);
        if all(q == p) {
            continue;
        }
        let vy = textureLoad(velocity, q, 0);
        let d = length(vec2f(q - p));
        let speed_y = max(length(vy.xy), 0.5);
        let a = nearer(vy.z, vx.z) * cone(d, speed_y) + nearer(vx.z, vy.z) * cone(d, speed_x)
            + 2.0 * cylinder(d, speed_y) * cylinder(d, speed_x);
        weight += a;
        sum += a * textureLoad(radiance, q, 0).rgb;
    }
    textureStore(blurred, p, vec4f(sum / weight, 1.0));
}
