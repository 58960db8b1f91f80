// Ray queries against the scene BVH built by `gpu/bvh` (binned SAH, 32-byte nodes, triangles in BVH
// order). The CPU traversal in `gpu/bvh/traverse.rs` mirrors this file operation for operation; keep
// them in step.
//
// CONTRACT WITH THE INCLUDING SHADER. This module declares no bindings (each technique picks its own
// group and binding numbers); the includer must declare, with exactly these names:
//
//   @group(G) @binding(B)     var<storage, read> bvh_nodes: array<BvhNode>;          // GpuBvh::nodes
//   @group(G) @binding(B + 1) var<storage, read> bvh_tris: array<vec4f>;             // GpuBvh::triangles
//   @group(G) @binding(C)     var<storage, read> bvh_instances: array<BvhInstance>;  // GpuBvh::instances
//   fn bvh_alpha_test(triangle: u32, u: f32, v: f32) -> bool
//
// bvh_tris holds 3 vec4f per triangle: v0.xyz + original triangle index (u32 bits), v1.xyz + flags
// (u32 bits, bit 0 = alpha-tested), v2.xyz + padding. bvh_alpha_test is called only for hits on
// triangles flagged alpha-tested, with the original (global) triangle index and the barycentrics of
// v1 and v2; it returns true for an opaque hit. Shaders without alpha-masked materials can simply
// `return true;`.
//
// Two levels: a leaf with count == BVH_INSTANCE_LEAF is instance left_first (a rigid moving mesh, see
// gpu/bvh/instances.rs). The ray is mapped into the instance's space and the traversal goes on at its
// bottom level's root; hit distances need no conversion (the map is affine and the direction keeps its
// length in units of t). Stack entries pushed before the instance was entered are in world space, so
// popping below that depth restores the world ray. Only one level of instancing exists.
//
// BVH_INSTANCES (a bool the includer may define; shaders::compose defines it true otherwise): false
// compiles the single-level traversal alone, for scenes without instances (GpuScene::bvh_defines).
// The instance branches cost a quarter of the closest-hit throughput on lavapipe even when no lane
// takes them.
//
// Queries: hits are accepted for tmin < t < tmax, t in units of ray.dir (which need not be
// normalised). A miss is `hit.triangle == BVH_NO_HIT`, with hit.t = FLT_MAX.

#import common/math.wgsl

// The builder never makes trees deeper than this, which bounds the stack (BVH_STACK_SIZE in
// gpu/bvh/mod.rs; a test checks they agree).
const BVH_STACK_SIZE: u32 = 32u;
const BVH_NO_HIT: u32 = 0xffffffffu;
const BVH_FLAG_ALPHA_TESTED: u32 = 1u;
const BVH_INSTANCE_LEAF: u32 = 7u;
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

// count > 0: leaf with triangles [left_first, left_first + count) in BVH order.
// count == 0: internal node with children left_first and left_first + 1.
struct BvhNode {
    aabb_min: vec3f,
    left_first: u32,
    aabb_max: vec3f,
    count: u32,
}

// world_to_object rows: object = (dot(row0, p), dot(row1, p), dot(row2, p)), p = (world, 1 or 0),
// evaluated by bvh_affine.
struct BvhInstance {
    row0: vec4f,
    row1: vec4f,
    row2: vec4f,
    root: u32,
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
    return BvhInstanceEntry(bvh_ray(Ray(origin, dir)), bvh_node_ref(bvh_nodes[instance.root]));
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

// Entry distance of the ray into the box, FLT_MAX if it misses it within [tmin, tmax]. (A real entry
// distance is at most the box's exit distance, finite for any box in a scene.)
fn bvh_box_entry(bmin: vec3f, bmax: vec3f, r: BvhRay, tmin: f32, tmax: f32) -> f32 {
    let t0 = (bmin - r.origin) * r.inv_dir;
    let t1 = (bmax - r.origin) * r.inv_dir;
    let near = max(max3(min(t0, t1)), tmin);
    let far = min(bvh_min3(max(t0, t1)) * BVH_BOX_EXIT_SCALE, tmax);
    return select(FLT_MAX, near, near <= far);
}

// Watertight ray–triangle test of triangle `i` (BVH order): vec4f(t, u, v, 1) for tmin < t < tmax,
// else w = 0 (a flag rather than a sentinel t, since tmax may be FLT_MAX or even +inf). An edge
// function of exactly 0 counts as inside for both triangles sharing the edge (the paper's
// double-precision fallback does not exist in WGSL): no gaps, at worst a double hit.
fn bvh_triangle(r: BvhRay, i: u32, tmin: f32, tmax: f32) -> vec4f {
    let miss = vec4f(0.0);
    let a = bvh_project(bvh_tris[3u * i].xyz, r);
    let b = bvh_project(bvh_tris[3u * i + 1u].xyz, r);
    let c = bvh_project(bvh_tris[3u * i + 2u].xyz, r);
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
    return vec4f(t, e.y / det, e.z / det, 1.0);
}

// Whether a candidate hit on triangle `i` (BVH order) counts, asking the includer for alpha-tested
// triangles.
fn bvh_accept(i: u32, u: f32, v: f32) -> bool {
    let flags = bitcast<u32>(bvh_tris[3u * i + 1u].w);
    if (flags & BVH_FLAG_ALPHA_TESTED) == 0u {
        return true;
    }
    return bvh_alpha_test(bitcast<u32>(bvh_tris[3u * i].w), u, v);
}

// What a visit needs of a node, (left_first << 3) | count, kept from the parent's fetch of both
// children so that visiting a node loads nothing. On lavapipe every storage load of a lane-varying
// address is a scalar load per lane, so loads dominate traversal cost. (left_first < 2^29 and
// count <= 4 or BVH_INSTANCE_LEAF are guaranteed by the builders.)
fn bvh_node_ref(n: BvhNode) -> u32 {
    return (n.left_first << 3u) | n.count;
}

// Closest hit with tmin < t < tmax (see the contract above).
fn trace_closest(ray: Ray, tmin: f32, tmax: f32) -> Hit {
    let world = bvh_ray(ray);
    var r = world;
    // The stack depth at which the current instance was entered: entries below it are world space
    // (0 in world space, where no entry lies below).
    var instance_sp = 0u;
    var hit = Hit(FLT_MAX, BVH_NO_HIT, 0.0, 0.0);
    var t_best = tmax;
    // Deferred far children and their entry distances, skipped when a closer hit was found since.
    var stack_node: array<u32, BVH_STACK_SIZE>;
    var stack_t: array<f32, BVH_STACK_SIZE>;
    var sp = 0u;
    let root = bvh_nodes[0];
    var current = bvh_node_ref(root);
    var have_current = bvh_box_entry(root.aabb_min, root.aabb_max, r, tmin, t_best) < FLT_MAX;
    // One flat loop (no nested descent loop): on a SIMD CPU driver all lanes of a batch then step
    // together through inner nodes and leaves alike.
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
            if stack_t[sp] >= t_best {
                continue;
            }
            current = stack_node[sp];
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
            for (var i = first; i < first + count; i++) {
                let h = bvh_triangle(r, i, tmin, t_best);
                if h.w != 0.0 && bvh_accept(i, h.y, h.z) {
                    t_best = h.x;
                    hit = Hit(h.x, bitcast<u32>(bvh_tris[3u * i].w), h.y, h.z);
                }
            }
            continue;
        }
        let left = bvh_nodes[first];
        let right = bvh_nodes[first + 1u];
        let tl = bvh_box_entry(left.aabb_min, left.aabb_max, r, tmin, t_best);
        let tr = bvh_box_entry(right.aabb_min, right.aabb_max, r, tmin, t_best);
        if tl < FLT_MAX && tr < FLT_MAX {
            // Near child first, so that hits found there cull the far one.
            let left_near = tl <= tr;
            current = select(bvh_node_ref(right), bvh_node_ref(left), left_near);
            stack_node[sp] = select(bvh_node_ref(left), bvh_node_ref(right), left_near);
            stack_t[sp] = max(tl, tr);
            sp += 1u;
            have_current = true;
        } else if tl < FLT_MAX {
            current = bvh_node_ref(left);
            have_current = true;
        } else if tr < FLT_MAX {
            current = bvh_node_ref(right);
            have_current = true;
        }
    }
    return hit;
}

// Whether anything is hit with tmin < t < tmax; returns at the first accepted hit.
fn trace_any(ray: Ray, tmin: f32, tmax: f32) -> bool {
    let world = bvh_ray(ray);
    var r = world;
    var instance_sp = 0u;
    var stack: array<u32, BVH_STACK_SIZE>;
    var sp = 0u;
    let root = bvh_nodes[0];
    var current = bvh_node_ref(root);
    var have_current = bvh_box_entry(root.aabb_min, root.aabb_max, r, tmin, tmax) < FLT_MAX;
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
            current = stack[sp];
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
            for (var i = first; i < first + count; i++) {
                let h = bvh_triangle(r, i, tmin, tmax);
                if h.w != 0.0 && bvh_accept(i, h.y, h.z) {
                    return true;
                }
            }
            continue;
        }
        let left = bvh_nodes[first];
        let right = bvh_nodes[first + 1u];
        let hl = bvh_box_entry(left.aabb_min, left.aabb_max, r, tmin, tmax) < FLT_MAX;
        let hr = bvh_box_entry(right.aabb_min, right.aabb_max, r, tmin, tmax) < FLT_MAX;
        // Any order finds an occluder; no distance sort needed.
        if hl && hr {
            stack[sp] = bvh_node_ref(right);
            sp += 1u;
        }
        current = select(bvh_node_ref(right), bvh_node_ref(left), hl);
        have_current = hl || hr;
    }
    return false;
}
