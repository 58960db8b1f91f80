// VPLs for splatting (Dachsbacher & Stamminger 2006), importance-sampled from the RSM by reflected flux:
// `build_cdf` sums the luminance of the pixel lights of all RSM layers into a running sum (one
// workgroup: each thread scans a block, then the block sums are scanned), `make_vpls` inverts it at N
// stratified points. A VPL carries I_p / (N · pmf_p), pmf_p = lum(I_p) / Σ lum, so the VPLs together
// are an unbiased estimate of all pixel lights, and all have the same luminance Σ lum / N.

#import common/color.wgsl

struct VplParams {
    count: u32,
    subsets: u32,
    jitter: f32,
    // Relative splat threshold (see `splat_threshold`).
    threshold: f32,
}

@group(2) @binding(0) var<storage, read_write> cdf: array<f32>;
@group(2) @binding(1) var<storage, read_write> vpls: array<Vpl>;
@group(2) @binding(2) var<uniform> params: VplParams;

const CDF_THREADS: u32 = 256u;
var<workgroup> block_sums: array<f32, CDF_THREADS>;

@compute @workgroup_size(CDF_THREADS)
fn build_cdf(@builtin(local_invocation_index) t: u32) {
    let n = rsm_texel_count();
    let block = (n + CDF_THREADS - 1u) / CDF_THREADS;
    let first = t * block;
    let last = min(first + block, n);
    var sum = 0.0;
    for (var i = first; i < last; i++) {
        let c = texel_of(i);
        let p = load_pixel_light(c.xy, c.z);
        if p.valid {
            sum += max(luminance(p.intensity), 0.0);
        }
        cdf[i] = sum;
    }
    block_sums[t] = sum;
    workgroupBarrier();
    if t == 0u {
        var running = 0.0;
        for (var k = 0u; k < CDF_THREADS; k++) {
            let b = block_sums[k];
            block_sums[k] = running;
            running += b;
        }
    }
    workgroupBarrier();
    let offset = block_sums[t];
    for (var i = first; i < last; i++) {
        cdf[i] += offset;
    }
}

@compute @workgroup_size(64)
fn make_vpls(@builtin(global_invocation_id) id: vec3u) {
    let k = id.x;
    if k >= params.count {
        return;
    }
    var v: Vpl;
    v.subset = k % params.subsets;
    let n = rsm_texel_count();
    let total = select(0.0, cdf[max(n, 1u) - 1u], n > 0u);
    if total <= 0.0 {
        vpls[k] = v;
        return;
    }
    // Stratified: the k-th of N equal slices of the cumulative luminance.
    let u = (f32(k) + params.jitter) / f32(params.count) * total;
    var lo = 0u;
    var hi = n - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if cdf[mid] > u {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    let c = texel_of(lo);
    let p = load_pixel_light(c.xy, c.z);
    let lum = max(luminance(p.intensity), 1e-30);
    v.position = p.position;
    v.normal = p.normal;
    // The VPL stands for `weight` pixel lights: its distance clamp is their joint area.
    let weight = total / (f32(params.count) * lum);
    v.area = p.area * weight;
    v.intensity = p.intensity * weight;
    // Bound lum(I)/(π d²) against threshold × (Σ lum / N) / (π R²), R = scene radius.
    let scene_radius = 0.5 * length(scene_info.bounds_max - scene_info.bounds_min);
    let mean = total / f32(params.count);
    v.radius = scene_radius * sqrt(luminance(v.intensity) / (mean * params.threshold));
    vpls[k] = v;
}
