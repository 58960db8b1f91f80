// Ray queries against the scene BVH built by `gpu/bvh` (binned SAH collapsed into 4-wide nodes with
// byte-quantised child boxes, see gpu/bvh/wide.rs; triangles in BVH order). The CPU traversal in `gpu/bvh/traverse.rs` mirrors this file operation for operation; keep
// them in step.
//
// CONTRACT WITH THE INCLUDING SHADER. This module declares no bindings (each technique picks its own
// group and binding numbers); the includer must declare, with exactly these names:
//
//   @group(G) @binding(B)     var bvh_nodes: texture_storage_2d<rgba32uint, read>;   // GpuBvh::nodes
//   @group(G) @binding(B + 1) var bvh_tris: texture_storage_2d<rgba32uint, read>;    // GpuBvh::triangles
//   @group(G) @binding(C)     var<storage, read> bvh_instances: array<BvhInstance>;  // GpuBvh::instances
//   fn bvh_alpha_test(triangle: u32, u: f32, v: f32) -> bool
//
// Nodes and triangles are linear textures of 16-byte texels (common/linear_texture.wgsl): 4 per node
// (the BvhNode struct's bytes), 3 per triangle: v0.xyz + original triangle index (u32 bits), v1.xyz +
// flags (u32 bits, bit 0 = alpha-tested), v2.xyz + padding. Read-only storage textures rather than
// storage buffers or sampled textures because the traversal loads inside its loop
// (gpu/linear_texture.rs says why that matters). bvh_alpha_test is called only for hits on triangles
// flagged alpha-tested, with the original (global) triangle index and the barycentrics of v1 and v2;
// it returns true for an opaque hit. Shaders without alpha-masked materials can simply
// `return true;`.
//
// Two levels: a child reference with count == BVH_INSTANCE_LEAF is instance `first` (a rigid moving
// mesh, see gpu/bvh/instances.rs). The ray is mapped into the instance's space and the traversal goes on at its
// bottom level's root; hit distances need no conversion (the map is affine and the direction keeps its
// length in units of t). Stack entries pushed before the instance was entered are in world space, so
// popping below that depth restores the world ray. Only one level of instancing exists.
//
// BVH_INSTANCES (a bool the includer may define; shaders::compose defines it true otherwise): false
// compiles the single-level traversal alone, for scenes without instances (GpuScene::bvh_defines).
// The instance branches cost a quarter of the closest-hit throughput on lavapipe even when no lane
// takes them. BVH_ALPHA_TESTS likewise (defined true unless the includer says otherwise): false
// compiles the traversal without the alpha test, for scenes without alpha-tested triangles. Lavapipe
// runs the body of a branch on per-lane values with every lane masked off rather than skip it, so
// the whole alpha test (vertex and material loads, a texture sample) ran for every triangle tested
// although atrium has no alpha-tested triangle: without it the path tracer's frame takes 0.62x the
// time on atrium:detail=5 at 256² (best of 4 alternating runs, 583 against 935 ms).
//
// Queries: hits are accepted for tmin < t < tmax, t in units of ray.dir (which need not be
// normalised). A miss is `hit.triangle == BVH_NO_HIT`, with hit.t = FLT_MAX.

#import common/math.wgsl
#import common/linear_texture.wgsl

// Twice the binary tree's depth limit, which bounds the deferred children of a path (BVH_STACK_SIZE
// in gpu/bvh/mod.rs, which explains; a test checks they agree).
const BVH_STACK_SIZE: u32 = 64u;
const BVH_NO_HIT: u32 = 0xffffffffu;
const BVH_FLAG_ALPHA_TESTED: u32 = 1u;
// bvh_triangle's w for a candidate hit on an opaque and an alpha-tested triangle (0: no hit).
const BVH_HIT_OPAQUE: f32 = 1.0;
const BVH_HIT_ALPHA_TESTED: f32 = 2.0;
const BVH_INSTANCE_LEAF: u32 = 7u;
const BVH_EMPTY_CHILD: u32 = 0xffffffffu;
const BVH_NODE_TEXELS: u32 = 4u;
const BVH_TRIANGLE_TEXELS: u32 = 3u;
// Box exit distances are scaled by 1 + 16u (u = 2^-24) so rounding never culls a box the ray touches,
// e.g. one whose face holds a triangle (Ize 2013, "Robust BVH Ray Traversal", whose 1 + 2γ₃ assumes a
// correctly rounded 1/dir). WGSL only promises 2.5 ulp (≤ 5u) for a division, so a slab distance
// (b − o)·(1/d) is within 7u of exact, the entry may come out 7u high and the exit 7u low, and
// (1 + 7u) / ((1 − 7u)(1 − u)) < 1 + 16u covers both plus the rounding of the product below.
const BVH_BOX_EXIT_SCALE: f32 = 1.000001;
// Direction components below this are replaced by ±this before inverting: no inf × 0 = NaN in slabs.
const BVH_MIN_DIR_COMPONENT: f32 = 1e-20;

struct Ray {
    origin: vec3f,
    dir: vec3f,
}

// origin + t·dir = (1 − u − v)·v0 + u·v1 + v·v2. Miss: triangle == BVH_NO_HIT, t == FLT_MAX.
struct Hit {
    t: f32,
    triangle: u32,
    u: f32,
    v: f32,
}

// Up to four children. A child reference is (first << 3) | count: count == 0 node `first`, 1..4 the
// triangles [first, first + count) in BVH order, BVH_INSTANCE_LEAF instance `first`; BVH_EMPTY_CHILD
// an empty slot. Child j's box is origin + q · 2^(e − 127) per axis, q the byte j of lo (min) and hi
// (max), e the axis's byte of exponents.
struct BvhNode {
    origin: vec3f,
    exponents: u32,
    children: vec4u,
    lo: vec3u,
    spare: u32,
    hi: vec3u,
}

// world_to_object rows: object = (dot(row0, p), dot(row1, p), dot(row2, p)), p = (world, 1 or 0),
// evaluated by bvh_affine.
struct BvhInstance {
    row0: vec4f,
    row1: vec4f,
    row2: vec4f,
    root: u32,
}

// Element i of the node table and of the triangle table.
#if BVH_TABLES_IN_BUFFERS
fn bvh_node_element(i: u32) -> vec4u {
    return bvh_nodes[i];
}

fn bvh_triangle_element(i: u32) -> vec4u {
    return bvh_tris[i];
}
#else
fn bvh_node_element(i: u32) -> vec4u {
    return textureLoad(bvh_nodes, linear_texel(i));
}

fn bvh_triangle_element(i: u32) -> vec4u {
    return textureLoad(bvh_tris, linear_texel(i));
}
#endif

fn bvh_node(i: u32) -> BvhNode {
    let first = BVH_NODE_TEXELS * i;
    let a = bvh_node_element(first);
    let children = bvh_node_element(first + 1u);
    let lo = bvh_node_element(first + 2u);
    let hi = bvh_node_element(first + 3u);
    return BvhNode(bitcast<vec3f>(a.xyz), a.w, children, lo.xyz, lo.w, hi.xyz);
}

// Element j (0..3) of triangle i (BVH order), as the words it holds.
fn bvh_triangle_words(i: u32, j: u32) -> vec4u {
    return bvh_triangle_element(BVH_TRIANGLE_TEXELS * i + j);
}

// Element j of triangle i as floats (the vertex positions in xyz).
fn bvh_triangle_texel(i: u32, j: u32) -> vec4f {
    return bitcast<vec4f>(bvh_triangle_words(i, j));
}

// The original (scene-order) index of triangle i (BVH order).
fn bvh_original_triangle(i: u32) -> u32 {
    return bvh_triangle_words(i, 0u).w;
}

fn hit_found(hit: Hit) -> bool {
    return hit.triangle != BVH_NO_HIT;
}

// Per-ray constants of the watertight test (Woop, Benthin & Wald 2013). The paper permutes the axes
// (kz = dominant direction axis, kx/ky swapped when d[kz] < 0 to keep the winding) and shears by
// d[kx]/d[kz] and d[ky]/d[kz]. Here x and y are scaled by d[kz] instead (and a power of two), which
// multiplies every edge function by the same positive number: the same signs, t and barycentrics,
// but no division in any hit-or-miss decision. WGSL only promises 2.5 ulp for a division, and with
// one there a GPU rounds a vertex otherwise than the CPU twin and decides differently where rounding
// alone decides (a ray through a silhouette vertex or edge). Only 1/d[kz] (t's scale) and inv_dir
// (box tests, made conservative for it) divide.
struct BvhRay {
    origin: vec3f,
    inv_dir: vec3f,
    // Columns of the map p ↦ (x, y, z) (see bvh_project), applied without dynamic indexing.
    m0: vec3f,
    m1: vec3f,
    m2: vec3f,
}

fn bvh_axis(k: u32) -> vec3f {
    return select(vec3f(0.0), vec3f(1.0), vec3u(k) == vec3u(0u, 1u, 2u));
}

fn bvh_ray(ray: Ray) -> BvhRay {
    let d = ray.dir;
    let a = abs(d);
    var kz = 2u;
    if a.x >= a.y && a.x >= a.z {
        kz = 0u;
    } else if a.y >= a.z {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    // Swapping keeps the winding, so both orientations of a triangle are hit.
    if d[kz] < 0.0 {
        let k = kx;
        kx = ky;
        ky = k;
    }
    // (d[kx], d[ky], d[kz]) times 2^-e for |d[kz]| in [2^e, 2^(e+1)) (exponent bits: 254 − biased
    // exponent), an exact scaling that gives edge functions the paper's magnitude whatever |d| is.
    let s = vec3f(d[kx], d[ky], d[kz]) * bitcast<f32>(0x7f000000u - (bitcast<u32>(d[kz]) & 0x7f800000u));
    // Rows of the map: every product is by 0 or 1, so they are exact however they are contracted.
    let ez = bvh_axis(kz);
    let row_x = s.z * bvh_axis(kx) - s.x * ez;
    let row_y = s.z * bvh_axis(ky) - s.y * ez;
    let m = transpose(mat3x3f(row_x, row_y, (1.0 / d[kz]) * ez));
    let tiny = select(vec3f(BVH_MIN_DIR_COMPONENT), vec3f(-BVH_MIN_DIR_COMPONENT), d < vec3f(0.0));
    let safe = select(d, tiny, a < vec3f(BVH_MIN_DIR_COMPONENT));
    return BvhRay(ray.origin, 1.0 / safe, m[0], m[1], m[2]);
}

// A vertex in the ray's frame: x = s.z·p[kx] − s.x·p[kz], y = s.z·p[ky] − s.y·p[kz], z = p[kz] / d[kz]
// with s the scaled direction (the products by the map's zeros are exact and change nothing). One
// function of the vertex and the ray alone, so a vertex shared by several triangles gets the same
// coordinates, bit for bit, in each of their tests (whatever a compiler makes of it, it makes the
// same of every call). Explicit fma rather than dot(), whose order and contraction are the
// compiler's: a GPU whose fma is fused (and one that splits it) then computes what the CPU twin
// computes, which the GPU tests check bit for bit.
fn bvh_project(v: vec3f, r: BvhRay) -> vec3f {
    let p = v - r.origin;
    return fma(vec3f(p.x), r.m0, fma(vec3f(p.y), r.m1, p.z * r.m2));
}

// Edge functions of the edges p → q, lane by lane: q.x·p.y − q.y·p.x. Watertightness needs the edge
// shared by two triangles, run p → q by one and q → p by the other, to give exactly opposite values,
// or a ray through it can be rejected by both. q.x·p.y − q.y·p.x and p.x·q.y − p.y·q.x are not exact
// negations once a product is fused (fma(q.x, p.y, −q.y·p.x) rounds q.y·p.x, the other p.x·q.y), and
// WGSL leaves contraction to the compiler (NVIDIA's contracts). Nor is an algebraically antisymmetric
// form safe: (a·b − c·d) − (c·d − a·b), with or without explicit fma, comes out of lavapipe as
// ((a·b − c·d) + a·b) − c·d, fma split and the subtraction reassociated (measured: `LavapipePaired`
// in gpu/bvh/tests.rs reproduces its output bit for bit), which is not antisymmetric.
// So both triangles evaluate one expression on the same operands in the same order: the endpoints
// sorted (by x, then y, of bvh_project's coordinates, which are the same bits in both), the product
// difference taken hi.x·lo.y − hi.y·lo.x, and negated by the triangle that runs the edge from hi to
// lo. Whatever a compiler does to that expression (contract either product, split the fma,
// reassociate) it does alike to both evaluations, as long as it compiles one expression into one
// computation: here a single vector expression for all three edges of every triangle. An edge seen
// end-on (p == q: a triangle collapsed by rounding, or an instance scaled to nothing) is 0 outright,
// as the exact value is: with one product fused, x·y − y·x is the product's rounding error, three
// equal such edges look like a hit, and two opposite ones no longer cancel in det.
fn bvh_edges(px: vec3f, py: vec3f, qx: vec3f, qy: vec3f) -> vec3f {
    let same_x = px == qx;
    let swap = (px > qx) | (same_x & (py > qy));
    let lo_x = select(px, qx, swap);
    let lo_y = select(py, qy, swap);
    let hi_x = select(qx, px, swap);
    let hi_y = select(qy, py, swap);
    let e = fma(hi_x, lo_y, -(hi_y * lo_x));
    return select(select(e, -e, swap), vec3f(0.0), same_x & (py == qy));
}

struct BvhInstanceEntry {
    ray: BvhRay,
    // Node reference of the instance's bottom-level root.
    root: u32,
}

// Entering instance `i`: the ray in its space, ready for traversal, and where traversal goes on.
fn bvh_enter_instance(ray: Ray, i: u32) -> BvhInstanceEntry {
    let instance = bvh_instances[i];
    let origin = bvh_affine(instance, ray.origin, 1.0);
    let dir = bvh_affine(instance, ray.dir, 0.0);
    return BvhInstanceEntry(bvh_ray(Ray(origin, dir)), instance.root << 3u);
}

// world_to_object applied to (p, w), as explicit fma in the CPU twin's order (BvhInstance::map_ray)
// rather than dot(), whose order and contraction are the compiler's: the instance-space ray then
// comes out identical on both, and so does every decision made with it.
fn bvh_affine(instance: BvhInstance, p: vec3f, w: f32) -> vec3f {
    let x = vec3f(instance.row0.x, instance.row1.x, instance.row2.x);
    let y = vec3f(instance.row0.y, instance.row1.y, instance.row2.y);
    let z = vec3f(instance.row0.z, instance.row1.z, instance.row2.z);
    let t = vec3f(instance.row0.w, instance.row1.w, instance.row2.w);
    return fma(vec3f(p.x), x, fma(vec3f(p.y), y, fma(vec3f(p.z), z, w * t)));
}

fn bvh_min3(v: vec3f) -> f32 {
    return min(v.x, min(v.y, v.z));
}

// Bytes 0..3 of w as the lanes of a vector. A byte b goes into the mantissa of 2^23 and 2^23 is taken
// away again, both exact: the same floats as an integer conversion, without one (GPUs convert at a
// quarter of their float rate or less, and a node's boxes need 24).
fn bvh_bytes(w: u32) -> vec4f {
    let b = (vec4u(w) >> vec4u(0u, 8u, 16u, 24u)) & vec4u(0xffu);
    return bitcast<vec4f>(b | vec4u(0x4b000000u)) - vec4f(8388608.0);
}

// A node's grid cell size along one axis, 2^(byte − 127).
fn bvh_cell(exponents: u32, axis: u32) -> f32 {
    return bitcast<f32>(((exponents >> (8u * axis)) & 0xffu) << 23u);
}

// Slab distances of the ray to a plane of each child: the plane is origin + q·cell with q·cell
// exact, so fused or not the box is the CPU twin's to the bit (BvhNode::child_box).
fn bvh_slabs(q: u32, cell: f32, origin: f32, ray_origin: f32, inv_dir: f32) -> vec4f {
    return (fma(bvh_bytes(q), vec4f(cell), vec4f(origin)) - ray_origin) * inv_dir;
}

// Entry distances of the ray into the node's four children, FLT_MAX for children it misses within
// [tmin, tmax] and for empty slots. (A real entry distance is at most the box's exit distance,
// finite for any box in a scene.)
fn bvh_children_entry(node: BvhNode, r: BvhRay, tmin: f32, tmax: f32) -> vec4f {
    let x0 = bvh_slabs(node.lo.x, bvh_cell(node.exponents, 0u), node.origin.x, r.origin.x, r.inv_dir.x);
    let x1 = bvh_slabs(node.hi.x, bvh_cell(node.exponents, 0u), node.origin.x, r.origin.x, r.inv_dir.x);
    let y0 = bvh_slabs(node.lo.y, bvh_cell(node.exponents, 1u), node.origin.y, r.origin.y, r.inv_dir.y);
    let y1 = bvh_slabs(node.hi.y, bvh_cell(node.exponents, 1u), node.origin.y, r.origin.y, r.inv_dir.y);
    let z0 = bvh_slabs(node.lo.z, bvh_cell(node.exponents, 2u), node.origin.z, r.origin.z, r.inv_dir.z);
    let z1 = bvh_slabs(node.hi.z, bvh_cell(node.exponents, 2u), node.origin.z, r.origin.z, r.inv_dir.z);
    let near = max(max(min(x0, x1), min(y0, y1)), max(min(z0, z1), vec4f(tmin)));
    let far = min(min(min(max(x0, x1), max(y0, y1)), max(z0, z1)) * BVH_BOX_EXIT_SCALE, vec4f(tmax));
    let hit = (near <= far) & (node.children != vec4u(BVH_EMPTY_CHILD));
    return select(vec4f(FLT_MAX), near, hit);
}

// A node's children ordered by entry distance, nearest first, misses last: a compare-exchange
// network whose equal distances keep their slot order (sort_children in gpu/bvh/traverse.rs, so
// that both visit children, and break ties between equally near hits, alike).
struct BvhChildren {
    t: vec4f,
    refs: vec4u,
}

fn bvh_sort_children(entry: vec4f, children: vec4u) -> BvhChildren {
    var t = entry;
    var c = children;
    // Pairs (0, 1) and (2, 3).
    let a = vec4<bool>(t.y < t.x, t.y < t.x, t.w < t.z, t.w < t.z);
    t = select(t, t.yxwz, a);
    c = select(c, c.yxwz, a);
    // Pairs (0, 2) and (1, 3).
    let b = vec4<bool>(t.z < t.x, t.w < t.y, t.z < t.x, t.w < t.y);
    t = select(t, t.zwxy, b);
    c = select(c, c.zwxy, b);
    // Pair (1, 2).
    let m = t.z < t.y;
    let d = vec4<bool>(false, m, m, false);
    t = select(t, t.xzyw, d);
    c = select(c, c.xzyw, d);
    return BvhChildren(t, c);
}

// Watertight ray–triangle test of triangle `i` (BVH order): vec4f(t, u, v, w) for tmin < t < tmax,
// w = BVH_HIT_OPAQUE or BVH_HIT_ALPHA_TESTED (the triangle's flag, so that bvh_accept needs no second
// load), else w = 0 (a flag rather than a sentinel t, since tmax may be FLT_MAX or even +inf). An edge
// function of exactly 0 counts as inside for both triangles sharing the edge (the paper's
// double-precision fallback does not exist in WGSL): no gaps, at worst a double hit.
fn bvh_triangle(r: BvhRay, i: u32, tmin: f32, tmax: f32) -> vec4f {
    let miss = vec4f(0.0);
    let v1 = bvh_triangle_words(i, 1u);
    let a = bvh_project(bvh_triangle_texel(i, 0u).xyz, r);
    let b = bvh_project(bitcast<vec3f>(v1.xyz), r);
    let c = bvh_project(bvh_triangle_texel(i, 2u).xyz, r);
    // Lanes: edges b → c, c → a, a → b, i.e. the weights of a, b, c (the paper's U, V, W).
    let e = bvh_edges(vec3f(b.x, c.x, a.x), vec3f(b.y, c.y, a.y), vec3f(c.x, a.x, b.x), vec3f(c.y, a.y, b.y));
    if any(e < vec3f(0.0)) && any(e > vec3f(0.0)) {
        return miss;
    }
    let det = e.x + e.y + e.z;
    if det == 0.0 {
        return miss;
    }
    // In det's order of summation, so that a triangle at one depth gets that depth exactly.
    let t = fma(e.z, c.z, fma(e.y, b.z, e.x * a.z)) / det;
    if !(t > tmin && t < tmax) {
        return miss;
    }
    let alpha_tested = (v1.w & BVH_FLAG_ALPHA_TESTED) != 0u;
    return vec4f(t, e.y / det, e.z / det, select(BVH_HIT_OPAQUE, BVH_HIT_ALPHA_TESTED, alpha_tested));
}

// Whether candidate hit `h` (bvh_triangle's, w != 0) on triangle `i` (BVH order) counts, asking the
// includer for alpha-tested triangles.
fn bvh_accept(i: u32, h: vec4f) -> bool {
    if !BVH_ALPHA_TESTS || h.w != BVH_HIT_ALPHA_TESTED {
        return true;
    }
    return bvh_alpha_test(bvh_original_triangle(i), h.y, h.z);
}

// The traversal stack: deferred children and (closest hit) their entry distances, skipped when a
// closer hit was found since. Module-scope rather than a local of each query: WGSL zero-initialises
// a function's arrays at every call, which cost lavapipe 16 % of the path tracer's frame on cornell
// (short traversals, ~8 queries per sample); private memory is initialised once per invocation.
// Only one query runs at a time (they do not nest). Holding the stack's newest four entries in vectors
// (selects instead of indexed private memory, spilling the oldest) was tried: the same images, but
// 1.12× the path tracer's frame on atrium:detail=5 at 256² on lavapipe.
var<private> bvh_stack_node: array<u32, BVH_STACK_SIZE>;
var<private> bvh_stack_t: array<f32, BVH_STACK_SIZE>;

// The reference of a leaf's triangles after its first: first + 1, count − 1 (first < 2^29 − 1).
fn bvh_leaf_rest(leaf: u32) -> u32 {
    return leaf + (1u << 3u) - 1u;
}

// Closest hit with tmin < t < tmax (see the contract above).
fn trace_closest(ray: Ray, tmin: f32, tmax: f32) -> Hit {
    return trace_closest_from(ray, bvh_ray(ray), 0u, tmin, tmax);
}

// trace_closest within the part of the BVH under node reference `start`, as trace_any_from.
fn trace_closest_from(ray: Ray, start_ray: BvhRay, start: u32, tmin: f32, tmax: f32) -> Hit {
    let world = start_ray;
    var r = world;
    // The stack depth at which the current instance was entered: entries below it are world space
    // (0 in world space, where no entry lies below).
    var instance_sp = 0u;
    var hit = Hit(FLT_MAX, BVH_NO_HIT, 0.0, 0.0);
    var t_best = tmax;
    var sp = 0u;
    var current = start;
    var have_current = true;
    // One flat loop (no nested descent loop): on a SIMD CPU driver all lanes of a batch then step
    // together through nodes and leaves alike.
    loop {
        if !have_current {
            if sp == 0u {
                break;
            }
            sp -= 1u;
            if BVH_INSTANCES && sp < instance_sp {
                r = world;
                instance_sp = 0u;
            }
            if bvh_stack_t[sp] >= t_best {
                continue;
            }
            current = bvh_stack_node[sp];
        }
        have_current = false;
        let first = current >> 3u;
        let count = current & 7u;
        if BVH_INSTANCES && count == BVH_INSTANCE_LEAF {
            let entry = bvh_enter_instance(ray, first);
            r = entry.ray;
            current = entry.root;
            instance_sp = sp;
            have_current = true;
            continue;
        }
        // One triangle per iteration, the leaf's rest next: lanes in leaves and lanes in nodes then
        // step together (a leaf loop made every lane wait for the longest leaf among them; 1.4x the
        // closest-hit rays/s of random rays on lavapipe). The order of tests is the leaf's.
        if count > 0u {
            let h = bvh_triangle(r, first, tmin, t_best);
            if h.w != 0.0 && bvh_accept(first, h) {
                t_best = h.x;
                // The BVH-order index until the end: one lookup of the original per query.
                hit = Hit(h.x, first, h.y, h.z);
            }
            current = bvh_leaf_rest(current);
            have_current = count > 1u;
            continue;
        }
        let node = bvh_node(first);
        let s = bvh_sort_children(bvh_children_entry(node, r, tmin, t_best), node.children);
        // The nearest child next, the others deferred far to near.
        if s.t.w < FLT_MAX {
            bvh_stack_node[sp] = s.refs.w;
            bvh_stack_t[sp] = s.t.w;
            sp += 1u;
        }
        if s.t.z < FLT_MAX {
            bvh_stack_node[sp] = s.refs.z;
            bvh_stack_t[sp] = s.t.z;
            sp += 1u;
        }
        if s.t.y < FLT_MAX {
            bvh_stack_node[sp] = s.refs.y;
            bvh_stack_t[sp] = s.t.y;
            sp += 1u;
        }
        current = s.refs.x;
        have_current = s.t.x < FLT_MAX;
    }
    if hit_found(hit) {
        hit.triangle = bvh_original_triangle(hit.triangle);
    }
    return hit;
}

// Whether anything is hit with tmin < t < tmax; returns at the first accepted hit.
fn trace_any(ray: Ray, tmin: f32, tmax: f32) -> bool {
    return trace_any_from(ray, bvh_ray(ray), 0u, tmin, tmax);
}

// trace_any within the part of the BVH under node reference `start`, `start_ray` being `ray` ready for
// traversal in that part's space: the whole scene from the root (0, the world ray), or one bottom level
// alone (the static meshes' in world space, or an instance's in its own space; see
// GpuScene::bvh_parts), for transfer that sees a rigid part's own geometry only.
fn trace_any_from(ray: Ray, start_ray: BvhRay, start: u32, tmin: f32, tmax: f32) -> bool {
    let world = start_ray;
    var r = world;
    var instance_sp = 0u;
    var sp = 0u;
    var current = start;
    var have_current = true;
    loop {
        if !have_current {
            if sp == 0u {
                break;
            }
            sp -= 1u;
            if BVH_INSTANCES && sp < instance_sp {
                r = world;
                instance_sp = 0u;
            }
            current = bvh_stack_node[sp];
        }
        have_current = false;
        let first = current >> 3u;
        let count = current & 7u;
        if BVH_INSTANCES && count == BVH_INSTANCE_LEAF {
            let entry = bvh_enter_instance(ray, first);
            r = entry.ray;
            current = entry.root;
            instance_sp = sp;
            have_current = true;
            continue;
        }
        if count > 0u {
            let h = bvh_triangle(r, first, tmin, tmax);
            if h.w != 0.0 && bvh_accept(first, h) {
                return true;
            }
            current = bvh_leaf_rest(current);
            have_current = count > 1u;
            continue;
        }
        let node = bvh_node(first);
        // Any order finds an occluder; nearest first is the closest-hit code.
        let s = bvh_sort_children(bvh_children_entry(node, r, tmin, tmax), node.children);
        if s.t.w < FLT_MAX {
            bvh_stack_node[sp] = s.refs.w;
            sp += 1u;
        }
        if s.t.z < FLT_MAX {
            bvh_stack_node[sp] = s.refs.z;
            sp += 1u;
        }
        if s.t.y < FLT_MAX {
            bvh_stack_node[sp] = s.refs.y;
            sp += 1u;
        }
        current = s.refs.x;
        have_current = s.t.x < FLT_MAX;
    }
    return false;
}
