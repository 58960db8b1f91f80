//! The BVH the GPU traverses: the binary SAH tree of [`super::build`] collapsed into nodes of up to
//! four children whose boxes are quantised to one byte per plane (the compressed wide BVH of Ylitie,
//! Karras & Laine 2017, "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide BVHs", at
//! width 4 with distance-sorted children instead of octant orders).
//!
//! Why: traversal cost is dominated by node fetches and loop iterations on every adapter rtgi runs on
//! (lavapipe loads a lane-varying address one lane at a time; a discrete GPU waits on memory). A
//! 4-wide node needs about half the visits of a binary tree, and its 64 bytes hold four boxes where
//! the binary layout spent 64 bytes on two.
//!
//! Quantisation: a node stores the corner `origin` of a grid whose cell size per axis is a power of
//! two, 2^e, and each child's box as whole cells `lo..=hi` (bytes). Traversal tests the box
//! `origin + q·2^e`: q·2^e is exact (a byte times a power of two), so the sum is rounded once, the same
//! on every device whether or not its compiler fuses it. Quantising rounds lo down and hi up, and
//! rounding to nearest is monotonic, so the tested box contains the child's exact box; the build
//! checks it in f32 anyway.
//!
//! Stack bound: a visit defers up to k − 1 of its k children. The collapse only makes a node with k
//! children whose every child lies at least (k − 1) / 2 binary levels below it (opening a child adds
//! one child and one level to the opened side), so a path defers at most twice as many entries as
//! the binary tree is deep: [`BVH_STACK_SIZE`](super::BVH_STACK_SIZE) = 2 ·
//! [`MAX_BINARY_DEPTH`](super::MAX_BINARY_DEPTH), also across an instance (whose bottom level is built
//! with the depth its top level leaves).

use glam::Vec3;

use super::{BVH_EMPTY_CHILD, BvhNode, Child, node_ref};

/// Children per node.
pub const BVH_WIDTH: usize = 4;

/// A node of the binary tree (the builder's output and the top level's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct BinaryNode {
    pub aabb_min: [f32; 3],
    pub aabb_max: [f32; 3],
    /// Internal: index of the left child (the right one follows it). Leaf: the node reference the
    /// wide parent stores for it (see [`node_ref`]).
    pub link: u32,
    pub leaf: bool,
}

impl BinaryNode {
    fn half_area(&self) -> f32 {
        let e = (Vec3::from(self.aabb_max) - Vec3::from(self.aabb_min)).max(Vec3::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

/// Collapses the binary tree `binary` (root at index 0) into wide nodes appended to `out`, its root
/// first. References to triangle ranges are moved by `triangle_base` (a bottom level whose triangles
/// follow others); node references index `out`. Deterministic: a function of the tree alone.
pub(super) fn collapse(binary: &[BinaryNode], out: &mut Vec<BvhNode>, triangle_base: u32) {
    let root = out.len();
    out.push(BvhNode::EMPTY);
    // (binary node, wide slot): nodes still to fill, depth first so that subtrees stay contiguous.
    let mut pending = vec![(0usize, root)];
    // (binary node, binary levels below the wide node being made).
    let mut children: Vec<(usize, u32)> = Vec::with_capacity(BVH_WIDTH);
    while let Some((b, slot)) = pending.pop() {
        let node = &binary[b];
        children.clear();
        if node.leaf {
            // Only a root can be a leaf: a node with one child.
            children.push((b, 0));
        } else {
            let left = node.link as usize;
            children.extend([(left, 1), (left + 1, 1)]);
        }
        // Open the largest internal child while the node has room and the stack bound holds.
        while children.len() < BVH_WIDTH {
            let deferred = children.len() as u32; // k − 1 after opening one more
            let mut best: Option<(f32, usize)> = None;
            for (i, &(c, levels)) in children.iter().enumerate() {
                if binary[c].leaf {
                    continue;
                }
                let nearest = children
                    .iter()
                    .enumerate()
                    .filter(|&(j, _)| j != i)
                    .map(|(_, &(_, l))| l)
                    .fold(levels + 1, u32::min);
                if deferred > 2 * nearest {
                    continue;
                }
                let area = binary[c].half_area();
                // Ties keep the first candidate, so the tree is a pure function of the input.
                if best.is_none_or(|(a, _)| area > a) {
                    best = Some((area, i));
                }
            }
            let Some((_, i)) = best else { break };
            let (c, levels) = children[i];
            let left = binary[c].link as usize;
            children.splice(i..=i, [(left, levels + 1), (left + 1, levels + 1)]);
        }
        let mut references = [BVH_EMPTY_CHILD; BVH_WIDTH];
        let mut boxes = [(Vec3::ZERO, Vec3::ZERO); BVH_WIDTH];
        let first_pending = pending.len();
        for (j, &(c, _)) in children.iter().enumerate() {
            let n = &binary[c];
            boxes[j] = (Vec3::from(n.aabb_min), Vec3::from(n.aabb_max));
            references[j] = if n.leaf {
                match Child::of(n.link) {
                    Child::Triangles { .. } => n.link + (triangle_base << 3),
                    _ => n.link,
                }
            } else {
                // Siblings' slots are adjacent, and filled first child first.
                let s = out.len();
                out.push(BvhNode::EMPTY);
                pending.push((c, s));
                node_ref(s as u32, 0)
            };
        }
        pending[first_pending..].reverse();
        out[slot] = BvhNode::quantised(&boxes[..children.len()], references);
    }
}

/// The byte `value` of `word` for child `j`.
fn set_byte(word: &mut u32, j: usize, value: u32) {
    *word |= value << (8 * j);
}

impl BvhNode {
    /// A node with no children (nothing under it is ever hit).
    pub const EMPTY: BvhNode = BvhNode {
        origin: [0.0; 3],
        // Cells of size 1 (biased exponent 127) on every axis.
        exponents: 127 | 127 << 8 | 127 << 16,
        children: [BVH_EMPTY_CHILD; BVH_WIDTH],
        lo: [0; 3],
        spare: 0,
        hi: [0; 3],
        pad: 0,
    };

    /// The node over children `references` with exact boxes `boxes` (as many as there are children;
    /// the remaining slots of `references` are [`BVH_EMPTY_CHILD`]).
    pub(super) fn quantised(boxes: &[(Vec3, Vec3)], references: [u32; BVH_WIDTH]) -> BvhNode {
        let mut node = BvhNode { children: references, ..BvhNode::EMPTY };
        if boxes.is_empty() {
            return node;
        }
        let lo = boxes.iter().fold(Vec3::INFINITY, |a, b| a.min(b.0));
        let hi = boxes.iter().fold(Vec3::NEG_INFINITY, |a, b| a.max(b.1));
        node.origin = lo.to_array();
        node.exponents = 0;
        for axis in 0..3 {
            let extent = f64::from(hi[axis]) - f64::from(lo[axis]);
            // The least exponent (of a normal cell size) whose 255 cells span the extent.
            let mut e = if extent > 0.0 { (extent / 255.0).log2().ceil() as i32 } else { -126 };
            e = e.clamp(-126, 127);
            while e < 127 && extent > 255.0 * 2f64.powi(e) {
                e += 1;
            }
            while e > -126 && extent <= 255.0 * 2f64.powi(e - 1) {
                e -= 1;
            }
            // Rounding could still leave a box a cell short on huge coordinates: a coarser grid then.
            let (byte, lo_q, hi_q) = loop {
                let byte = (e + 127) as u32;
                let cell = 2f64.powi(e);
                let cell_f32 = f32::from_bits(byte << 23);
                let (mut lo_q, mut hi_q) = (0u32, 0u32);
                let mut fits = true;
                for (j, (bmin, bmax)) in boxes.iter().enumerate() {
                    let origin = f64::from(lo[axis]);
                    let mut a = ((f64::from(bmin[axis]) - origin) / cell).floor().max(0.0) as u32;
                    let mut b = ((f64::from(bmax[axis]) - origin) / cell).ceil().max(0.0) as u32;
                    while a > 0 && dequantise(a, cell_f32, lo[axis]) > bmin[axis] {
                        a -= 1;
                    }
                    while b <= 255 && dequantise(b, cell_f32, lo[axis]) < bmax[axis] {
                        b += 1;
                    }
                    fits &= b <= 255;
                    set_byte(&mut lo_q, j, a.min(255));
                    set_byte(&mut hi_q, j, b.min(255));
                }
                if fits || e == 127 {
                    break (byte, lo_q, hi_q);
                }
                e += 1;
            };
            node.exponents |= byte << (8 * axis);
            node.lo[axis] = lo_q;
            node.hi[axis] = hi_q;
        }
        node
    }

    /// The reference of child `j`, `None` for an empty slot.
    #[inline(always)]
    pub fn child(&self, j: usize) -> Option<u32> {
        Some(self.children[j]).filter(|&c| c != BVH_EMPTY_CHILD)
    }

    /// The grid's cell size along `axis` (`bvh_cell` in `bvh.wgsl`).
    #[inline(always)]
    pub fn cell(&self, axis: usize) -> f32 {
        f32::from_bits(((self.exponents >> (8 * axis)) & 0xff) << 23)
    }

    /// The box traversal tests for child `j`, as `bvh_children_entry` in `bvh.wgsl` computes it.
    #[inline(always)]
    pub fn child_box(&self, j: usize) -> (Vec3, Vec3) {
        let corner = |q: [u32; 3]| {
            Vec3::from_array(std::array::from_fn(|axis| {
                dequantise((q[axis] >> (8 * j)) & 0xff, self.cell(axis), self.origin[axis])
            }))
        };
        (corner(self.lo), corner(self.hi))
    }

    /// The non-empty children: reference and tested box.
    pub fn children(&self) -> impl Iterator<Item = (u32, Vec3, Vec3)> + '_ {
        (0..BVH_WIDTH).filter_map(|j| {
            self.child(j).map(|c| {
                let (lo, hi) = self.child_box(j);
                (c, lo, hi)
            })
        })
    }
}

/// origin + q·cell, as the GPU computes it: with a power-of-two cell the product is exact, so fused
/// (the GPU's `fma`) or not (here: `mul_add` is a library call on x86-64 without FMA) the sum is
/// rounded once.
#[inline(always)]
fn dequantise(q: u32, cell: f32, origin: f32) -> f32 {
    q as f32 * cell + origin
}
