//! The two-level BVH of a scene with moving rigid meshes: one bottom level per moving mesh, built
//! once in the space its geometry was given in, one bottom level for all static meshes in world space,
//! and a small top level over them rebuilt whenever an instance moves.
//!
//! Static meshes share one bottom level rather than one each: their boxes overlap (a room's walls
//! and the furniture in it), and a shared SAH tree separates them far better than a top level over
//! per-mesh boxes, so a scene that does not move traces exactly as fast as with a single-level BVH.
//! The top level refers to the static tree's root as a child node, so no transform is applied to it.
//!
//! Layout of the flattened [`Bvh`] (what `bvh.wgsl` reads): the top level in the first
//! max(1, L − 1) nodes for L top-level leaves (the most a wide tree over L leaves needs; unused
//! ones are empty), then the bottom levels; triangles of all bottom levels, then one degenerate
//! triangle so that the buffer is never empty; the instances. The top level is collapsed from a
//! balanced binary tree, so its binary depth is ⌈log₂ L⌉ and the bottom levels are built with the
//! rest of the depth budget (which bounds the traversal stack, see [`super::wide`]).

use glam::{Mat4, Vec3};

use super::build::{self, EMPTY_TRIANGLE, MAX_DEPTH};
use super::wide::{self, BinaryNode};
use super::{BVH_INSTANCE_LEAF, Bvh, BvhInstance, BvhNode, SceneTriangles, node_ref};
use crate::gpu::GpuError;

/// A top-level leaf.
#[derive(Clone, Copy, Debug, PartialEq)]
enum TopLeaf {
    /// The static bottom level: its root node and box.
    Static { root: u32, min: Vec3, max: Vec3 },
    /// Instance `index`, with the box of its bottom level in its own space.
    Instance { index: u32, min: Vec3, max: Vec3 },
}

/// A scene's two-level BVH; see the module documentation.
#[derive(Clone, Debug, PartialEq)]
pub struct InstancedBvh {
    /// The flattened tree as the GPU reads it, top level placed by the last [`Self::place`].
    pub bvh: Bvh,
    /// What placing the instances needs; all a GPU scene keeps after the upload.
    pub top: TopLevel,
}

/// The top level of an [`InstancedBvh`] with what rebuilding it needs: small (at most a node and an
/// instance per moving mesh), unlike the bottom levels.
#[derive(Clone, Debug, PartialEq)]
pub struct TopLevel {
    /// Per instance, the mesh it holds.
    pub instance_meshes: Vec<usize>,
    /// The first nodes of the flattened tree (see the module documentation).
    pub nodes: Vec<BvhNode>,
    pub instances: Vec<BvhInstance>,
    leaves: Vec<TopLeaf>,
}

impl InstancedBvh {
    /// Builds the bottom levels: one per mesh flagged in `moving` (that has triangles), one over all
    /// other meshes. Triangle indices stay global (as in [`SceneTriangles`]). The top level starts
    /// with every instance in place (identity transforms).
    pub fn build(tris: &SceneTriangles, moving: &[bool]) -> Result<InstancedBvh, GpuError> {
        let meshes = tris.mesh_offsets.len().saturating_sub(1);
        let range = |m: usize| tris.mesh_offsets[m] as usize..tris.mesh_offsets[m + 1] as usize;
        let is_moving = |m: usize| moving.get(m).copied().unwrap_or(false);
        let instance_meshes: Vec<usize> =
            (0..meshes).filter(|&m| is_moving(m) && !range(m).is_empty()).collect();
        let static_ids: Vec<u32> =
            (0..meshes).filter(|&m| !is_moving(m)).flat_map(range).map(|i| i as u32).collect();
        let leaf_count = instance_meshes.len() + usize::from(!static_ids.is_empty());
        let top_depth = leaf_count.max(1).next_power_of_two().trailing_zeros();
        let depth_limit = MAX_DEPTH - top_depth.min(MAX_DEPTH);

        // Each bottom level's binary tree, triangle indices global.
        let build_part = |ids: &[u32]| -> Result<build::BinaryBvh, GpuError> {
            if build::least_depth(ids.len()) > depth_limit {
                return Err(GpuError::OverLimit(format!(
                    "a part of the scene with {} triangles needs a BVH deeper than the {depth_limit} levels \
                     left below a top level over {leaf_count} instances",
                    ids.len()
                )));
            }
            let triangles: Vec<[Vec3; 3]> = ids.iter().map(|&i| tris.triangles[i as usize]).collect();
            let alpha: Vec<bool> = ids.iter().map(|&i| tris.alpha_tested[i as usize]).collect();
            let mut part = build::build(&triangles, Some(&alpha), depth_limit);
            for t in &mut part.triangles {
                t.index = ids[t.index as usize];
            }
            Ok(part)
        };

        let top_nodes = leaf_count.saturating_sub(1).max(1);
        let mut nodes = vec![BvhNode::EMPTY; top_nodes];
        let mut triangles = Vec::new();
        let mut leaves = Vec::with_capacity(leaf_count);
        let mut instances = Vec::with_capacity(instance_meshes.len());
        let mut bottom_depth = 0;
        // Appends a bottom level; returns its root node and box.
        let mut append = |part: build::BinaryBvh, nodes: &mut Vec<BvhNode>| -> (u32, Vec3, Vec3) {
            let root = nodes.len() as u32;
            bottom_depth = bottom_depth.max(part.max_depth);
            wide::collapse(&part.nodes, nodes, triangles.len() as u32);
            triangles.extend_from_slice(&part.triangles);
            (root, Vec3::from(part.nodes[0].aabb_min), Vec3::from(part.nodes[0].aabb_max))
        };
        if !static_ids.is_empty() {
            let (root, min, max) = append(build_part(&static_ids)?, &mut nodes);
            leaves.push(TopLeaf::Static { root, min, max });
        }
        for (index, &m) in instance_meshes.iter().enumerate() {
            let ids: Vec<u32> = range(m).map(|i| i as u32).collect();
            let (root, min, max) = append(build_part(&ids)?, &mut nodes);
            instances.push(BvhInstance { world_to_object: IDENTITY_ROWS, root, pad: [0; 3] });
            leaves.push(TopLeaf::Instance { index: index as u32, min, max });
        }
        triangles.push(EMPTY_TRIANGLE);
        let top = TopLevel {
            nodes: nodes[..top_nodes].to_vec(),
            instances: instances.clone(),
            instance_meshes,
            leaves,
        };
        let mut out = InstancedBvh {
            bvh: Bvh { nodes, triangles, instances, max_depth: top_depth + bottom_depth },
            top,
        };
        out.place(&vec![Mat4::IDENTITY; out.top.instance_meshes.len()]);
        Ok(out)
    }

    /// Instances (moving meshes with triangles).
    pub fn instance_count(&self) -> usize {
        self.top.instance_meshes.len()
    }

    /// [`TopLevel::place`], copied into the flattened tree.
    pub fn place(&mut self, object_to_world: &[Mat4]) {
        self.top.place(object_to_world);
        self.bvh.nodes[..self.top.nodes.len()].copy_from_slice(&self.top.nodes);
        self.bvh.instances.copy_from_slice(&self.top.instances);
    }
}

impl TopLevel {
    /// The node reference of the static meshes' bottom level (`None` when every mesh may move): a
    /// traversal started there sees the static meshes alone, in world space.
    pub fn static_root(&self) -> Option<u32> {
        self.leaves.iter().find_map(|leaf| match *leaf {
            TopLeaf::Static { root, .. } => Some(node_ref(root, 0)),
            TopLeaf::Instance { .. } => None,
        })
    }

    /// Places instance i by `object_to_world[i]` (the map from the geometry its bottom level was built
    /// over to where it is now) and rebuilds the top level. An instance whose map cannot be inverted
    /// (scaled to nothing) is left out: nothing can hit it.
    pub fn place(&mut self, object_to_world: &[Mat4]) {
        let mut live: Vec<(BinaryNode, Vec3)> = Vec::with_capacity(self.leaves.len());
        for leaf in &self.leaves {
            let (link, min, max) = match *leaf {
                TopLeaf::Static { root, min, max } => (node_ref(root, 0), min, max),
                TopLeaf::Instance { index, min, max } => {
                    let m = object_to_world.get(index as usize).copied().unwrap_or(Mat4::IDENTITY);
                    let inverse = m.inverse();
                    if !(m.determinant().abs() > 0.0 && inverse.is_finite()) {
                        continue;
                    }
                    let t = inverse.transpose();
                    self.instances[index as usize].world_to_object =
                        [t.x_axis.to_array(), t.y_axis.to_array(), t.z_axis.to_array()];
                    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
                    for corner in 0..8 {
                        let pick = |bit: u32, a: f32, b: f32| if corner & bit == 0 { a } else { b };
                        let p =
                            Vec3::new(pick(1, min.x, max.x), pick(2, min.y, max.y), pick(4, min.z, max.z));
                        let w = m.transform_point3(p);
                        lo = lo.min(w);
                        hi = hi.max(w);
                    }
                    (node_ref(index, BVH_INSTANCE_LEAF), lo, hi)
                }
            };
            let node = BinaryNode { aabb_min: min.into(), aabb_max: max.into(), link, leaf: true };
            live.push((node, (min + max) * 0.5));
        }
        self.nodes.fill(BvhNode::EMPTY);
        // Every instance scaled to nothing leaves a root without children, which nothing hits.
        if !live.is_empty() {
            let mut binary = vec![live[0].0; 2 * live.len() - 1];
            build_top_level(&mut live, &mut binary);
            let mut top = Vec::with_capacity(self.nodes.len());
            wide::collapse(&binary, &mut top, 0);
            debug_assert!(top.len() <= self.nodes.len(), "a wide tree over L leaves has at most L - 1 nodes");
            self.nodes[..top.len()].copy_from_slice(&top);
        }
    }
}

const IDENTITY_ROWS: [[f32; 4]; 3] = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]];

/// A balanced tree over `leaves` into `top` (root at 0, children in adjacent pairs): each node splits
/// its leaves in half by centre along the axis where the centres spread most. With few leaves this is
/// about as good as SAH, and it bounds the depth at ⌈log₂ L⌉, which the bottom levels were built for.
fn build_top_level(leaves: &mut [(BinaryNode, Vec3)], top: &mut [BinaryNode]) {
    let mut next = 1;
    let mut stack = vec![(0usize, 0usize, leaves.len())];
    while let Some((slot, start, end)) = stack.pop() {
        let part = &mut leaves[start..end];
        if part.len() == 1 {
            top[slot] = part[0].0;
            continue;
        }
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        let (mut clo, mut chi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for (n, c) in part.iter() {
            lo = lo.min(Vec3::from(n.aabb_min));
            hi = hi.max(Vec3::from(n.aabb_max));
            clo = clo.min(*c);
            chi = chi.max(*c);
        }
        let spread = chi - clo;
        let axis = if spread.x >= spread.y && spread.x >= spread.z {
            0
        } else if spread.y >= spread.z {
            1
        } else {
            2
        };
        // Stable: equal centres keep their order, so the tree is a function of the input.
        part.sort_by(|a, b| a.1[axis].total_cmp(&b.1[axis]));
        let mid = part.len().div_ceil(2);
        let left = next;
        next += 2;
        top[slot] = BinaryNode { aabb_min: lo.into(), aabb_max: hi.into(), link: left as u32, leaf: false };
        stack.push((left + 1, start + mid, end));
        stack.push((left, start, start + mid));
    }
    debug_assert_eq!(next, 2 * leaves.len() - 1, "a full binary tree over L leaves has 2L - 1 nodes");
}
