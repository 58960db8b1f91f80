// Conservative voxelisation (`voxelization=conservative`; prepended: volume.wgsl with CONSERVATIVE,
// voxelize.wgsl). The column rays give a surface the voxels it crosses at their columns' centres; a
// triangle that crosses a voxel elsewhere (smaller than a voxel, a sliver between column centres, a
// slope that crosses two voxels of one column) leaves that voxel empty, and light leaks through it.
// Here every triangle claims each empty voxel its area overlaps (separating-axis test against the
// voxel's box), then each claimed voxel takes the surface of its claiming triangle nearest its centre.
//
// A claim is one atomic max into the voxel's normal word, which is still 0 in an empty voxel: the
// claim's top byte ranks triangles by how near their planes pass to the voxel's centre, its low
// CLAIM_INDEX_BITS name the triangle (+1). The nearest triangle wins, ties go to the higher index, in whatever
// order the threads run, so the result is the same on every run and device.
//
// Work is balanced within a workgroup: its CLAIM_GROUP triangles' columns (voxel columns along each triangle's
// dominant axis, over its box) are numbered by a prefix sum and shared out over its threads, so a
// triangle across the whole level does not keep one thread busy while the others idle. A column holds
// at most three voxels of the triangle's plane (the dominant axis bounds its slope by 1 per axis).

// CLAIM_GROUP (triangles per workgroup) and CLAIM_INDEX_BITS (bits of a claim naming its triangle) come
// from vxgi/mod.rs.
#import common/indirect.wgsl

const CLAIM_INDEX_MASK: u32 = (1u << CLAIM_INDEX_BITS) - 1u;
// Voxel boxes are shrunk by this (voxels) on every side: a surface on a voxel face (moved behind it by
// FACE_TIE, as the column rays move their hits) or an edge along one does not claim the voxel on the
// other side. Larger than the rounding of lattice positions (below 1e-4 voxels for lattices up to
// 4096 voxels), smaller than FACE_TIE.
const CLAIM_SHRINK: f32 = 2.5e-4;
// Margin (voxels) of a column's range of voxels, against rounding of the plane's extent in it (the
// overlap test decides).
const COLUMN_PAD: f32 = 1e-3;
// Farthest a plane that overlaps a voxel passes from its centre: half its diagonal.
const HALF_DIAGONAL: f32 = 0.8660254;

// A triangle of the workgroup, in lattice units of the level, moved against its authored normal by
// FACE_TIE.
struct ClaimTriangle {
    a: vec3f,
    // Dominant axis of its normal: its columns run along it.
    axis: u32,
    b: vec3f,
    index: u32,
    c: vec3f,
    // Lattice voxels [lo, hi) of its box within the dispatch's box (lo = hi when it has none).
    lo: vec3i,
    hi: vec3i,
}

// Bricks of 4³ voxels of the level that hold claims: a bit each, and the list of those whose bit a
// claim set first. The resolve pass runs a workgroup per listed brick (an indirect dispatch) rather
// than a thread per voxel of the level: most of a level is empty and holds no claim, and reading its
// voxel words costs more than the claims themselves (lavapipe: 150-200 ms at 128³).
// CLAIM_BRICK (the bricks' edge in voxels) comes from vxgi/mod.rs.
const BRICKS: u32 = GRID / CLAIM_BRICK;

struct ClaimedBricks {
    count: atomic<u32>,
    bricks: array<u32>,
}

@group(2) @binding(10) var<storage, read_write> brick_bits: array<atomic<u32>>;
@group(2) @binding(11) var<storage, read_write> claimed: ClaimedBricks;
// The resolve dispatch's workgroup counts, written by resolve_arguments (bound there only: the resolve
// dispatch reads them as its indirect arguments).
@group(3) @binding(0) var<storage, read_write> resolve_args: array<u32, 3>;

var<workgroup> claim_triangles: array<ClaimTriangle, CLAIM_GROUP>;
// Inclusive prefix sums of the triangles' column counts.
var<workgroup> claim_ends: array<u32, CLAIM_GROUP>;

fn claim_triangle(t: u32, level: u32) -> ClaimTriangle {
    var ct: ClaimTriangle;
    ct.index = t;
    if t >= scene_info.triangle_count {
        return ct;
    }
    let v = triangle_vertices(t);
    let a = lattice_position(level, v[0].position);
    let b = lattice_position(level, v[1].position);
    let c = lattice_position(level, v[2].position);
    let n = cross(b - a, c - a);
    // Degenerate triangles cover nothing (the column rays never meet them either).
    if !(dot(n, n) > 0.0) {
        return ct;
    }
    let authored = vertex_normal(v[0]) + vertex_normal(v[1]) + vertex_normal(v[2]);
    let back = normalize(n) * select(FACE_TIE, -FACE_TIE, dot(n, authored) < 0.0);
    ct.a = a - back;
    ct.b = b - back;
    ct.c = c - back;
    let m = abs(n);
    ct.axis = select(select(2u, 1u, m.y >= m.z), 0u, m.x >= m.y && m.x >= m.z);
    let corner = volume.corners[level].xyz;
    let box = dispatch_box();
    let lo = max(vec3i(floor(min(ct.a, min(ct.b, ct.c)))), corner + box.lo.xyz);
    let hi = min(vec3i(floor(max(ct.a, max(ct.b, ct.c)))) + 1, corner + box.hi.xyz);
    if all(hi > lo) {
        ct.lo = lo;
        ct.hi = hi;
    }
    return ct;
}

// Whether triangle (a, b, c) with normal n overlaps the cube about `centre` with half-edge h: no
// separating axis among the cube's three, the normal, and the nine products of an edge with an axis.
fn triangle_overlaps_cube(a0: vec3f, b0: vec3f, c0: vec3f, n: vec3f, centre: vec3f, h: f32) -> bool {
    let a = a0 - centre;
    let b = b0 - centre;
    let c = c0 - centre;
    if any(min(a, min(b, c)) > vec3f(h)) || any(max(a, max(b, c)) < vec3f(-h)) {
        return false;
    }
    if abs(dot(n, a)) > h * dot(abs(n), vec3f(1.0)) {
        return false;
    }
    let edges = array<vec3f, 3>(b - a, c - b, a - c);
    for (var e = 0u; e < 3u; e++) {
        for (var k = 0u; k < 3u; k++) {
            var unit = vec3f(0.0);
            unit[k] = 1.0;
            let axis = cross(unit, edges[e]);
            let p = vec3f(dot(axis, a), dot(axis, b), dot(axis, c));
            let r = h * dot(abs(axis), vec3f(1.0));
            if min(p.x, min(p.y, p.z)) > r || max(p.x, max(p.y, p.z)) < -r {
                return false;
            }
        }
    }
    return true;
}

// Claims the empty voxels that column `w` of `ct` overlaps.
fn claim_column(ct: ClaimTriangle, w: u32, level: u32) {
    let ax = ct.axis;
    let u = (ax + 1u) % 3u;
    let v = (ax + 2u) % 3u;
    let columns_u = u32(ct.hi[u] - ct.lo[u]);
    var cell = ct.lo;
    cell[u] += i32(w % columns_u);
    cell[v] += i32(w / columns_u);
    let n = cross(ct.b - ct.a, ct.c - ct.a);
    // The plane's extent along the axis over the column's square.
    let base = (dot(n, ct.a) - n[u] * f32(cell[u]) - n[v] * f32(cell[v])) / n[ax];
    let su = -n[u] / n[ax];
    let sv = -n[v] / n[ax];
    let low = base + min(su, 0.0) + min(sv, 0.0);
    let high = base + max(su, 0.0) + max(sv, 0.0);
    let first = max(i32(floor(low - COLUMN_PAD)), ct.lo[ax]);
    let last = min(i32(floor(high + COLUMN_PAD)), ct.hi[ax] - 1);
    let unit_normal = normalize(n);
    let corner = volume.corners[level].xyz;
    for (var z = first; z <= last; z++) {
        cell[ax] = z;
        // Most voxels a surface crosses hold it already: their test is skipped.
        let texel = clip_texel(level, vec3u(cell - corner));
        if voxel_occupied(texel) {
            continue;
        }
        let centre = vec3f(cell) + 0.5;
        if !triangle_overlaps_cube(ct.a, ct.b, ct.c, n, centre, 0.5 - CLAIM_SHRINK) {
            continue;
        }
        let distance = abs(dot(unit_normal, centre - ct.a));
        let rank = u32(round(255.0 * (1.0 - saturate(distance / HALF_DIAGONAL))));
        textureAtomicMax(voxel_normal, texel, (rank << CLAIM_INDEX_BITS) | (ct.index + 1u));
        let brick = vec3u(cell - corner) / CLAIM_BRICK;
        let b = brick.x + BRICKS * (brick.y + BRICKS * brick.z);
        let bit = 1u << (b % 32u);
        if (atomicOr(&brick_bits[b / 32u], bit) & bit) == 0u {
            claimed.bricks[atomicAdd(&claimed.count, 1u)] = b;
        }
    }
}

// One workgroup per CLAIM_GROUP triangles (x and y: a scene may need more than 65 535) and slice of their
// columns (z: few triangles, as in a room of large walls, would otherwise leave a handful of
// workgroups all the work), over the dispatch's box of level `dispatch_slot.clip`.
@compute @workgroup_size(CLAIM_GROUP)
fn claim_voxels(
    @builtin(workgroup_id) group: vec3u,
    @builtin(num_workgroups) groups: vec3u,
    @builtin(local_invocation_index) li: u32,
) {
    let level = dispatch_slot.clip;
    let ct = claim_triangle((group.x + group.y * groups.x) * CLAIM_GROUP + li, level);
    claim_triangles[li] = ct;
    let extent = ct.hi - ct.lo;
    claim_ends[li] = u32(extent[(ct.axis + 1u) % 3u] * extent[(ct.axis + 2u) % 3u]);
    for (var d = 1u; d < CLAIM_GROUP; d *= 2u) {
        workgroupBarrier();
        var add = 0u;
        if li >= d {
            add = claim_ends[li - d];
        }
        workgroupBarrier();
        claim_ends[li] += add;
    }
    let total = workgroupUniformLoad(&claim_ends[CLAIM_GROUP - 1u]);
    // Slice group.z of groups.z: the workgroups of one set of triangles share out its columns.
    for (var item = li + CLAIM_GROUP * group.z; item < total; item += CLAIM_GROUP * groups.z) {
        // The triangle whose columns hold `item`: the first whose inclusive end exceeds it.
        var lo = 0u;
        var hi = CLAIM_GROUP - 1u;
        while lo < hi {
            let mid = (lo + hi) / 2u;
            if claim_ends[mid] > item {
                hi = mid;
            } else {
                lo = mid + 1u;
            }
        }
        let start = select(0u, claim_ends[max(lo, 1u) - 1u], lo > 0u);
        claim_column(claim_triangles[lo], item - start, level);
    }
}

// Barycentrics (of b, of c) of the point of triangle (a, b, c) nearest p: by the Voronoi region of the
// triangle's features that holds p (vertices, edges, face).
fn nearest_on_triangle(p: vec3f, a: vec3f, b: vec3f, c: vec3f) -> vec2f {
    let ab = b - a;
    let ac = c - a;
    let d1 = dot(ab, p - a);
    let d2 = dot(ac, p - a);
    if d1 <= 0.0 && d2 <= 0.0 {
        return vec2f(0.0);
    }
    let d3 = dot(ab, p - b);
    let d4 = dot(ac, p - b);
    if d3 >= 0.0 && d4 <= d3 {
        return vec2f(1.0, 0.0);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return vec2f(d1 / (d1 - d3), 0.0);
    }
    let d5 = dot(ab, p - c);
    let d6 = dot(ac, p - c);
    if d6 >= 0.0 && d5 <= d6 {
        return vec2f(0.0, 1.0);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return vec2f(0.0, d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 >= d3 && d5 >= d6 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return vec2f(1.0 - w, w);
    }
    let scale = 1.0 / (va + vb + vc);
    return vec2f(vb * scale, vc * scale);
}

// One thread: the resolve dispatch's workgroups, one per claimed brick (spread over y past the device's
// limit per dimension).
@compute @workgroup_size(1)
fn resolve_arguments() {
    let groups = indirect_args(atomicLoad(&claimed.count), 1u, MAX_WORKGROUPS);
    resolve_args = array<u32, 3>(groups.x, groups.y, groups.z);
}

// Gives each claimed voxel of the dispatch's box the surface of its claiming triangle nearest its centre
// (its albedo and authored normal, as the column rays would have), unless an alpha mask cuts the
// triangle away there. One workgroup per claimed brick.
@compute @workgroup_size(CLAIM_BRICK, CLAIM_BRICK, CLAIM_BRICK)
fn resolve_claims(
    @builtin(workgroup_id) group: vec3u,
    @builtin(num_workgroups) groups: vec3u,
    @builtin(local_invocation_id) local: vec3u,
) {
    let slot = group.x + group.y * groups.x;
    if slot >= atomicLoad(&claimed.count) {
        return;
    }
    let b = claimed.bricks[slot];
    let voxel = vec3i(vec3u(b % BRICKS, (b / BRICKS) % BRICKS, b / (BRICKS * BRICKS)) * CLAIM_BRICK + local);
    let box = dispatch_box();
    if any(voxel < box.lo.xyz) || any(voxel >= box.hi.xyz) {
        return;
    }
    let level = dispatch_slot.clip;
    let texel = clip_texel(level, vec3u(voxel.xyz));
    // An occupied voxel's normal word is its normal, never a claim.
    if voxel_occupied(texel) {
        return;
    }
    let claim = textureLoad(voxel_normal, texel).x;
    if claim == 0u {
        return;
    }
    let triangle = (claim & CLAIM_INDEX_MASK) - 1u;
    let t = triangle_vertices(triangle);
    let uv = nearest_on_triangle(voxel_centre(level, voxel.xyz), t[0].position, t[1].position, t[2].position);
    if !bvh_alpha_test(triangle, uv.x, uv.y) {
        textureStore(voxel_normal, texel, vec4u(0u));
        return;
    }
    let w = 1.0 - uv.x - uv.y;
    let authored = vertex_normal(t[0]) * w + vertex_normal(t[1]) * uv.x + vertex_normal(t[2]) * uv.y;
    // Seen from the authored side, surface_at's normals are the authored ones.
    let s = surface_at(triangle, uv.x, uv.y, -authored);
    var v: Voxel;
    v.occupied = true;
    v.albedo = brdf_lobe_weights(s.material, 1.0).diffuse;
    v.normal = s.normal;
    v.count = 1u;
    store_voxel(texel, v);
}
