//! Illumination samples on translucent meshes and their kd-trees (Jensen & Buhler 2002), built once on
//! the CPU from the scene's world-space triangles; the GPU lights them every frame.

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};

use crate::scene::Scene;
use crate::scene::builtin::shapes::hash_unit;

/// A point on a translucent surface standing for `area` m² of it (WGSL `IlluminationSample`), and
/// where it sits: barycentrics (u, v) of the second and third vertices of `triangle`, so that the GPU
/// can move it with its mesh. `triangle` counts within the mesh here; the technique makes it an index
/// into the GPU scene's triangles when it uploads the samples.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct IlluminationSample {
    pub position: [f32; 3],
    pub area: f32,
    pub normal: [f32; 3],
    pub mesh: u32,
    pub triangle: u32,
    pub u: f32,
    pub v: f32,
    pub _pad: u32,
}

/// A node of an illumination tree (WGSL `TreeNode`): covers samples `first..first + count`; its left
/// child is the next node, its right child `right` (for `count > 1`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct TreeNode {
    pub lo: [f32; 3],
    pub first: u32,
    pub hi: [f32; 3],
    pub count: u32,
    pub area: f32,
    pub right: u32,
    pub depth: u32,
    pub _pad: u32,
}

/// Deepest tree the traversal's stack (`STACK` in traverse.wgsl) can walk.
pub const MAX_DEPTH: u32 = 30;

/// No tree (the mesh is not translucent).
pub const NO_NODE: u32 = u32::MAX;

/// The samples of every translucent mesh, each mesh's kd-tree over its own samples (so that light does
/// not bleed from one object into another), and the order in which the GPU aggregates the nodes.
#[derive(Clone, Debug, Default)]
pub struct IlluminationTrees {
    /// In tree order: every node's samples are contiguous.
    pub samples: Vec<IlluminationSample>,
    pub nodes: Vec<TreeNode>,
    /// Per scene mesh: its root node or [`NO_NODE`].
    pub roots: Vec<u32>,
    /// Node indices, deepest level first.
    pub order: Vec<u32>,
    /// Per level, deepest first: (offset into `order`, count).
    pub levels: Vec<(u32, u32)>,
    /// Per translucent mesh: (name, sample spacing √(A/n), mean free path of its medium).
    pub spacing: Vec<(String, f32, f32)>,
}

/// Candidates generated per kept sample before the elimination.
pub const CANDIDATES_PER_SAMPLE: u32 = 4;

/// Weighted sample elimination (Yuksel 2015) on a surface of `area`: removes points of `points`, the most
/// crowded first (weight Σ (1 − d̂/2r_max)^8 over neighbours closer than 2r_max, d̂ = max(d, r_min)),
/// until `keep` remain, and returns their indices in increasing order. r_max is the spacing of the densest
/// packing of `keep` disks on the area; neighbours are found in a hashed grid of 2r_max cells (distances
/// are straight-line, fine where the surface is flat at that scale). Deterministic: ties go to the
/// larger index.
pub fn eliminate_samples(points: &[Vec3], keep: usize, area: f64) -> Vec<usize> {
    use std::cmp::Ordering;
    use std::collections::{BinaryHeap, HashMap};
    if keep >= points.len() {
        return (0..points.len()).collect();
    }
    let r_max = (area / (2.0 * 3f64.sqrt() * keep as f64)).sqrt() as f32;
    let r_min = r_max * (1.0 - (keep as f32 / points.len() as f32).powf(1.5)) * 0.65;
    let cell = 2.0 * r_max;
    let key = |p: Vec3| (p / cell).floor().as_ivec3();
    let mut grid: HashMap<glam::IVec3, Vec<usize>> = HashMap::new();
    for (i, &p) in points.iter().enumerate() {
        grid.entry(key(p)).or_default().push(i);
    }
    let weight = |a: Vec3, b: Vec3| {
        let d = a.distance(b).max(r_min);
        if d >= cell { 0.0 } else { (1.0 - d / cell).powi(8) }
    };
    let neighbours = |i: usize, f: &mut dyn FnMut(usize)| {
        let c = key(points[i]);
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if let Some(list) = grid.get(&(c + glam::IVec3::new(dx, dy, dz))) {
                        for &j in list {
                            if j != i {
                                f(j);
                            }
                        }
                    }
                }
            }
        }
    };
    let mut weights = vec![0.0f32; points.len()];
    for i in 0..points.len() {
        let mut w = 0.0;
        neighbours(i, &mut |j| w += weight(points[i], points[j]));
        weights[i] = w;
    }
    #[derive(PartialEq)]
    struct Entry(f32, usize);
    impl Eq for Entry {}
    impl PartialOrd for Entry {
        fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
            Some(self.cmp(other))
        }
    }
    impl Ord for Entry {
        fn cmp(&self, other: &Self) -> Ordering {
            self.0.total_cmp(&other.0).then(self.1.cmp(&other.1))
        }
    }
    let mut heap: BinaryHeap<Entry> = weights.iter().enumerate().map(|(i, &w)| Entry(w, i)).collect();
    let mut alive = vec![true; points.len()];
    let mut remaining = points.len();
    while remaining > keep {
        let Some(Entry(w, i)) = heap.pop() else { break };
        // Entries whose weight changed since they were pushed are stale: the fresh one follows.
        if !alive[i] || w != weights[i] {
            continue;
        }
        alive[i] = false;
        remaining -= 1;
        neighbours(i, &mut |j| {
            if alive[j] {
                weights[j] -= weight(points[i], points[j]);
                heap.push(Entry(weights[j], j));
            }
        });
    }
    (0..points.len()).filter(|&i| alive[i]).collect()
}

impl IlluminationTrees {
    /// Places `total` samples over the translucent meshes of `scene` in proportion to their areas (at
    /// least one per mesh) and builds their trees.
    pub fn build(scene: &Scene, total: u32) -> Self {
        let translucent: Vec<usize> = (0..scene.meshes.len())
            .filter(|&m| {
                let mesh = &scene.meshes[m];
                scene.materials.get(mesh.material as usize).is_some_and(|mat| mat.subsurface.is_some())
            })
            .collect();
        let areas: Vec<Vec<f32>> = translucent
            .iter()
            .map(|&m| {
                let mesh = &scene.meshes[m];
                mesh.indices
                    .chunks_exact(3)
                    .map(|t| {
                        let [a, b, c] = [0, 1, 2].map(|i| mesh.positions[t[i] as usize]);
                        0.5 * (b - a).cross(c - a).length()
                    })
                    .collect()
            })
            .collect();
        let total_area: f64 = areas.iter().flatten().map(|&a| f64::from(a)).sum();
        let mut trees = IlluminationTrees { roots: vec![NO_NODE; scene.meshes.len()], ..Default::default() };
        for (&m, tri_areas) in translucent.iter().zip(&areas) {
            let mesh = &scene.meshes[m];
            let area: f64 = tri_areas.iter().map(|&a| f64::from(a)).sum();
            if area <= 0.0 {
                continue;
            }
            let n = ((f64::from(total) * area / total_area).round() as u32).max(1);
            let start = trees.samples.len();
            // Candidates: systematic sampling of the cumulative area with hashed uniform barycentrics
            // inside each triangle, CANDIDATES_PER_SAMPLE times more than wanted; Yuksel's weighted
            // sample elimination then keeps a blue-noise subset (the paper's samples are Poisson disks),
            // each standing for the same area. (Low-discrepancy candidates thinned this way settle into
            // patches of different lattices, ±20 % in density over a few centimetres: random ones do not.)
            let mut cumulative = Vec::with_capacity(tri_areas.len());
            let mut acc = 0.0f64;
            for &a in tri_areas {
                acc += f64::from(a);
                cumulative.push(acc);
            }
            let candidates = n * CANDIDATES_PER_SAMPLE;
            let mut points = Vec::with_capacity(candidates as usize);
            let mut placed = Vec::with_capacity(candidates as usize);
            for k in 0..candidates {
                let target = (f64::from(k) + 0.5) / f64::from(candidates) * area;
                let t = cumulative.partition_point(|&c| c < target).min(tri_areas.len() - 1);
                let mut uv = Vec2::new(hash_unit(&[m as u32, k, 0]), hash_unit(&[m as u32, k, 1]));
                if uv.x + uv.y > 1.0 {
                    uv = Vec2::ONE - uv;
                }
                let idx = &mesh.indices[3 * t..3 * t + 3];
                let w = [1.0 - uv.x - uv.y, uv.x, uv.y];
                let p: Vec3 = (0..3).map(|i| mesh.positions[idx[i] as usize] * w[i]).sum();
                points.push(p);
                placed.push((t, uv));
            }
            for k in eliminate_samples(&points, n as usize, area) {
                let (t, uv) = placed[k];
                let idx = &mesh.indices[3 * t..3 * t + 3];
                let w = [1.0 - uv.x - uv.y, uv.x, uv.y];
                let nrm: Vec3 = (0..3).map(|i| mesh.normals[idx[i] as usize] * w[i]).sum();
                let [a, b, c] = [0, 1, 2].map(|i| mesh.positions[idx[i] as usize]);
                let nrm = nrm.try_normalize().or((b - a).cross(c - a).try_normalize()).unwrap_or(Vec3::Y);
                trees.samples.push(IlluminationSample {
                    position: points[k].to_array(),
                    area: (area / f64::from(n)) as f32,
                    normal: nrm.to_array(),
                    mesh: m as u32,
                    triangle: t as u32,
                    u: uv.x,
                    v: uv.y,
                    _pad: 0,
                });
            }
            let medium = scene.materials[mesh.material as usize].subsurface.expect("translucent");
            trees.spacing.push((
                mesh.name.clone(),
                (area / f64::from(n)).sqrt() as f32,
                medium.mean_free_path(),
            ));
            trees.roots[m] = trees.nodes.len() as u32;
            let end = trees.samples.len();
            trees.split(start, end, 0);
        }
        let deepest = trees.nodes.iter().map(|n| n.depth).max().unwrap_or(0);
        for depth in (0..=deepest).rev() {
            let offset = trees.order.len() as u32;
            trees
                .order
                .extend((0..trees.nodes.len() as u32).filter(|&i| trees.nodes[i as usize].depth == depth));
            trees.levels.push((offset, trees.order.len() as u32 - offset));
        }
        trees
    }

    /// Builds the subtree over samples `first..end` (reordering them), median split along the longest
    /// axis of their bounds, down to one sample per leaf.
    fn split(&mut self, first: usize, end: usize, depth: u32) -> u32 {
        let index = self.nodes.len() as u32;
        let items = &mut self.samples[first..end];
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let mut area = 0.0;
        for s in items.iter() {
            lo = lo.min(Vec3::from(s.position));
            hi = hi.max(Vec3::from(s.position));
            area += s.area;
        }
        let count = (end - first) as u32;
        self.nodes.push(TreeNode {
            lo: lo.to_array(),
            first: first as u32,
            hi: hi.to_array(),
            count,
            area,
            right: NO_NODE,
            depth,
            _pad: 0,
        });
        if count > 1 {
            let axis = (hi - lo).max_position();
            let mid = (end - first) / 2;
            items.select_nth_unstable_by(mid, |a, b| a.position[axis].total_cmp(&b.position[axis]));
            self.split(first, first + mid, depth + 1);
            let right = self.split(first + mid, end, depth + 1);
            self.nodes[index as usize].right = right;
        }
        index
    }

    pub fn depth(&self) -> u32 {
        self.levels.len().saturating_sub(1) as u32
    }
}
