//! The bounding volume hierarchy every technique and the path tracer trace rays against.
//!
//! - [`Bvh::build`]: binned SAH build on the CPU (deterministic, parallel with std threads).
//! - [`Bvh::intersect`] / [`Bvh::occluded`]: CPU traversal with the same watertight ray–triangle test
//!   (Woop, Benthin & Wald 2013) as `shaders/common/bvh.wgsl`, in the same operations, so CPU
//!   references and GPU results take every hit-or-miss decision alike, bit for bit on a GPU with a
//!   fused `fma` (hit distances may differ by the GPU's division error); [`intersect_brute_force`]
//!   checks both.
//! - [`GpuBvh`]: the two tables `bvh.wgsl` reads (`bvh_nodes`, `bvh_tris`), in textures or buffers
//!   ([`BvhTables`]).
//!
//! GPU layout (all `#[repr(C)]`, matching WGSL's storage layout):
//! - [`BvhNode`], 64 bytes: a node of the 4-wide BVH (see [`wide`] for how the binary SAH tree is
//!   collapsed into it and why): the references of up to four children and their boxes, quantised to
//!   bytes on a power-of-two grid. A child reference is `(first << 3) | count` ([`node_ref`]):
//!   `count == 0` is node `first`; `1..=4` the triangles `[first, first + count)` in BVH order;
//!   [`BVH_INSTANCE_LEAF`] instance `first`; [`BVH_EMPTY_CHILD`] an empty slot. The root is node 0.
//!   An empty input gives a root with one leaf holding one degenerate triangle, which never hits, so
//!   shaders need no special case (and no buffer is zero-sized).
//! - [`BvhTriangle`], 48 bytes (3 × `vec4f`): vertices in BVH order; the `w` lanes carry the original
//!   triangle index (v0), flags (v1, bit 0 = alpha-tested) and padding (v2). Keeping the vertices here
//!   instead of indexing the scene's vertex buffer saves a dependent load per triangle test.
//! - [`BvhInstance`], 64 bytes: the world-to-object rows of a rigid instance and the node index of its
//!   bottom-level root. A child referenced as instance `i` moves the ray into the instance's space
//!   and the traversal descends into its bottom level. Only [`InstancedBvh`] makes such references (a
//!   two-level BVH, for scenes with moving rigid meshes); a plain [`Bvh::build`] has none.
//!
//! Triangle indices are global: the position in the flat list given to [`Bvh::build`], which for a
//! scene is [`SceneTriangles`] (meshes concatenated in order, as the GPU scene upload does).

mod build;
mod instances;
mod traverse;
pub mod wide;

#[cfg(test)]
pub(crate) mod gpu_tests;
#[cfg(test)]
pub(crate) mod test_geometry;
#[cfg(test)]
mod tests;

use bytemuck::Zeroable;
use glam::Vec3;
use wgpu::util::DeviceExt;

use super::{GpuContext, GpuError, linear_texture};
use crate::scene::{AlphaMode, Scene};

pub use instances::{InstancedBvh, TopLevel};
pub use traverse::{intersect_brute_force, occluded_brute_force};
pub use wide::BVH_WIDTH;

/// Deepest leaf of the binary SAH tree (the root has depth 0). SAH trees of millions of triangles
/// are 25–30 deep; the builder keeps every tree within this, which bounds the traversal stack.
pub const MAX_BINARY_DEPTH: u32 = 32;

/// Entries of the traversal stack in `bvh.wgsl` (and the CPU traversal): a visit of a wide node
/// defers at most twice as many children as the binary levels it spans (see [`wide`]).
pub const BVH_STACK_SIZE: u32 = 2 * MAX_BINARY_DEPTH;

/// Most triangles a BVH can hold: node references in `bvh.wgsl` pack `first` into 29 bits. (Far
/// beyond what fits a storage buffer binding anyway.)
pub const BVH_MAX_TRIANGLES: usize = 1 << 28;

/// Most triangles of a leaf.
pub const BVH_MAX_LEAF: u32 = 4;

/// The reference of an empty child slot of a [`BvhNode`].
pub const BVH_EMPTY_CHILD: u32 = u32::MAX;

/// Flag bit of [`BvhTriangle::flags`]: the triangle's material is alpha-masked, so a hit on it is
/// confirmed by the includer's `bvh_alpha_test`.
pub const BVH_FLAG_ALPHA_TESTED: u32 = 1;

/// `count` of a child reference to an instance (see [`BvhInstance`]); triangle leaves hold at most
/// [`BVH_MAX_LEAF`] triangles, and a reference keeps `count` in 3 bits.
pub const BVH_INSTANCE_LEAF: u32 = 7;

/// The child reference `(first << 3) | count` (see the module documentation).
pub const fn node_ref(first: u32, count: u32) -> u32 {
    (first << 3) | count
}

/// What a child reference of a [`BvhNode`] points at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Child {
    Node(u32),
    Triangles { first: u32, count: u32 },
    Instance(u32),
}

impl Child {
    /// Decodes a reference made by [`node_ref`] (not [`BVH_EMPTY_CHILD`]).
    pub fn of(reference: u32) -> Child {
        let (first, count) = (reference >> 3, reference & 7);
        match count {
            0 => Child::Node(first),
            BVH_INSTANCE_LEAF => Child::Instance(first),
            _ => Child::Triangles { first, count },
        }
    }
}

/// A node of the 4-wide BVH as the GPU reads it (see the module documentation and [`wide`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BvhNode {
    /// Corner of the grid the children's boxes are quantised on.
    pub origin: [f32; 3],
    /// Byte a (a = x, y, z): the biased exponent of the grid's cell size along axis a, 2^(byte − 127).
    pub exponents: u32,
    /// Child references ([`node_ref`]), [`BVH_EMPTY_CHILD`] for empty slots.
    pub children: [u32; BVH_WIDTH],
    /// Per axis, byte j: child j's box starts this many cells from the origin ...
    pub lo: [u32; 3],
    pub spare: u32,
    /// ... and ends this many cells from it.
    pub hi: [u32; 3],
    pub pad: u32,
}

/// A rigid instance as the GPU reads it (see the module documentation).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BvhInstance {
    /// Rows of the affine map from world space to the instance's bottom level:
    /// `object = (dot(rows[0], p), dot(rows[1], p), dot(rows[2], p))` with `p = (world, 1)` for points
    /// and `(world, 0)` for directions.
    pub world_to_object: [[f32; 4]; 3],
    /// Node index of the bottom level's root.
    pub root: u32,
    pub pad: [u32; 3],
}

impl BvhInstance {
    /// `ray` in the instance's space. Hit distances carry over unchanged: the map is affine and the
    /// direction is not renormalised.
    pub fn ray_to_object(&self, ray: &Ray) -> Ray {
        self.map_ray::<traverse::Fused>(ray)
    }

    /// [`BvhInstance::ray_to_object`] in `bvh_affine`'s order of operations (`bvh.wgsl`), so that the
    /// GPU moves a ray into an instance with the same rounding.
    pub(crate) fn map_ray<A: traverse::Arithmetic>(&self, ray: &Ray) -> Ray {
        let map = |p: Vec3, w: f32| {
            let lane = |r: [f32; 4]| A::fma(p.x, r[0], A::fma(p.y, r[1], A::fma(p.z, r[2], w * r[3])));
            let [r0, r1, r2] = self.world_to_object;
            Vec3::new(lane(r0), lane(r1), lane(r2))
        };
        Ray { origin: map(ray.origin, 1.0), dir: map(ray.dir, 0.0) }
    }
}

/// A triangle in BVH order as the GPU reads it (see the module documentation).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BvhTriangle {
    pub v0: [f32; 3],
    /// Index of the triangle in the list given to [`Bvh::build`].
    pub index: u32,
    pub v1: [f32; 3],
    /// [`BVH_FLAG_ALPHA_TESTED`].
    pub flags: u32,
    pub v2: [f32; 3],
    pub pad: u32,
}

impl BvhTriangle {
    pub fn vertices(&self) -> [Vec3; 3] {
        [Vec3::from(self.v0), Vec3::from(self.v1), Vec3::from(self.v2)]
    }

    pub fn is_alpha_tested(&self) -> bool {
        self.flags & BVH_FLAG_ALPHA_TESTED != 0
    }
}

/// A ray; `dir` need not be normalised (hit distances are in units of `dir`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Ray { origin, dir }
    }
}

/// A ray–triangle hit: `origin + t·dir = (1 − u − v)·v0 + u·v1 + v·v2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Original (global) triangle index.
    pub triangle: u32,
    pub u: f32,
    pub v: f32,
}

/// A scene's triangles as one flat list, the input of [`Bvh::build`] and the order of the GPU scene's
/// concatenated index buffers.
#[derive(Clone, Debug, Default)]
pub struct SceneTriangles {
    pub triangles: Vec<[Vec3; 3]>,
    /// Per triangle: its material uses [`AlphaMode::Mask`].
    pub alpha_tested: Vec<bool>,
    /// First global triangle index of each mesh, plus the total at the end.
    pub mesh_offsets: Vec<u32>,
}

impl SceneTriangles {
    /// Concatenates the meshes of `scene` in order. The scene must be valid ([`Scene::validate`]).
    pub fn from_scene(scene: &Scene) -> Self {
        let total = scene.triangle_count();
        let mut out = SceneTriangles {
            triangles: Vec::with_capacity(total),
            alpha_tested: Vec::with_capacity(total),
            mesh_offsets: Vec::with_capacity(scene.meshes.len() + 1),
        };
        for mesh in &scene.meshes {
            out.mesh_offsets.push(out.triangles.len() as u32);
            let masked = scene
                .materials
                .get(mesh.material as usize)
                .is_some_and(|m| matches!(m.alpha_mode, AlphaMode::Mask { .. }));
            for tri in mesh.indices.chunks_exact(3) {
                out.triangles.push([
                    mesh.positions[tri[0] as usize],
                    mesh.positions[tri[1] as usize],
                    mesh.positions[tri[2] as usize],
                ]);
                out.alpha_tested.push(masked);
            }
        }
        out.mesh_offsets.push(out.triangles.len() as u32);
        out
    }

    /// The mesh a global triangle index belongs to (`None` past the end).
    pub fn mesh_of(&self, triangle: u32) -> Option<usize> {
        if triangle >= *self.mesh_offsets.last()? {
            return None;
        }
        // partition_point finds the first mesh starting after `triangle`; empty meshes share offsets
        // with their successor, so this lands on the mesh that actually holds it.
        Some(self.mesh_offsets.partition_point(|&o| o <= triangle) - 1)
    }

    /// The material index of a global triangle index.
    pub fn material_of(&self, scene: &Scene, triangle: u32) -> Option<u32> {
        self.mesh_of(triangle).and_then(|m| scene.meshes.get(m)).map(|m| m.material)
    }
}

/// A BVH over a triangle list, in the GPU layout.
#[derive(Clone, Debug, PartialEq)]
pub struct Bvh {
    pub nodes: Vec<BvhNode>,
    pub triangles: Vec<BvhTriangle>,
    /// The instances its top level refers to (empty for a single-level BVH).
    pub instances: Vec<BvhInstance>,
    /// Depth of the deepest leaf of the binary tree it was collapsed from (through the top level and
    /// a bottom level for a two-level BVH); at most [`MAX_BINARY_DEPTH`].
    pub max_depth: u32,
}

impl Bvh {
    /// Builds a BVH over `triangles`; `alpha_tested`, if given, flags triangles by the same index
    /// (missing entries count as opaque). Deterministic: the same input gives the same BVH, whatever
    /// the number of threads. Fails with [`GpuError::OverLimit`] over [`BVH_MAX_TRIANGLES`].
    pub fn build(triangles: &[[Vec3; 3]], alpha_tested: Option<&[bool]>) -> Result<Bvh, GpuError> {
        if triangles.len() > BVH_MAX_TRIANGLES {
            return Err(GpuError::OverLimit(format!(
                "the scene has {} triangles; the BVH holds at most {BVH_MAX_TRIANGLES}",
                triangles.len()
            )));
        }
        Ok(Bvh::collapsed(build::build(triangles, alpha_tested, MAX_BINARY_DEPTH)))
    }

    /// The wide BVH of a binary one.
    fn collapsed(binary: build::BinaryBvh) -> Bvh {
        let mut nodes = Vec::with_capacity(binary.nodes.len() / 3 + 1);
        wide::collapse(&binary.nodes, &mut nodes, 0);
        Bvh { nodes, triangles: binary.triangles, instances: Vec::new(), max_depth: binary.max_depth }
    }

    /// Builds the BVH of a (valid) scene, triangle indices as in [`SceneTriangles::from_scene`].
    pub fn from_scene(scene: &Scene) -> Result<Bvh, GpuError> {
        let tris = SceneTriangles::from_scene(scene);
        Self::build(&tris.triangles, Some(&tris.alpha_tested))
    }

    /// Whether any triangle is alpha-tested.
    pub fn has_alpha_tested(&self) -> bool {
        self.triangles.iter().any(BvhTriangle::is_alpha_tested)
    }

    /// Number of real triangles (an empty BVH holds one degenerate placeholder that never hits).
    pub fn triangle_count(&self) -> usize {
        if self.triangles.len() == 1 && self.triangles[0] == build::EMPTY_TRIANGLE {
            0
        } else {
            self.triangles.len()
        }
    }

    /// Leaves holding triangles.
    pub fn leaf_count(&self) -> usize {
        self.nodes
            .iter()
            .flat_map(BvhNode::children)
            .filter(|(c, _, _)| matches!(Child::of(*c), Child::Triangles { .. }))
            .count()
    }

    /// Bytes of the GPU buffers.
    pub fn memory_bytes(&self) -> u64 {
        (std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.triangles.as_slice())
            + std::mem::size_of_val(self.instances.as_slice())) as u64
    }

    /// SAH cost of the tree as traversed (tested boxes: a node visit and a triangle test cost 1 each,
    /// relative to the root's area): a quality figure for comparing builds, lower is better.
    pub fn sah_cost(&self) -> f64 {
        let half_area = |lo: Vec3, hi: Vec3| {
            let e = (hi - lo).max(Vec3::ZERO).as_dvec3();
            e.x * e.y + e.y * e.z + e.z * e.x
        };
        let bounds = |n: &BvhNode| {
            n.children()
                .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), (_, lo, hi)| (a.min(lo), b.max(hi)))
        };
        let (lo, hi) = bounds(&self.nodes[0]);
        let root = half_area(lo, hi);
        if root <= 0.0 || root.is_nan() {
            return 0.0;
        }
        let mut cost = 0.0;
        for node in &self.nodes {
            for (c, lo, hi) in node.children() {
                let weight = match Child::of(c) {
                    Child::Triangles { count, .. } => f64::from(count),
                    _ => 1.0,
                };
                cost += half_area(lo, hi) * weight;
            }
        }
        1.0 + cost / root
    }
}

/// Bytes of one texel of the node and triangle textures (rgba32uint), one element of their buffers.
const BVH_TEXEL_BYTES: usize = 16;
/// Texels per node and per triangle (`BVH_NODE_TEXELS`, `BVH_TRIANGLE_TEXELS` in `bvh.wgsl`).
pub const BVH_NODE_TEXELS: usize = size_of::<BvhNode>() / BVH_TEXEL_BYTES;
pub const BVH_TRIANGLE_TEXELS: usize = size_of::<BvhTriangle>() / BVH_TEXEL_BYTES;

/// Storage buffers an adapter must bind per stage before [`BvhTables::Auto`] puts the tables in two
/// more: lavapipe's Vulkan limit, under which every pipeline fits with the tables as textures.
const AUTO_BUFFERS_MIN_PER_STAGE: u32 = 32;

/// Where a [`GpuBvh`] keeps its node and triangle tables (`BVH_TABLES_IN_BUFFERS` in
/// `common/bvh.wgsl`). The traversal loads them inside its loop, where drivers differ: lavapipe loads a
/// storage buffer inside a loop lane by lane but an image for all lanes at once, and inlines a storage
/// image's load where a sampled texture's is a function call (the path tracer 1.4–1.7× and then 1.16×
/// faster, see `gpu/linear_texture.rs`). On an H200 the 4-wide BVH in storage buffers took 26.1 ms per
/// frame of `path` on `atrium:detail=5` at 1080p and in sampled textures 25.3 ms (one run each, README);
/// storage images there are unmeasured, and NVIDIA GPUs load them through the surface path rather than
/// the texture or the memory path, so GPUs get buffers, the known case. Both kinds hold the same bytes,
/// read in the same order: images are identical. `rtgi render --bvh-tables` (and
/// `scripts/measure-traversal.py`) compares them on an adapter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BvhTables {
    /// Textures on CPU adapters; buffers on GPUs that bind at least [`AUTO_BUFFERS_MIN_PER_STAGE`]
    /// storage buffers per stage, where both tables fit one storage binding; textures otherwise.
    #[default]
    Auto,
    /// Read-only storage textures (`texture_storage_2d<rgba32uint, read>`, linear textures).
    Textures,
    /// Read-only storage buffers (`array<vec4u>`).
    Buffers,
}

impl BvhTables {
    pub const NAMES: [&'static str; 3] = ["auto", "textures", "buffers"];

    pub fn name(self) -> &'static str {
        match self {
            BvhTables::Auto => "auto",
            BvhTables::Textures => "textures",
            BvhTables::Buffers => "buffers",
        }
    }

    /// The kind (never `Auto`) for tables of `bytes` bytes each on `ctx`; an explicit `Buffers` that
    /// the device cannot bind fails with [`GpuError::OverLimit`] naming the table.
    fn resolve(self, ctx: &GpuContext, bytes: [u64; 2]) -> Result<BvhTables, GpuError> {
        let limits = ctx.limits();
        let per_stage = super::scene::SCENE_STORAGE_BUFFERS + 2;
        let fits = bytes.iter().all(|&b| b <= limits.max_storage_buffer_binding_size);
        match self {
            BvhTables::Textures => Ok(BvhTables::Textures),
            BvhTables::Buffers => {
                ctx.check_storage_size("BVH node buffer", bytes[0])?;
                ctx.check_storage_size("BVH triangle buffer", bytes[1])?;
                if limits.max_storage_buffers_per_shader_stage < per_stage {
                    return Err(GpuError::OverLimit(format!(
                        "BVH tables in buffers need {per_stage} storage buffers per shader stage, over the \
                         device's max_storage_buffers_per_shader_stage of {}",
                        limits.max_storage_buffers_per_shader_stage
                    )));
                }
                Ok(BvhTables::Buffers)
            }
            BvhTables::Auto => {
                let gpu = ctx.adapter.get_info().device_type != wgpu::DeviceType::Cpu;
                let room = limits.max_storage_buffers_per_shader_stage >= AUTO_BUFFERS_MIN_PER_STAGE;
                Ok(if gpu && room && fits { BvhTables::Buffers } else { BvhTables::Textures })
            }
        }
    }

    /// Layout entries of `bvh_nodes` and `bvh_tris` at `first_binding` and the binding after it.
    pub fn layout_entries(
        self,
        first_binding: u32,
        visibility: wgpu::ShaderStages,
    ) -> [wgpu::BindGroupLayoutEntry; 2] {
        let entry = |binding| wgpu::BindGroupLayoutEntry {
            visibility,
            ..match self {
                BvhTables::Buffers => super::resources::buffer_layout_entry(
                    binding,
                    visibility,
                    wgpu::BufferBindingType::Storage { read_only: true },
                ),
                _ => super::resources::storage_texture_layout_entry(
                    binding,
                    wgpu::TextureFormat::Rgba32Uint,
                    wgpu::StorageTextureAccess::ReadOnly,
                    wgpu::TextureViewDimension::D2,
                ),
            }
        };
        [entry(first_binding), entry(first_binding + 1)]
    }
}

impl std::str::FromStr for BvhTables {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        [BvhTables::Auto, BvhTables::Textures, BvhTables::Buffers]
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| {
                format!("unknown BVH table kind '{s}' (expected one of {})", Self::NAMES.join(", "))
            })
    }
}

/// One of the BVH's tables on the device, 16-byte elements in order.
enum BvhTable {
    Texture { texture: wgpu::Texture, view: wgpu::TextureView },
    Buffer(wgpu::Buffer),
}

impl BvhTable {
    fn new(ctx: &GpuContext, label: &str, data: &[u8], kind: BvhTables) -> Result<BvhTable, GpuError> {
        if kind == BvhTables::Buffers {
            return Ok(BvhTable::Buffer(ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: data,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
            })));
        }
        let texels = (data.len() / BVH_TEXEL_BYTES) as u64;
        // create checks it against the device's texture limits, naming it.
        let texture = linear_texture::create_storage(ctx, label, wgpu::TextureFormat::Rgba32Uint, texels)?;
        linear_texture::write(ctx, &texture, data);
        Ok(BvhTable::Texture { view: texture.create_view(&Default::default()), texture })
    }

    /// Writes `data` over the table's first bytes.
    fn write(&self, ctx: &GpuContext, data: &[u8]) {
        match self {
            BvhTable::Texture { texture, .. } => linear_texture::write(ctx, texture, data),
            BvhTable::Buffer(buffer) => ctx.queue.write_buffer(buffer, 0, data),
        }
    }

    fn bytes(&self) -> u64 {
        match self {
            BvhTable::Texture { texture, .. } => linear_texture::bytes(texture),
            BvhTable::Buffer(buffer) => buffer.size(),
        }
    }

    fn resource(&self) -> wgpu::BindingResource<'_> {
        match self {
            BvhTable::Texture { view, .. } => wgpu::BindingResource::TextureView(view),
            BvhTable::Buffer(buffer) => buffer.as_entire_binding(),
        }
    }
}

/// The BVH on the GPU, as `bvh.wgsl` expects it: `bvh_nodes` and `bvh_tris`, 16-byte elements (the
/// arrays' bytes in order) in read-only storage textures or buffers ([`BvhTables`]), and
/// `bvh_instances` as a storage buffer.
pub struct GpuBvh {
    nodes: BvhTable,
    triangles: BvhTable,
    /// Where the tables are (`Textures` or `Buffers`, never `Auto`).
    pub tables: BvhTables,
    /// At least one entry (zeroed and never read for a single-level BVH): no binding is zero-sized.
    pub instances: wgpu::Buffer,
    pub node_count: u32,
    pub triangle_count: u32,
    /// Whether it has instances (two levels): without, shaders compile the single-level traversal
    /// (`BVH_INSTANCES`, see `common/bvh.wgsl`).
    pub instanced: bool,
    /// Whether any triangle is alpha-tested: without one, shaders compile the traversal without the
    /// alpha test (`BVH_ALPHA_TESTS`).
    pub alpha_tested: bool,
}

impl GpuBvh {
    /// Uploads `bvh` with its tables where the context asks ([`GpuContext::bvh_tables`]).
    pub fn new(ctx: &GpuContext, bvh: &Bvh) -> Result<GpuBvh, GpuError> {
        Self::with_tables(ctx, bvh, ctx.bvh_tables)
    }

    /// Uploads `bvh` with its tables as `tables` says; fails with [`GpuError::OverLimit`] naming the
    /// table if one exceeds the device.
    pub fn with_tables(ctx: &GpuContext, bvh: &Bvh, tables: BvhTables) -> Result<GpuBvh, GpuError> {
        let nodes: &[u8] = bytemuck::cast_slice(&bvh.nodes);
        let tris: &[u8] = bytemuck::cast_slice(&bvh.triangles);
        let tables = tables.resolve(ctx, [nodes.len() as u64, tris.len() as u64])?;
        let (node_label, tri_label) = match tables {
            BvhTables::Buffers => ("BVH node buffer", "BVH triangle buffer"),
            _ => ("BVH node texture", "BVH triangle texture"),
        };
        // Allocation failures are reported asynchronously by wgpu; the scope turns them into a result.
        let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let node_table = BvhTable::new(ctx, node_label, nodes, tables)?;
        let tri_table = BvhTable::new(ctx, tri_label, tris, tables)?;
        let placeholder = [BvhInstance::zeroed()];
        let instances = if bvh.instances.is_empty() { &placeholder[..] } else { &bvh.instances[..] };
        let instance_buffer = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("bvh instances"),
            contents: bytemuck::cast_slice(instances),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Other(format!("allocating the BVH: {e}")));
        }
        Ok(GpuBvh {
            nodes: node_table,
            triangles: tri_table,
            tables,
            instances: instance_buffer,
            node_count: bvh.nodes.len() as u32,
            triangle_count: bvh.triangles.len() as u32,
            instanced: !bvh.instances.is_empty(),
            alpha_tested: bvh.has_alpha_tested(),
        })
    }

    /// `defines` plus the traversal this BVH needs (`BVH_INSTANCES`, `BVH_ALPHA_TESTS` and
    /// `BVH_TABLES_IN_BUFFERS`, see `common/bvh.wgsl`): every pipeline that traces it is built with them.
    pub fn defines(&self, defines: crate::shaders::Defines) -> crate::shaders::Defines {
        defines
            .bool("BVH_INSTANCES", self.instanced)
            .bool("BVH_ALPHA_TESTS", self.alpha_tested)
            .bool("BVH_TABLES_IN_BUFFERS", self.tables == BvhTables::Buffers)
    }

    /// Writes the top level and instances of `bvh` (placed anew) over those uploaded from it.
    pub fn update_top_level(&self, ctx: &GpuContext, top: &TopLevel) {
        self.nodes.write(ctx, bytemuck::cast_slice(&top.nodes));
        if !top.instances.is_empty() {
            ctx.queue.write_buffer(&self.instances, 0, bytemuck::cast_slice(&top.instances));
        }
    }

    /// Bytes of GPU memory the BVH takes (tables, a texture's last row's padding included, and
    /// instances).
    pub fn bytes(&self) -> u64 {
        self.nodes.bytes() + self.triangles.bytes() + self.instances.size()
    }

    /// Bind group entries for `bvh_nodes`, `bvh_tris` and `bvh_instances` at `first_binding` and the
    /// two bindings after it.
    pub fn bind_entries(&self, first_binding: u32) -> [wgpu::BindGroupEntry<'_>; 3] {
        [
            wgpu::BindGroupEntry { binding: first_binding, resource: self.nodes.resource() },
            wgpu::BindGroupEntry { binding: first_binding + 1, resource: self.triangles.resource() },
            wgpu::BindGroupEntry { binding: first_binding + 2, resource: self.instances.as_entire_binding() },
        ]
    }
}
