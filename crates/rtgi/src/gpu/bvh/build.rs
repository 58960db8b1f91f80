//! Binned SAH build (Wald 2007, "On fast Construction of SAH-based Bounding Volume Hierarchies").
//!
//! The top levels are split on one thread until the tree has a fixed set of large subtrees; those are
//! built in parallel and stitched back in a fixed order. The decomposition depends only on the input,
//! never on the thread count or scheduling, so the output is deterministic.

use std::sync::Mutex;

use glam::{Vec3, Vec3A};

use super::wide::BinaryNode;
use super::{
    BVH_FLAG_ALPHA_TESTED, BVH_MAX_LEAF, BVH_MAX_TRIANGLES, BvhTriangle, MAX_BINARY_DEPTH, node_ref,
};

/// Bins per axis for large nodes; small nodes use fewer (see [`Binner::new`]).
const BINS: usize = 32;
const MIN_BINS: usize = 8;
const MAX_LEAF: usize = BVH_MAX_LEAF as usize;
/// SAH constants: a node visit (two box tests) costs about as much as a triangle test in `bvh.wgsl`.
const COST_TRAVERSAL: f32 = 1.0;
const COST_TRIANGLE: f32 = 1.0;
/// The traversal stack bounds the tree depth (see [`median_height`] and [`super::wide`]).
pub(super) const MAX_DEPTH: u32 = MAX_BINARY_DEPTH;
/// Nodes at this depth with at least `PARALLEL_MIN` triangles become independent subtree builds.
const PARALLEL_DEPTH: u32 = 4;
const PARALLEL_MIN: usize = 16 * 1024;

/// The single triangle of an empty BVH: degenerate (determinant 0), so it never hits.
pub(super) const EMPTY_TRIANGLE: BvhTriangle =
    BvhTriangle { v0: [0.0; 3], index: u32::MAX, v1: [0.0; 3], flags: 0, v2: [0.0; 3], pad: 0 };

#[derive(Clone, Copy, Debug)]
struct Bounds {
    min: Vec3A,
    max: Vec3A,
}

impl Bounds {
    const EMPTY: Bounds = Bounds { min: Vec3A::splat(f32::INFINITY), max: Vec3A::splat(f32::NEG_INFINITY) };

    #[inline(always)]
    fn grow(&mut self, min: Vec3A, max: Vec3A) {
        self.min = self.min.min(min);
        self.max = self.max.max(max);
    }

    #[inline(always)]
    fn union(self, o: Bounds) -> Bounds {
        Bounds { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    fn half_area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3A::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

/// A triangle reference during the build. Partitioning moves these (not indices into a side table)
/// so that every pass streams through memory.
#[derive(Clone, Copy)]
struct Prim {
    min: Vec3A,
    max: Vec3A,
    id: u32,
}

impl Prim {
    /// Twice the box centre: binning only needs an affine image of the centroid.
    #[inline(always)]
    fn centroid2(&self) -> Vec3A {
        self.min + self.max
    }
}

/// A node still to be built: its slot in the node array, its prim range and bounds.
#[derive(Clone, Copy)]
struct Task {
    slot: u32,
    start: usize,
    end: usize,
    bounds: Bounds,
    /// Bounds of the prims' `centroid2`.
    centroids: Bounds,
    depth: u32,
    /// Deepest a leaf of this build may be (see [`build`]).
    depth_limit: u32,
}

#[derive(Clone, Copy)]
struct Bin {
    bounds: Bounds,
    count: u32,
}

/// Maps a prim to its bin along each axis. Binning and partitioning both call this, so they classify
/// every prim identically and the binned counts are exactly the partition sizes.
#[derive(Clone, Copy)]
struct Binner {
    origin: Vec3A,
    scale: Vec3A,
    bins: usize,
}

impl Binner {
    /// Most nodes are small, where 32 bins cost more to sweep than they gain: a node of `count` prims
    /// gets about as many bins as prims (at least MIN_BINS).
    fn new(centroids: &Bounds, count: usize) -> Binner {
        let bins = count.clamp(MIN_BINS, BINS);
        let extent = centroids.max - centroids.min;
        let s = Vec3A::splat(bins as f32) / extent;
        // A flat axis (or one so thin that the scale overflows) cannot be split: all prims go to bin 0.
        let scale = Vec3A::select(extent.cmpgt(Vec3A::ZERO) & s.is_finite_mask(), s, Vec3A::ZERO);
        Binner { origin: centroids.min, scale, bins }
    }

    #[inline(always)]
    fn bins(&self, c: Vec3A) -> [usize; 3] {
        let b = ((c - self.origin) * self.scale).min(Vec3A::splat((self.bins - 1) as f32));
        [b.x as usize, b.y as usize, b.z as usize]
    }

    #[inline(always)]
    fn bin(&self, c: Vec3A, axis: usize) -> usize {
        (((c[axis] - self.origin[axis]) * self.scale[axis]).min((self.bins - 1) as f32)) as usize
    }
}

/// Height of the subtree that object-median splits build over `count` prims: each level halves the
/// count (rounding up) until a leaf holds at most MAX_LEAF.
fn median_height(count: usize) -> u32 {
    count.div_ceil(MAX_LEAF).next_power_of_two().trailing_zeros()
}

enum Plan {
    Leaf,
    /// Prims in bins `< bin` along `axis` go left.
    Binned {
        axis: usize,
        bin: usize,
        left: Bounds,
        right: Bounds,
    },
    Median,
}

fn plan(prims: &[Prim], task: &Task) -> Plan {
    let count = prims.len();
    if count == 1 {
        return Plan::Leaf;
    }
    // Depth budget: median splits finish any node within median_height levels, and an SAH split is
    // allowed only while its children could still finish that way. Every node then satisfies
    // depth + median_height(count) <= depth_limit (true at the root: `build` is only called with a
    // limit of at least median_height of the count), so no leaf is deeper than the limit, whatever the
    // geometry.
    if task.depth + 1 + median_height(count) > task.depth_limit {
        return if count <= MAX_LEAF { Plan::Leaf } else { Plan::Median };
    }
    let binner = Binner::new(&task.centroids, count);
    let nb = binner.bins;
    let mut bins = [[Bin { bounds: Bounds::EMPTY, count: 0 }; BINS]; 3];
    for p in prims {
        let b = binner.bins(p.centroid2());
        for axis in 0..3 {
            let bin = &mut bins[axis][b[axis]];
            bin.bounds.grow(p.min, p.max);
            bin.count += 1;
        }
    }
    let mut best: Option<(f32, usize, usize)> = None;
    for (axis, bins) in bins.iter().enumerate() {
        let mut right_cost = [0.0f32; BINS];
        let mut right_count = [0u32; BINS];
        let mut acc = Bounds::EMPTY;
        let mut n = 0u32;
        for i in (1..nb).rev() {
            acc = acc.union(bins[i].bounds);
            n += bins[i].count;
            right_cost[i] = acc.half_area() * n as f32;
            right_count[i] = n;
        }
        let mut acc = Bounds::EMPTY;
        let mut n = 0u32;
        for i in 1..nb {
            acc = acc.union(bins[i - 1].bounds);
            n += bins[i - 1].count;
            let cost = acc.half_area() * n as f32 + right_cost[i];
            // Ties keep the first candidate, so the choice is a pure function of the input.
            if n > 0 && right_count[i] > 0 && best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, i));
            }
        }
    }
    let Some((cost, axis, bin)) = best else {
        return if count <= MAX_LEAF { Plan::Leaf } else { Plan::Median };
    };
    let area = task.bounds.half_area();
    let split_cost = if area > 0.0 {
        COST_TRAVERSAL + COST_TRIANGLE * cost / area
    } else {
        COST_TRAVERSAL + COST_TRIANGLE * count as f32
    };
    if count <= MAX_LEAF && COST_TRIANGLE * count as f32 <= split_cost {
        return Plan::Leaf;
    }
    let side = |range: std::ops::Range<usize>| {
        bins[axis][range].iter().fold(Bounds::EMPTY, |b, bin| b.union(bin.bounds))
    };
    Plan::Binned { axis, bin, left: side(0..bin), right: side(bin..nb) }
}

/// Bounds and centroid bounds of a prim range.
fn measure(prims: &[Prim]) -> (Bounds, Bounds) {
    let (mut b, mut c) = (Bounds::EMPTY, Bounds::EMPTY);
    for p in prims {
        b.grow(p.min, p.max);
        let c2 = p.centroid2();
        c.grow(c2, c2);
    }
    (b, c)
}

/// Splits `prims` in place according to `plan`; returns the left count and both sides' centroid
/// bounds (and, for median splits, the sides' bounds, which binning did not provide).
fn split(prims: &mut [Prim], task: &Task, plan: &Plan) -> (usize, [Bounds; 2], [Bounds; 2]) {
    match *plan {
        Plan::Binned { axis, bin, left, right } => {
            let binner = Binner::new(&task.centroids, prims.len());
            let (mut cl, mut cr) = (Bounds::EMPTY, Bounds::EMPTY);
            let (mut i, mut j) = (0, prims.len());
            while i < j {
                let c = prims[i].centroid2();
                if binner.bin(c, axis) < bin {
                    cl.grow(c, c);
                    i += 1;
                } else {
                    cr.grow(c, c);
                    j -= 1;
                    prims.swap(i, j);
                }
            }
            (i, [left, right], [cl, cr])
        }
        Plan::Median => {
            let e = task.centroids.max - task.centroids.min;
            let axis = if e.x >= e.y && e.x >= e.z {
                0
            } else if e.y >= e.z {
                1
            } else {
                2
            };
            // Ids break ties, so the order (and the tree) is unique.
            prims.sort_unstable_by(|a, b| {
                a.centroid2()[axis].total_cmp(&b.centroid2()[axis]).then(a.id.cmp(&b.id))
            });
            let mid = prims.len() / 2;
            let (l, r) = (measure(&prims[..mid]), measure(&prims[mid..]));
            (mid, [l.0, r.0], [l.1, r.1])
        }
        Plan::Leaf => unreachable!("leaves are not split"),
    }
}

struct Subtree {
    /// Root at index 0; internal nodes' `link` index this vector.
    nodes: Vec<BinaryNode>,
    /// Tasks left for a parallel pass (`start`/`end` global), whose slots are placeholders.
    deferred: Vec<Task>,
    max_depth: u32,
}

fn inner(bounds: &Bounds, left: u32) -> BinaryNode {
    BinaryNode { aabb_min: bounds.min.into(), aabb_max: bounds.max.into(), link: left, leaf: false }
}

fn leaf(bounds: &Bounds, first: u32, count: u32) -> BinaryNode {
    BinaryNode {
        aabb_min: bounds.min.into(),
        aabb_max: bounds.max.into(),
        link: node_ref(first, count),
        leaf: true,
    }
}

/// Builds the subtree of `root` over `prims` (which start at global prim index `offset`), depth first
/// so that subtrees are contiguous in memory.
fn build_subtree(prims: &mut [Prim], offset: usize, root: Task, defer: bool) -> Subtree {
    let mut out = Subtree { nodes: vec![inner(&root.bounds, 0)], deferred: Vec::new(), max_depth: 0 };
    let mut stack = vec![Task { slot: 0, start: 0, end: prims.len(), ..root }];
    while let Some(task) = stack.pop() {
        let range = &mut prims[task.start..task.end];
        let count = range.len();
        if defer && task.depth == PARALLEL_DEPTH && count >= PARALLEL_MIN {
            out.deferred.push(Task { start: task.start + offset, end: task.end + offset, ..task });
            continue;
        }
        out.max_depth = out.max_depth.max(task.depth);
        let plan = plan(range, &task);
        if let Plan::Leaf = plan {
            out.nodes[task.slot as usize] = leaf(&task.bounds, (offset + task.start) as u32, count as u32);
            continue;
        }
        let (mid, bounds, centroids) = split(range, &task, &plan);
        debug_assert!(mid > 0 && mid < count, "a split must leave triangles on both sides");
        let left = out.nodes.len() as u32;
        out.nodes[task.slot as usize] = inner(&task.bounds, left);
        out.nodes.extend([inner(&bounds[0], 0), inner(&bounds[1], 0)]);
        let child = |slot, start, end, side: usize| Task {
            slot,
            start,
            end,
            bounds: bounds[side],
            centroids: centroids[side],
            depth: task.depth + 1,
            depth_limit: task.depth_limit,
        };
        // Right pushed first so the left subtree is built (and laid out) first.
        stack.push(child(left + 1, task.start + mid, task.end, 1));
        stack.push(child(left, task.start, task.start + mid, 0));
    }
    out
}

/// Runs `f` over `0..n` in contiguous chunks on up to `threads` threads.
fn parallel_chunks<T: Send>(
    n: usize,
    threads: usize,
    f: impl Fn(std::ops::Range<usize>) -> T + Sync,
) -> Vec<T> {
    let chunk = n.div_ceil(threads.max(1)).max(1);
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..n)
            .step_by(chunk)
            .map(|start| {
                let f = &f;
                s.spawn(move || f(start..(start + chunk).min(n)))
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e))).collect()
    })
}

/// Height of the tree median splits build over `count` triangles: the least depth limit a build of
/// that many triangles can meet.
pub(super) fn least_depth(count: usize) -> u32 {
    median_height(count)
}

/// The binary SAH tree, which [`super::wide`] collapses into the BVH the GPU traverses.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct BinaryBvh {
    /// Root at index 0; leaves' links are node references of triangle ranges in `triangles`.
    pub nodes: Vec<BinaryNode>,
    pub triangles: Vec<BvhTriangle>,
    /// Depth of the deepest leaf (the root has depth 0).
    pub max_depth: u32,
}

/// Builds the binary tree with no leaf deeper than `depth_limit` (at least [`least_depth`] of the
/// count; [`MAX_DEPTH`] for a standalone tree, less for one grafted below a top level).
pub(super) fn build(triangles: &[[Vec3; 3]], alpha_tested: Option<&[bool]>, depth_limit: u32) -> BinaryBvh {
    let n = triangles.len();
    if n == 0 {
        let zero = Bounds { min: Vec3A::ZERO, max: Vec3A::ZERO };
        return BinaryBvh { nodes: vec![leaf(&zero, 0, 1)], triangles: vec![EMPTY_TRIANGLE], max_depth: 0 };
    }
    debug_assert!(n <= BVH_MAX_TRIANGLES && median_height(n) <= depth_limit && depth_limit <= MAX_DEPTH);
    let threads = std::thread::available_parallelism().map_or(1, |t| t.get()).min(16);
    let threads = if n < 64 * 1024 { 1 } else { threads };

    let chunks = parallel_chunks(n, threads, |range| {
        let mut b = Bounds::EMPTY;
        let mut c = Bounds::EMPTY;
        let prims: Vec<Prim> = range
            .map(|i| {
                let [v0, v1, v2] = triangles[i].map(Vec3A::from);
                let p = Prim { min: v0.min(v1).min(v2), max: v0.max(v1).max(v2), id: i as u32 };
                b.grow(p.min, p.max);
                let c2 = p.centroid2();
                c.grow(c2, c2);
                p
            })
            .collect();
        (prims, b, c)
    });
    let mut prims = Vec::with_capacity(n);
    let (mut bounds, mut centroids) = (Bounds::EMPTY, Bounds::EMPTY);
    for (p, b, c) in chunks {
        prims.extend_from_slice(&p);
        bounds = bounds.union(b);
        centroids = centroids.union(c);
    }

    let root = Task { slot: 0, start: 0, end: n, bounds, centroids, depth: 0, depth_limit };
    let top = build_subtree(&mut prims, 0, root, true);
    let mut nodes = top.nodes;
    let mut max_depth = top.max_depth;

    // Deferred tasks cover disjoint prim ranges; carve them out in order of position.
    let mut by_start: Vec<usize> = (0..top.deferred.len()).collect();
    by_start.sort_by_key(|&i| top.deferred[i].start);
    let mut queue: Vec<(usize, &mut [Prim])> = Vec::with_capacity(by_start.len());
    let mut rest: &mut [Prim] = &mut prims;
    let mut consumed = 0;
    for &i in &by_start {
        let t = &top.deferred[i];
        let (_, tail) = std::mem::take(&mut rest).split_at_mut(t.start - consumed);
        let (slice, tail) = tail.split_at_mut(t.end - t.start);
        queue.push((i, slice));
        rest = tail;
        consumed = t.end;
    }
    // Popped largest first, which balances the threads; the order of work does not affect the result.
    queue.sort_by_key(|(i, _)| top.deferred[*i].end - top.deferred[*i].start);
    let queue = Mutex::new(queue);
    let mut subtrees: Vec<Option<Subtree>> = (0..top.deferred.len()).map(|_| None).collect();
    let workers = threads.min(top.deferred.len());
    let results = std::thread::scope(|s| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                s.spawn(|| {
                    let mut done = Vec::new();
                    loop {
                        let job = queue.lock().unwrap_or_else(|e| e.into_inner()).pop();
                        let Some((i, slice)) = job else { break };
                        let t = top.deferred[i];
                        done.push((i, build_subtree(slice, t.start, t, false)));
                    }
                    done
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
            .collect::<Vec<_>>()
    });
    for (i, sub) in results {
        subtrees[i] = Some(sub);
    }

    // Stitch: each subtree's root replaces its placeholder, the rest is appended with child indices
    // shifted (local index k ≥ 1 lands at base + k − 1).
    for (task, sub) in top.deferred.iter().zip(subtrees) {
        let Some(sub) = sub else { unreachable!("every deferred subtree is built") };
        max_depth = max_depth.max(sub.max_depth);
        let base = nodes.len() as u32;
        let remap = |mut n: BinaryNode| {
            if !n.leaf {
                n.link = base + n.link - 1;
            }
            n
        };
        nodes[task.slot as usize] = remap(sub.nodes[0]);
        nodes.extend(sub.nodes[1..].iter().map(|&n| remap(n)));
    }

    let flags = |id: usize| {
        if alpha_tested.and_then(|a| a.get(id)).copied().unwrap_or(false) { BVH_FLAG_ALPHA_TESTED } else { 0 }
    };
    let packed = parallel_chunks(n, threads, |range| {
        prims[range]
            .iter()
            .map(|p| {
                let [v0, v1, v2] = triangles[p.id as usize].map(|v| v.to_array());
                BvhTriangle { v0, index: p.id, v1, flags: flags(p.id as usize), v2, pad: 0 }
            })
            .collect::<Vec<_>>()
    });
    let triangles = packed.concat();
    BinaryBvh { nodes, triangles, max_depth }
}
