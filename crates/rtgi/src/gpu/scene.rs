//! Uploads a [`Scene`] to the GPU: vertex/index/material/light buffers, texture arrays, the environment,
//! the emissive-triangle table and the BVH, all behind one bind group (group 0, `common/scene.wgsl`).

use std::collections::HashMap;
use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec2, Vec3, Vec4};
use wgpu::util::DeviceExt;

use super::bvh::{Bvh, BvhTables, GpuBvh, InstancedBvh, SceneTriangles, TopLevel};
use super::resources::buffer_layout_entry;
use super::{GpuContext, GpuError, linear_texture};
use crate::scene::{AlphaMode, Environment, Light, Scene};

/// 32-byte vertex shared by the raster vertex stage and storage reads (`Vertex` in scene.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuVertex {
    pub position: [f32; 3],
    /// Material index in the low 24 bits; bit 31 set when the tangent's handedness is negative.
    pub material_flags: u32,
    /// Octahedral unit normal as snorm16x2.
    pub normal_oct: u32,
    pub tangent_oct: u32,
    pub uv: [f32; 2],
}

pub const MATERIAL_MASK: u32 = 0x00ff_ffff;
pub const TANGENT_FLIP_BIT: u32 = 0x8000_0000;

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuMaterial {
    pub base_color: [f32; 4],
    pub emissive: [f32; 3],
    pub normal_scale: f32,
    pub metallic: f32,
    pub roughness: f32,
    pub alpha_cutoff: f32,
    pub specular: f32,
    pub tex_base: i32,
    pub tex_metal_rough: i32,
    pub tex_emissive: i32,
    pub tex_normal: i32,
    /// The translucent medium under the surface (σ_a, σ_s' per scene unit, η), zero when opaque.
    pub medium_absorption: [f32; 3],
    pub medium_eta: f32,
    pub medium_scattering: [f32; 3],
    pub _pad_medium: f32,
}

pub const LIGHT_POINT: u32 = 0;
pub const LIGHT_SPOT: u32 = 1;
pub const LIGHT_DIRECTIONAL: u32 = 2;

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuLight {
    pub position: [f32; 3],
    pub kind: u32,
    pub direction: [f32; 3],
    pub shadow_layer: i32,
    pub intensity: [f32; 3],
    pub cos_outer: f32,
    pub cos_inner: f32,
    pub _pad: [f32; 3],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuEmissiveTriangle {
    pub triangle: u32,
    pub cdf: f32,
    pub area: f32,
    pub power: f32,
}

pub const ENV_NONE: u32 = 0;
pub const ENV_UNIFORM: u32 = 1;
pub const ENV_SKY: u32 = 2;
pub const ENV_MAP: u32 = 3;

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuSceneInfo {
    pub triangle_count: u32,
    pub light_count: u32,
    pub emissive_count: u32,
    pub env_kind: u32,
    pub env_radiance: [f32; 3],
    pub env_intensity: f32,
    pub sun_direction: [f32; 3],
    pub emissive_power: f32,
    pub sun_radiance: [f32; 3],
    pub _pad0: f32,
    pub ground_radiance: [f32; 3],
    pub _pad1: f32,
    pub bounds_min: [f32; 3],
    pub _pad2: f32,
    pub bounds_max: [f32; 3],
    pub _pad3: f32,
    /// Columns of the rotation [`Scene::environment_rotation`] (WGSL `mat3x3f`: each column padded to
    /// 16 bytes).
    pub world_from_environment: [[f32; 4]; 3],
}

/// The scene info's columns of `rotation`.
fn rotation_columns(rotation: glam::Quat) -> [[f32; 4]; 3] {
    let m = glam::Mat3::from_quat(rotation.normalize());
    [m.x_axis.extend(0.0).into(), m.y_axis.extend(0.0).into(), m.z_axis.extend(0.0).into()]
}

/// Size of the table the procedural sky is importance-sampled with.
pub const SKY_BAKE_WIDTH: u32 = 128;
pub const SKY_BAKE_HEIGHT: u32 = 64;

/// Evaluates `environment_radiance_unrotated` of `shaders/common/environment.wgsl` at the centre of every texel of a
/// `SKY_BAKE_WIDTH` × `SKY_BAKE_HEIGHT` equirectangular grid. Made once per scene upload, so a moving
/// sun re-bakes without compiling anything.
struct SkyBaker {
    pipeline: wgpu::ComputePipeline,
    out: wgpu::Buffer,
    out_group: wgpu::BindGroup,
}

const SKY_BAKE_COUNT: u64 = (SKY_BAKE_WIDTH * SKY_BAKE_HEIGHT) as u64;

impl SkyBaker {
    fn new(ctx: &GpuContext, scene_layout: &wgpu::BindGroupLayout) -> Result<SkyBaker, GpuError> {
        const SOURCE: &str = "#import common/environment.wgsl
@group(1) @binding(0) var<storage, read_write> baked: array<vec4f>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let i = id.x;
    if i >= BAKE_W * BAKE_H {
        return;
    }
    let uv = vec2f((f32(i % BAKE_W) + 0.5) / f32(BAKE_W), (f32(i / BAKE_W) + 0.5) / f32(BAKE_H));
    baked[i] = vec4f(environment_radiance_unrotated(equirect_direction(uv)), 1.0);
}";
        let device = &ctx.device;
        let count = SKY_BAKE_COUNT;
        let defines =
            crate::shaders::Defines::new().u32("BAKE_W", SKY_BAKE_WIDTH).u32("BAKE_H", SKY_BAKE_HEIGHT);
        let module = crate::shaders::create_module(ctx, "environment bake", SOURCE, &defines)
            .map_err(|e| GpuError::Other(e.to_string()))?;
        let out_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("environment bake"),
            entries: &[buffer_layout_entry(
                0,
                wgpu::ShaderStages::COMPUTE,
                wgpu::BufferBindingType::Storage { read_only: false },
            )],
        });
        let out = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("environment bake"),
            size: count * 16,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let out_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("environment bake"),
            layout: &out_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: out.as_entire_binding() }],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("environment bake"),
            bind_group_layouts: &[Some(scene_layout), Some(&out_layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("environment bake"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        Ok(SkyBaker { pipeline, out, out_group })
    }

    /// The sky of `scene_group`'s scene info as linear RGB, rows top (zenith) to bottom.
    fn bake(&self, ctx: &GpuContext, scene_group: &wgpu::BindGroup) -> Result<Vec<f32>, GpuError> {
        let (pipeline, out, out_group, count) = (&self.pipeline, &self.out, &self.out_group, SKY_BAKE_COUNT);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, scene_group, &[]);
            pass.set_bind_group(1, out_group, &[]);
            pass.dispatch_workgroups((count as u32).div_ceil(64), 1, 1);
        }
        ctx.queue.submit([encoder.finish()]);
        let bytes = super::readback::read_buffer(ctx, out, 0, count * 16)?;
        let rgba: &[f32] = bytemuck::cast_slice(&bytes);
        Ok(rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect())
    }
}

/// Largest texture layer edge; bigger images are downsampled (and a warning is recorded).
pub const MAX_TEXTURE_SIZE: u32 = 2048;

/// The CPU twin of `oct_encode` (math.wgsl): a unit vector to the octahedral square [-1, 1]².
pub fn oct_encode(n: Vec3) -> Vec2 {
    let n = n / (n.x.abs() + n.y.abs() + n.z.abs()).max(1e-20);
    if n.z >= 0.0 {
        Vec2::new(n.x, n.y)
    } else {
        let sign = |v: f32| if v >= 0.0 { 1.0 } else { -1.0 };
        Vec2::new((1.0 - n.y.abs()) * sign(n.x), (1.0 - n.x.abs()) * sign(n.y))
    }
}

/// The CPU twin of `oct_decode` (math.wgsl): a point of the octahedral square to a unit vector.
pub fn oct_decode(e: Vec2) -> Vec3 {
    let mut n = Vec3::new(e.x, e.y, 1.0 - e.x.abs() - e.y.abs());
    let t = (-n.z).clamp(0.0, 1.0);
    n.x += if n.x >= 0.0 { -t } else { t };
    n.y += if n.y >= 0.0 { -t } else { t };
    n.normalize()
}

fn pack_snorm16x2(v: Vec2) -> u32 {
    let q = |x: f32| ((x.clamp(-1.0, 1.0) * 32767.0).round() as i16) as u16 as u32;
    q(v.x) | (q(v.y) << 16)
}

/// Packs a unit vector for `unpack2x16snorm` + `oct_decode`.
pub fn pack_unit_vector(n: Vec3) -> u32 {
    pack_snorm16x2(oct_encode(n))
}

/// Everything about the scene that lives on the GPU.
pub struct GpuScene {
    pub info: GpuSceneInfo,
    pub vertex_buffer: wgpu::Buffer,
    pub index_buffer: wgpu::Buffer,
    pub index_count: u32,
    /// Each mesh's range in the index buffer, in scene order: per-mesh draws (the G-buffer's instance
    /// ids and object motion) use them.
    pub mesh_ranges: Vec<std::ops::Range<u32>>,
    pub material_buffer: wgpu::Buffer,
    pub light_buffer: wgpu::Buffer,
    /// The analytic lights as the GPU sees them: the one copy every pass reads (shadow layers assigned).
    pub lights: Vec<GpuLight>,
    /// Bumped whenever [`GpuScene::update_lights`] changes a light, so passes that render from the
    /// lights (shadow maps, RSMs) know to render again.
    pub lights_version: u64,
    /// Identifies the geometry: new with every upload and every [`GpuScene::move_meshes`], so state
    /// rendered from other geometry (shadow maps, RSMs) is never mistaken for current.
    pub geometry_version: u64,
    pub bind_group_layout: wgpu::BindGroupLayout,
    pub bind_group: wgpu::BindGroup,
    pub bvh_build_ms: f64,
    /// Bytes of all buffers and textures uploaded.
    pub memory_bytes: u64,
    /// Non-fatal findings during upload (e.g. downsampled textures).
    pub warnings: Vec<String>,
    /// ∫ luminance(L_env(ω)) dω over the sphere (W·m⁻²·sr⁻¹ · sr): the environment's weight when a
    /// technique chooses among light sources by power.
    pub environment_power: f32,
    /// Bumped whenever [`GpuScene::update_environment`] changes the environment.
    pub environment_version: u64,
    /// Side of the linear (normal, metallic-roughness) texture array's layers: see [`texture_layer_image`].
    pub linear_texture_size: u32,
    info_buffer: wgpu::Buffer,
    environment: wgpu::Texture,
    environment_cdf: wgpu::Texture,
    sky_baker: Option<SkyBaker>,
    bvh: GpuBvh,
    emissive_buffer: wgpu::Buffer,
    emission_pdf_buffer: wgpu::Buffer,
    moving: Option<MovingMeshes>,
}

struct TextureArrays {
    srgb: wgpu::Texture,
    linear: wgpu::Texture,
    bytes: u64,
}

/// Assigns texture-array layers to (texture, colour space) pairs used by materials.
struct LayerTable {
    srgb: Vec<u32>,
    linear: Vec<u32>,
    map: HashMap<(u32, bool), i32>,
}

impl LayerTable {
    fn layer(&mut self, texture: Option<crate::scene::TextureRef>, srgb: bool) -> i32 {
        let Some(t) = texture else { return -1 };
        let list = if srgb { &mut self.srgb } else { &mut self.linear };
        *self.map.entry((t.texture, srgb)).or_insert_with(|| {
            list.push(t.texture);
            (list.len() - 1) as i32
        })
    }
}

fn mip_chain(img: image::RgbaImage, levels: u32) -> Vec<image::RgbaImage> {
    let mut out = vec![img];
    for _ in 1..levels {
        let prev = &out[out.len() - 1];
        let (w, h) = ((prev.width() / 2).max(1), (prev.height() / 2).max(1));
        out.push(image::imageops::resize(prev, w, h, image::imageops::FilterType::Triangle));
    }
    out
}

/// The side of a texture array holding `layers` (indices into `Scene::textures`): every layer shares
/// it, the largest texture's side rounded up to a power of two, at most `MAX_TEXTURE_SIZE`.
pub fn texture_array_size(scene: &Scene, layers: &[u32]) -> u32 {
    layers
        .iter()
        .map(|&t| scene.textures[t as usize].width.max(scene.textures[t as usize].height))
        .max()
        .unwrap_or(1)
        .next_power_of_two()
        .min(MAX_TEXTURE_SIZE)
}

/// Texture `texture` of the scene as its array layer's level 0 holds it: resampled to `size`² (all
/// layers of an array share one size). CPU passes that must see the texels the GPU samples (the glint
/// histograms) read it from here.
pub fn texture_layer_image(scene: &Scene, texture: u32, size: u32) -> image::RgbaImage {
    let tex = &scene.textures[texture as usize];
    let src = image::RgbaImage::from_raw(tex.width, tex.height, tex.rgba8.clone())
        .unwrap_or_else(|| image::RgbaImage::from_pixel(1, 1, image::Rgba([255; 4])));
    if src.width() == size && src.height() == size {
        src
    } else {
        image::imageops::resize(&src, size, size, image::imageops::FilterType::Triangle)
    }
}

fn create_texture_array(
    ctx: &GpuContext,
    scene: &Scene,
    layers: &[u32],
    format: wgpu::TextureFormat,
    warnings: &mut Vec<String>,
) -> (wgpu::Texture, u64) {
    let size = texture_array_size(scene, layers);
    let levels = size.ilog2() + 1;
    let count = layers.len().max(1) as u32;
    let texture = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("scene textures"),
        size: wgpu::Extent3d { width: size, height: size, depth_or_array_layers: count },
        mip_level_count: levels,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    let mut bytes = 0u64;
    // An empty array still needs one layer to bind; white is the neutral texture.
    let images: Vec<image::RgbaImage> = if layers.is_empty() {
        vec![image::RgbaImage::from_pixel(1, 1, image::Rgba([255; 4]))]
    } else {
        layers.iter().map(|&t| texture_layer_image(scene, t, size)).collect()
    };
    for (layer, base) in images.into_iter().enumerate() {
        if let Some(&t) = layers.get(layer) {
            let tex = &scene.textures[t as usize];
            if tex.width.max(tex.height) > MAX_TEXTURE_SIZE {
                warnings.push(format!(
                    "texture layer {layer}: {}x{} downsampled to {size}x{size} (MAX_TEXTURE_SIZE)",
                    tex.width, tex.height
                ));
            }
        }
        for (level, img) in mip_chain(base, levels).iter().enumerate() {
            ctx.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &texture,
                    mip_level: level as u32,
                    origin: wgpu::Origin3d { x: 0, y: 0, z: layer as u32 },
                    aspect: wgpu::TextureAspect::All,
                },
                img.as_raw(),
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(4 * img.width()),
                    rows_per_image: Some(img.height()),
                },
                wgpu::Extent3d { width: img.width(), height: img.height(), depth_or_array_layers: 1 },
            );
            bytes += img.as_raw().len() as u64;
        }
    }
    (texture, bytes)
}

fn storage_layout_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    buffer_layout_entry(
        binding,
        wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE,
        wgpu::BufferBindingType::Storage { read_only: true },
    )
}

fn texture_layout_entry(
    binding: u32,
    view_dimension: wgpu::TextureViewDimension,
    sample_type: wgpu::TextureSampleType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        visibility: wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE,
        ..super::resources::texture_layout_entry(binding, sample_type, view_dimension)
    }
}

/// Storage buffers in bind group 0, visible to every stage, with the BVH's tables in textures: the
/// least any adapter must bind per stage (two more with them in buffers, see [`BvhTables`]).
pub const SCENE_STORAGE_BUFFERS: u32 = 7;

/// The entries of bind group 0 (`common/scene.wgsl`) with the BVH's tables as `tables` says.
fn scene_layout_entries(tables: BvhTables) -> [wgpu::BindGroupLayoutEntry; 15] {
    let all = wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE;
    const D2: wgpu::TextureViewDimension = wgpu::TextureViewDimension::D2;
    let filterable = wgpu::TextureSampleType::Float { filterable: true };
    let unfilterable = wgpu::TextureSampleType::Float { filterable: false };
    let bvh_tables = tables.layout_entries(5, all);
    [
        buffer_layout_entry(0, all, wgpu::BufferBindingType::Uniform),
        storage_layout_entry(1),
        storage_layout_entry(2),
        storage_layout_entry(3),
        storage_layout_entry(4),
        // The BVH's nodes and triangles (`common/bvh.wgsl`).
        bvh_tables[0],
        bvh_tables[1],
        storage_layout_entry(7),
        texture_layout_entry(8, wgpu::TextureViewDimension::D2Array, filterable),
        texture_layout_entry(9, wgpu::TextureViewDimension::D2Array, filterable),
        wgpu::BindGroupLayoutEntry {
            binding: 10,
            visibility: all,
            ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
            count: None,
        },
        texture_layout_entry(11, D2, unfilterable),
        storage_layout_entry(12),
        texture_layout_entry(13, D2, unfilterable),
        storage_layout_entry(14),
    ]
}

/// The layout of bind group 0 with the BVH's tables as `tables` says (`Textures` or `Buffers`); every
/// pipeline that imports `common/scene.wgsl` uses its scene's ([`GpuScene::bind_group_layout`]).
fn scene_bind_group_layout(device: &wgpu::Device, tables: BvhTables) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("scene"),
        entries: &scene_layout_entries(tables),
    })
}

/// Shadow-map (and RSM) layers a light of `kind` takes: six cube faces for a point light, one view for
/// spot and directional lights.
pub fn shadow_layer_count(kind: u32) -> i32 {
    match kind {
        LIGHT_POINT => 6,
        LIGHT_SPOT | LIGHT_DIRECTIONAL => 1,
        _ => 0,
    }
}

/// Converts scene lights to their GPU form. Each light's `shadow_layer` is its first layer in the
/// per-light view arrays (shadow maps, RSMs): the layers depend only on the lights' kinds, so they stay
/// fixed while lights move.
pub fn gpu_lights(lights: &[Light]) -> Vec<GpuLight> {
    let mut next_layer = 0;
    let mut gpu: Vec<GpuLight> = lights
        .iter()
        .map(|l| match *l {
            Light::Point { position, intensity } => GpuLight {
                position: position.into(),
                kind: LIGHT_POINT,
                direction: [0.0, -1.0, 0.0],
                shadow_layer: -1,
                intensity: intensity.into(),
                cos_outer: -1.0,
                cos_inner: -1.0,
                _pad: [0.0; 3],
            },
            Light::Spot { position, direction, intensity, inner_angle, outer_angle } => GpuLight {
                position: position.into(),
                kind: LIGHT_SPOT,
                direction: direction.normalize_or(Vec3::NEG_Y).into(),
                shadow_layer: -1,
                intensity: intensity.into(),
                cos_outer: outer_angle.cos(),
                cos_inner: inner_angle.cos(),
                _pad: [0.0; 3],
            },
            Light::Directional { direction, irradiance } => GpuLight {
                position: [0.0; 3],
                kind: LIGHT_DIRECTIONAL,
                direction: direction.normalize_or(Vec3::NEG_Y).into(),
                shadow_layer: -1,
                intensity: irradiance.into(),
                cos_outer: -1.0,
                cos_inner: -1.0,
                _pad: [0.0; 3],
            },
        })
        .collect();
    for light in &mut gpu {
        let layers = shadow_layer_count(light.kind);
        light.shadow_layer = if layers > 0 { next_layer } else { -1 };
        next_layer += layers;
    }
    gpu
}

pub(crate) fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// The GPU materials of `scene` and the texture-array layers they use, checked against the device's
/// layer limit.
fn gpu_materials(ctx: &GpuContext, scene: &Scene) -> Result<(Vec<GpuMaterial>, LayerTable), GpuError> {
    let mut table = LayerTable { srgb: Vec::new(), linear: Vec::new(), map: HashMap::new() };
    let materials: Vec<GpuMaterial> = scene
        .materials
        .iter()
        .map(|m| GpuMaterial {
            base_color: m.base_color.into(),
            emissive: m.emissive.into(),
            normal_scale: m.normal_scale,
            metallic: m.metallic,
            roughness: m.roughness,
            alpha_cutoff: match m.alpha_mode {
                AlphaMode::Mask { cutoff } => cutoff,
                AlphaMode::Opaque | AlphaMode::Blend => -1.0,
            },
            specular: m.specular,
            tex_base: table.layer(m.base_color_texture, true),
            tex_metal_rough: table.layer(m.metallic_roughness_texture, false),
            tex_emissive: table.layer(m.emissive_texture, true),
            tex_normal: table.layer(m.normal_texture, false),
            medium_absorption: m.subsurface.map_or([0.0; 3], |s| s.absorption.into()),
            medium_eta: m.subsurface.map_or(0.0, |s| s.eta),
            medium_scattering: m.subsurface.map_or([0.0; 3], |s| s.reduced_scattering.into()),
            _pad_medium: 0.0,
        })
        .collect();
    let max_layers = ctx.limits().max_texture_array_layers as usize;
    for (what, n) in [("sRGB", table.srgb.len()), ("linear", table.linear.len())] {
        if n > max_layers {
            return Err(GpuError::OverLimit(format!(
                "scene '{}' uses {n} {what} textures, over the device's max_texture_array_layers of {max_layers}",
                scene.name
            )));
        }
    }
    Ok((materials, table))
}

/// The scene's meshes concatenated in order: triangle t of the scene is `indices[3t..3t+3]`.
struct Geometry {
    vertices: Vec<GpuVertex>,
    indices: Vec<u32>,
    mesh_ranges: Vec<std::ops::Range<u32>>,
    /// Per mesh, its first vertex.
    vertex_bases: Vec<u32>,
}

/// A mesh's vertices as the GPU reads them.
fn mesh_vertices(mesh: &crate::scene::Mesh) -> impl Iterator<Item = GpuVertex> + '_ {
    (0..mesh.positions.len()).map(|i| {
        let t = mesh.tangents[i];
        let flip = if t.w < 0.0 { TANGENT_FLIP_BIT } else { 0 };
        GpuVertex {
            position: mesh.positions[i].into(),
            material_flags: (mesh.material & MATERIAL_MASK) | flip,
            normal_oct: pack_unit_vector(mesh.normals[i].normalize_or(Vec3::Y)),
            tangent_oct: pack_unit_vector(t.truncate().normalize_or(Vec3::X)),
            uv: mesh.uvs[i].into(),
        }
    })
}

fn pack_geometry(scene: &Scene, vertex_count: usize, triangle_count: usize) -> Geometry {
    let mut vertices = Vec::with_capacity(vertex_count);
    let mut indices = Vec::with_capacity(triangle_count * 3);
    let mut mesh_ranges = Vec::with_capacity(scene.meshes.len());
    let mut vertex_bases = Vec::with_capacity(scene.meshes.len());
    for mesh in &scene.meshes {
        let base = vertices.len() as u32;
        vertex_bases.push(base);
        mesh_ranges.push(indices.len() as u32..(indices.len() + mesh.indices.len()) as u32);
        vertices.extend(mesh_vertices(mesh));
        indices.extend(mesh.indices.iter().map(|i| i + base));
    }
    Geometry { vertices, indices, mesh_ranges, vertex_bases }
}

/// [`BvhParts::vertex_instances`] of a vertex of a static mesh.
pub const NO_INSTANCE: u32 = u32::MAX;

/// The parts of a two-level BVH (see [`crate::gpu::bvh::instances`]) as a technique that traces within
/// one part sees them.
pub struct BvhParts {
    /// Per vertex, the instance (index into the BVH's instances) holding it, or [`NO_INSTANCE`].
    pub vertex_instances: Vec<u32>,
    /// The node reference of the static meshes' bottom level, if any.
    pub static_root: Option<u32>,
}

/// A fresh [`GpuScene::geometry_version`]: unique across uploads and in-place moves, so state rendered
/// from other geometry (shadow maps, RSMs) is never mistaken for current.
fn next_geometry_version() -> u64 {
    static VERSIONS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    VERSIONS.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

/// What moving rigid meshes in place needs (see [`GpuScene::move_meshes`]).
struct MovingMeshes {
    /// Per mesh: whether it may move (it has a bottom level of its own).
    moving: Vec<bool>,
    top: TopLevel,
    vertex_bases: Vec<u32>,
    /// Bounds of the meshes that never move.
    static_bounds: crate::scene::Aabb,
}

/// The emissive triangles with their power CDF, and the per-material area density of emitted power.
struct Emitters {
    triangles: Vec<GpuEmissiveTriangle>,
    pdf: Vec<f32>,
    total_power: f64,
}

fn emitters(scene: &Scene) -> Emitters {
    let mut emissive = Vec::new();
    let mut tri_base = 0u32;
    for mesh in &scene.meshes {
        let mat = &scene.materials[mesh.material as usize];
        if mat.is_emissive() {
            // Power ∝ luminance of the emission factor × area (× mean texel of an emissive texture).
            let tex_mean = mat
                .emissive_texture
                .map_or(1.0, |t| mean_srgb_luminance(&scene.textures[t.texture as usize]));
            let radiance = luminance(mat.emissive) * tex_mean;
            for (k, tri) in mesh.indices.chunks_exact(3).enumerate() {
                let [a, b, c] = [0, 1, 2].map(|j| mesh.positions[tri[j] as usize]);
                let area = 0.5 * (b - a).cross(c - a).length();
                if area > 0.0 && radiance > 0.0 {
                    emissive.push(GpuEmissiveTriangle {
                        triangle: tri_base + k as u32,
                        cdf: 0.0,
                        area,
                        power: radiance * area * std::f32::consts::PI,
                    });
                }
            }
        }
        tri_base += (mesh.indices.len() / 3) as u32;
    }
    let total_power: f64 = emissive.iter().map(|e| f64::from(e.power)).sum();
    // power = L · A · π for a Lambertian emitter, so the area density of a point is L · π / total.
    let emission_pdf: Vec<f32> = scene
        .materials
        .iter()
        .map(|m| {
            if !m.is_emissive() || total_power <= 0.0 {
                return 0.0;
            }
            let tex_mean =
                m.emissive_texture.map_or(1.0, |t| mean_srgb_luminance(&scene.textures[t.texture as usize]));
            (f64::from(luminance(m.emissive) * tex_mean) * std::f64::consts::PI / total_power) as f32
        })
        .collect();
    let mut running = 0.0f64;
    for e in &mut emissive {
        running += f64::from(e.power);
        e.cdf = (running / total_power) as f32;
    }
    if let Some(last) = emissive.last_mut() {
        last.cdf = 1.0;
    }
    Emitters { triangles: emissive, pdf: emission_pdf, total_power }
}

/// Writes the environment's kind and analytic parameters (a map's intensity) into `info`.
fn environment_info(environment: &Environment, info: &mut GpuSceneInfo) {
    match environment {
        Environment::None => info.env_kind = ENV_NONE,
        Environment::Uniform(c) => {
            info.env_kind = ENV_UNIFORM;
            info.env_radiance = (*c).into();
        }
        Environment::Sky { sun_direction, sun_radiance, sky_radiance, ground_radiance } => {
            info.env_kind = ENV_SKY;
            info.sun_direction = sun_direction.normalize_or(Vec3::Y).into();
            info.sun_radiance = (*sun_radiance).into();
            info.env_radiance = (*sky_radiance).into();
            info.ground_radiance = (*ground_radiance).into();
        }
        Environment::Map(map) => {
            info.env_kind = ENV_MAP;
            info.env_intensity = map.intensity;
        }
    }
}

/// Width, height and RGBA texels of the environment texture.
type EnvironmentTexels = (u32, u32, Vec<f32>);

/// The environment's texels and sampling table as uploaded: a map's own, or a 1×1 placeholder that the
/// sky bake replaces. Sets `info`'s environment fields.
fn environment_tables(
    ctx: &GpuContext,
    environment: &Environment,
    info: &mut GpuSceneInfo,
) -> Result<(EnvironmentTexels, Vec<f32>), GpuError> {
    environment_info(environment, info);
    let Environment::Map(map) = environment else {
        return Ok(((1, 1, vec![0.0; 4]), vec![0.0; 4]));
    };
    let max = ctx.limits().max_texture_dimension_2d;
    if map.width > max || map.height > max {
        return Err(GpuError::OverLimit(format!(
            "environment map '{}' is {}x{}, over the device's max_texture_dimension_2d of {max}",
            map.path, map.width, map.height
        )));
    }
    let rgba: Vec<f32> = map.rgb.chunks_exact(3).flat_map(|c| [c[0], c[1], c[2], 1.0]).collect();
    Ok(((map.width, map.height, rgba), environment_cdf(map.width, map.height, &map.rgb)))
}

impl GpuScene {
    /// Uploads `scene`. Device limits are checked before any allocation.
    pub fn new(ctx: &GpuContext, scene: &Scene) -> Result<GpuScene, GpuError> {
        Self::with_moving_meshes(ctx, scene, &[])
    }

    /// Uploads `scene`, whose meshes flagged in `moving` may later move rigidly
    /// ([`GpuScene::move_meshes`]): each gets a bottom-level BVH of its own under a top level over
    /// instances; all other meshes share one static bottom level. With nothing moving the BVH is a
    /// single level, as [`GpuScene::new`] makes it.
    pub fn with_moving_meshes(
        ctx: &GpuContext,
        scene: &Scene,
        moving: &[bool],
    ) -> Result<GpuScene, GpuError> {
        scene.validate().map_err(|e| GpuError::Other(format!("invalid scene '{}': {e}", scene.name)))?;
        let mut warnings = Vec::new();
        let vertex_count = scene.vertex_count();
        let triangle_count = scene.triangle_count();
        if triangle_count == 0 {
            return Err(GpuError::Other(format!("scene '{}' has no triangles", scene.name)));
        }
        ctx.check_storage_size("the vertex buffer", (vertex_count * size_of::<GpuVertex>()) as u64)?;
        ctx.check_storage_size("the index buffer", (triangle_count * 12) as u64)?;

        let (materials, table) = gpu_materials(ctx, scene)?;

        let Geometry { vertices, indices, mesh_ranges, vertex_bases } =
            pack_geometry(scene, vertex_count, triangle_count);
        let Emitters { triangles: emissive, pdf: emission_pdf, total_power } = emitters(scene);

        let lights = gpu_lights(&scene.lights);
        let bounds = scene.bounds();
        let mut info = GpuSceneInfo {
            triangle_count: triangle_count as u32,
            light_count: lights.len() as u32,
            emissive_count: emissive.len() as u32,
            env_kind: ENV_NONE,
            env_radiance: [0.0; 3],
            env_intensity: 1.0,
            sun_direction: [0.0, 1.0, 0.0],
            emissive_power: total_power as f32,
            sun_radiance: [0.0; 3],
            _pad0: 0.0,
            ground_radiance: [0.0; 3],
            _pad1: 0.0,
            bounds_min: bounds.min.into(),
            _pad2: 0.0,
            bounds_max: bounds.max.into(),
            _pad3: 0.0,
            world_from_environment: rotation_columns(scene.environment_rotation),
        };
        let (mut env_texels, env_cdf) = environment_tables(ctx, &scene.environment, &mut info)?;

        let device = &ctx.device;
        let storage =
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC;
        let buffer = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
            // wgpu rejects zero-sized storage bindings: pad empty tables to one (zeroed) element of
            // any of the structs above.
            let padded;
            let contents = if contents.is_empty() {
                padded = vec![0u8; 256];
                &padded[..]
            } else {
                contents
            };
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let vertex_buffer =
            buffer("vertices", bytemuck::cast_slice(&vertices), storage | wgpu::BufferUsages::VERTEX);
        let index_buffer =
            buffer("indices", bytemuck::cast_slice(&indices), storage | wgpu::BufferUsages::INDEX);
        let material_buffer = buffer("materials", bytemuck::cast_slice(&materials), storage);
        let light_buffer = buffer("lights", bytemuck::cast_slice(&lights), storage);
        let emissive_buffer = buffer("emissive triangles", bytemuck::cast_slice(&emissive), storage);
        let emission_pdf_buffer = buffer("emission pdf", bytemuck::cast_slice(&emission_pdf), storage);
        let env_cdf_texture = |cdf: &[f32]| -> Result<wgpu::Texture, GpuError> {
            let texture = linear_texture::create(
                ctx,
                "the environment map's sampling table",
                wgpu::TextureFormat::R32Float,
                cdf.len() as u64,
            )?;
            linear_texture::write(ctx, &texture, bytemuck::cast_slice(cdf));
            Ok(texture)
        };
        let env_cdf_table = env_cdf_texture(&env_cdf)?;
        let info_buffer = buffer(
            "scene info",
            bytemuck::bytes_of(&info),
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );

        let t0 = Instant::now();
        let mut moving_meshes = None;
        let gpu_bvh = if moving.iter().any(|&m| m) {
            let tris = SceneTriangles::from_scene(scene);
            let two_level = InstancedBvh::build(&tris, moving)?;
            let gpu_bvh = GpuBvh::new(ctx, &two_level.bvh)?;
            let mut static_bounds = crate::scene::Aabb::EMPTY;
            for (mesh, _) in
                scene.meshes.iter().zip(moving.iter().chain(std::iter::repeat(&false))).filter(|(_, m)| !**m)
            {
                for p in &mesh.positions {
                    static_bounds.grow(*p);
                }
            }
            moving_meshes = Some(MovingMeshes {
                moving: (0..scene.meshes.len()).map(|m| moving.get(m).copied().unwrap_or(false)).collect(),
                top: two_level.top,
                vertex_bases,
                static_bounds,
            });
            gpu_bvh
        } else {
            GpuBvh::new(ctx, &Bvh::from_scene(scene)?)?
        };
        let bvh_build_ms = t0.elapsed().as_secs_f64() * 1e3;

        let (srgb_layers, linear_layers) = (table.srgb.clone(), table.linear.clone());
        let (srgb, srgb_bytes) = create_texture_array(
            ctx,
            scene,
            &srgb_layers,
            wgpu::TextureFormat::Rgba8UnormSrgb,
            &mut warnings,
        );
        let (linear, linear_bytes) =
            create_texture_array(ctx, scene, &linear_layers, wgpu::TextureFormat::Rgba8Unorm, &mut warnings);
        let textures = TextureArrays { srgb, linear, bytes: srgb_bytes + linear_bytes };
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("scene textures"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            address_mode_w: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });

        let layout = scene_bind_group_layout(device, gpu_bvh.tables);
        let array_view = |t: &wgpu::Texture| {
            t.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            })
        };
        let srgb_view = array_view(&textures.srgb);
        let linear_view = array_view(&textures.linear);
        let create_env = |width: u32, height: u32, rgba: &[f32]| {
            device.create_texture_with_data(
                &ctx.queue,
                &wgpu::TextureDescriptor {
                    label: Some("environment map"),
                    size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::Rgba32Float,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                    view_formats: &[],
                },
                wgpu::util::TextureDataOrder::LayerMajor,
                bytemuck::cast_slice(rgba),
            )
        };
        let make_bind_group = |env: &wgpu::Texture, env_cdf: &wgpu::Texture| {
            let env_view = env.create_view(&Default::default());
            let env_cdf_view = env_cdf.create_view(&Default::default());
            let [bvh_nodes, bvh_tris, bvh_instances] = gpu_bvh.bind_entries(5);
            let bvh_instances = wgpu::BindGroupEntry { binding: 14, ..bvh_instances };
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("scene"),
                layout: &layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: info_buffer.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: vertex_buffer.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 2, resource: index_buffer.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 3, resource: material_buffer.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 4, resource: light_buffer.as_entire_binding() },
                    bvh_nodes,
                    bvh_tris,
                    wgpu::BindGroupEntry { binding: 7, resource: emissive_buffer.as_entire_binding() },
                    wgpu::BindGroupEntry {
                        binding: 8,
                        resource: wgpu::BindingResource::TextureView(&srgb_view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 9,
                        resource: wgpu::BindingResource::TextureView(&linear_view),
                    },
                    wgpu::BindGroupEntry { binding: 10, resource: wgpu::BindingResource::Sampler(&sampler) },
                    wgpu::BindGroupEntry {
                        binding: 11,
                        resource: wgpu::BindingResource::TextureView(&env_view),
                    },
                    wgpu::BindGroupEntry { binding: 12, resource: emission_pdf_buffer.as_entire_binding() },
                    wgpu::BindGroupEntry {
                        binding: 13,
                        resource: wgpu::BindingResource::TextureView(&env_cdf_view),
                    },
                    bvh_instances,
                ],
            })
        };
        let mut env = create_env(env_texels.0, env_texels.1, &env_texels.2);
        let mut env_cdf_table = env_cdf_table;
        let mut bind_group = make_bind_group(&env, &env_cdf_table);
        let mut sky_baker = None;
        if info.env_kind == ENV_SKY {
            // The procedural sky is importance-sampled through a table baked from the shader's own sky
            // function (one source of truth); its radiance stays analytic.
            let baker = SkyBaker::new(ctx, &layout)?;
            let baked = baker.bake(ctx, &bind_group)?;
            sky_baker = Some(baker);
            let cdf = environment_cdf(SKY_BAKE_WIDTH, SKY_BAKE_HEIGHT, &baked);
            let rgba: Vec<f32> = baked.chunks_exact(3).flat_map(|c| [c[0], c[1], c[2], 1.0]).collect();
            env = create_env(SKY_BAKE_WIDTH, SKY_BAKE_HEIGHT, &rgba);
            env_cdf_table = env_cdf_texture(&cdf)?;
            bind_group = make_bind_group(&env, &env_cdf_table);
            env_texels = (SKY_BAKE_WIDTH, SKY_BAKE_HEIGHT, rgba);
        }
        let memory_bytes = vertex_buffer.size()
            + index_buffer.size()
            + material_buffer.size()
            + light_buffer.size()
            + emissive_buffer.size()
            + emission_pdf_buffer.size()
            + linear_texture::bytes(&env_cdf_table)
            + info_buffer.size()
            + gpu_bvh.bytes()
            + textures.bytes
            + (env_texels.2.len() * 4) as u64;
        let environment_power = match info.env_kind {
            ENV_UNIFORM => luminance(Vec3::from(info.env_radiance)) * 4.0 * std::f32::consts::PI,
            ENV_SKY | ENV_MAP => {
                let (w, h, rgba) = (&env_texels.0, &env_texels.1, &env_texels.2);
                let scale = if info.env_kind == ENV_MAP { info.env_intensity } else { 1.0 };
                scale * equirect_integral(*w, *h, rgba)
            }
            _ => 0.0,
        };
        Ok(GpuScene {
            info,
            vertex_buffer,
            index_buffer,
            index_count: indices.len() as u32,
            mesh_ranges,
            material_buffer,
            light_buffer,
            lights,
            lights_version: 0,
            geometry_version: next_geometry_version(),
            bind_group_layout: layout,
            bind_group,
            bvh_build_ms,
            memory_bytes,
            warnings,
            environment_power,
            environment_version: 0,
            linear_texture_size: texture_array_size(scene, &linear_layers),
            info_buffer,
            environment: env,
            environment_cdf: env_cdf_table,
            sky_baker,
            bvh: gpu_bvh,
            emissive_buffer,
            emission_pdf_buffer,
            moving: moving_meshes,
        })
    }

    /// Whether the BVH has two levels (meshes that may move).
    pub fn has_instances(&self) -> bool {
        self.moving.is_some()
    }

    /// The parts of the two-level BVH a vertex's rays may be limited to, for transfer precomputed per
    /// rigid part (prt's self-transfer), for the `vertex_count` vertices of the uploaded scene; `None`
    /// without moving meshes.
    pub fn bvh_parts(&self, vertex_count: usize) -> Option<BvhParts> {
        let moving = self.moving.as_ref()?;
        let mut vertex_instances = vec![NO_INSTANCE; vertex_count];
        for (instance, &m) in moving.top.instance_meshes.iter().enumerate() {
            let start = moving.vertex_bases[m] as usize;
            let end = moving.vertex_bases.get(m + 1).map_or(vertex_count, |&b| b as usize);
            vertex_instances[start..end].fill(instance as u32);
        }
        Some(BvhParts { vertex_instances, static_root: moving.top.static_root() })
    }

    /// Per BVH instance, the linear part of its map from world space to the space its geometry was
    /// uploaded in, as placed now (empty without moving meshes).
    pub fn instance_world_to_object(&self) -> Vec<glam::Mat3> {
        let Some(moving) = &self.moving else { return Vec::new() };
        moving
            .top
            .instances
            .iter()
            .map(|i| {
                let [x, y, z] = i.world_to_object;
                glam::Mat3::from_cols_array(&[x[0], y[0], z[0], x[1], y[1], z[1], x[2], y[2], z[2]])
            })
            .collect()
    }

    /// `defines` plus the BVH variant this scene needs (`BVH_INSTANCES`, `BVH_ALPHA_TESTS` and
    /// `BVH_TABLES_IN_BUFFERS`, see `common/bvh.wgsl`): every pipeline that traces rays is built with
    /// them.
    pub fn bvh_defines(&self, defines: crate::shaders::Defines) -> crate::shaders::Defines {
        self.bvh.defines(defines)
    }

    /// Where the BVH keeps its node and triangle tables (`Textures` or `Buffers`).
    pub fn bvh_tables(&self) -> BvhTables {
        self.bvh.tables
    }

    /// Moves meshes in place: `scene` is the uploaded scene posed anew, in which the meshes `moved`
    /// (flagged moving at upload) changed; `from_upload[m]` maps mesh m's geometry as uploaded to where
    /// it is now. Rewrites their vertices and indices, rebuilds the BVH's top level, the bounds and (when
    /// an emitter moved) the emitter table, and gives the geometry a new version. Returns `false` when
    /// the change cannot be made in place (a mesh moved that was uploaded as static, or an emitter
    /// scaled to nothing): the scene must then be uploaded anew.
    pub fn move_meshes(
        &mut self,
        ctx: &GpuContext,
        scene: &Scene,
        moved: &[usize],
        from_upload: &[Mat4],
    ) -> Result<bool, GpuError> {
        let Some(moving) = &mut self.moving else { return Ok(moved.is_empty()) };
        if moved.iter().any(|&m| !moving.moving.get(m).copied().unwrap_or(false))
            || scene.meshes.len() != moving.moving.len()
        {
            return Ok(false);
        }
        for &m in moved {
            let mesh = &scene.meshes[m];
            let base = moving.vertex_bases[m];
            let vertices: Vec<GpuVertex> = mesh_vertices(mesh).collect();
            // A mirroring transform flips the winding, so the indices are rewritten too.
            let indices: Vec<u32> = mesh.indices.iter().map(|i| i + base).collect();
            if !vertices.is_empty() {
                let offset = u64::from(base) * size_of::<GpuVertex>() as u64;
                ctx.queue.write_buffer(&self.vertex_buffer, offset, bytemuck::cast_slice(&vertices));
            }
            if !indices.is_empty() {
                let offset = u64::from(self.mesh_ranges[m].start) * 4;
                ctx.queue.write_buffer(&self.index_buffer, offset, bytemuck::cast_slice(&indices));
            }
        }
        let transforms: Vec<Mat4> = moving
            .top
            .instance_meshes
            .iter()
            .map(|&m| from_upload.get(m).copied().unwrap_or(Mat4::IDENTITY))
            .collect();
        moving.top.place(&transforms);
        self.bvh.update_top_level(ctx, &moving.top);

        let mut info = self.info;
        let mut bounds = moving.static_bounds;
        for (mesh, _) in scene.meshes.iter().zip(&moving.moving).filter(|(_, m)| **m) {
            for p in &mesh.positions {
                bounds.grow(*p);
            }
        }
        info.bounds_min = bounds.min.into();
        info.bounds_max = bounds.max.into();
        let emitter_moved = moved.iter().any(|&m| {
            scene.materials.get(scene.meshes[m].material as usize).is_some_and(|mat| mat.is_emissive())
        });
        if emitter_moved {
            // Areas (so powers and the sampling CDF) change under scaling; the triangles stay the same.
            let Emitters { triangles, pdf, total_power } = emitters(scene);
            if triangles.len() as u32 != info.emissive_count {
                return Ok(false);
            }
            if !triangles.is_empty() {
                ctx.queue.write_buffer(&self.emissive_buffer, 0, bytemuck::cast_slice(&triangles));
            }
            if !pdf.is_empty() {
                ctx.queue.write_buffer(&self.emission_pdf_buffer, 0, bytemuck::cast_slice(&pdf));
            }
            info.emissive_power = total_power as f32;
        }
        if bytemuck::bytes_of(&info) != bytemuck::bytes_of(&self.info) {
            ctx.queue.write_buffer(&self.info_buffer, 0, bytemuck::bytes_of(&info));
            self.info = info;
        }
        self.geometry_version = next_geometry_version();
        Ok(true)
    }

    /// Changes the environment in place where its kind stays and its tables keep their size: a sky
    /// whose sun (or colours) moved is re-baked into the same texture and sampling table, a uniform
    /// colour rewrites the scene info. Returns `false` for any other change (a new upload is needed).
    pub fn update_environment(
        &mut self,
        ctx: &GpuContext,
        environment: &Environment,
    ) -> Result<bool, GpuError> {
        let same_kind = matches!(
            (environment, self.info.env_kind),
            (Environment::None, ENV_NONE)
                | (Environment::Uniform(_), ENV_UNIFORM)
                | (Environment::Sky { .. }, ENV_SKY)
        );
        if !same_kind {
            return Ok(false);
        }
        let mut info = self.info;
        environment_info(environment, &mut info);
        if bytemuck::bytes_of(&info) == bytemuck::bytes_of(&self.info) {
            return Ok(true);
        }
        ctx.queue.write_buffer(&self.info_buffer, 0, bytemuck::bytes_of(&info));
        self.info = info;
        self.environment_power = match &self.sky_baker {
            Some(baker) => {
                let baked = baker.bake(ctx, &self.bind_group)?;
                let cdf = environment_cdf(SKY_BAKE_WIDTH, SKY_BAKE_HEIGHT, &baked);
                let rgba: Vec<f32> = baked.chunks_exact(3).flat_map(|c| [c[0], c[1], c[2], 1.0]).collect();
                ctx.queue.write_texture(
                    self.environment.as_image_copy(),
                    bytemuck::cast_slice(&rgba),
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(SKY_BAKE_WIDTH * 16),
                        rows_per_image: Some(SKY_BAKE_HEIGHT),
                    },
                    self.environment.size(),
                );
                linear_texture::write(ctx, &self.environment_cdf, bytemuck::cast_slice(&cdf));
                equirect_integral(SKY_BAKE_WIDTH, SKY_BAKE_HEIGHT, &rgba)
            }
            None => luminance(Vec3::from(info.env_radiance)) * 4.0 * std::f32::consts::PI,
        };
        self.environment_version += 1;
        Ok(true)
    }

    /// Turns the environment to `rotation` ([`Scene::environment_rotation`]): only the scene info
    /// changes, since the environment's texture and sampling table stay in its own frame. Returns
    /// whether anything changed.
    pub fn rotate_environment(&mut self, ctx: &GpuContext, rotation: glam::Quat) -> bool {
        let columns = rotation_columns(rotation);
        if columns == self.info.world_from_environment {
            return false;
        }
        self.info.world_from_environment = columns;
        ctx.queue.write_buffer(&self.info_buffer, 0, bytemuck::bytes_of(&self.info));
        true
    }

    /// The environment's current turn ([`Scene::environment_rotation`]) as a rotation matrix.
    pub fn world_from_environment(&self) -> glam::Mat3 {
        let [x, y, z] = self.info.world_from_environment.map(|c| Vec4::from(c).truncate());
        glam::Mat3::from_cols(x, y, z)
    }

    /// The scene bounds the upload was made with (what shadow maps and RSMs frame).
    pub fn bounds(&self) -> crate::scene::Aabb {
        crate::scene::Aabb { min: self.info.bounds_min.into(), max: self.info.bounds_max.into() }
    }

    /// Moves the analytic lights: `lights` must be the scene's lights posed anew (same count and kinds,
    /// so shadow layers and buffer sizes stay). Rewrites the light buffer only when something changed.
    pub fn update_lights(&mut self, ctx: &GpuContext, lights: &[Light]) -> Result<bool, GpuError> {
        let posed = gpu_lights(lights);
        if posed.len() != self.lights.len() || posed.iter().zip(&self.lights).any(|(a, b)| a.kind != b.kind) {
            return Err(GpuError::Other(format!(
                "the posed scene has {} lights of other kinds than the {} uploaded; lights cannot be added, \
                 removed or change type during an animation",
                posed.len(),
                self.lights.len()
            )));
        }
        if bytemuck::cast_slice::<GpuLight, u8>(&posed) == bytemuck::cast_slice::<GpuLight, u8>(&self.lights)
        {
            return Ok(false);
        }
        if !posed.is_empty() {
            ctx.queue.write_buffer(&self.light_buffer, 0, bytemuck::cast_slice(&posed));
        }
        self.lights = posed;
        self.lights_version += 1;
        Ok(true)
    }

    /// Vertex buffer layout for raster passes (matches [`GpuVertex`]).
    pub fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
        const ATTRIBUTES: [wgpu::VertexAttribute; 5] = wgpu::vertex_attr_array![
            0 => Float32x3, 1 => Uint32, 2 => Uint32, 3 => Uint32, 4 => Float32x2
        ];
        wgpu::VertexBufferLayout {
            array_stride: size_of::<GpuVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &ATTRIBUTES,
        }
    }
}

/// The sampling table of an equirectangular map, proportional to luminance × sin θ (the solid angle of a
/// texel row): `height` marginal CDF values over rows, then `width` conditional CDF values per row, each
/// running sum normalised to end at 1.
pub fn environment_cdf(width: u32, height: u32, rgb: &[f32]) -> Vec<f32> {
    let (w, h) = (width as usize, height as usize);
    let mut table = vec![0.0f32; h + w * h];
    let mut row_sums = vec![0.0f64; h];
    for y in 0..h {
        let sin_theta = ((y as f64 + 0.5) / h as f64 * std::f64::consts::PI).sin();
        let mut running = 0.0f64;
        for x in 0..w {
            let i = (y * w + x) * 3;
            let l = f64::from(luminance(Vec3::new(rgb[i], rgb[i + 1], rgb[i + 2])).max(0.0));
            running += l * sin_theta;
            table[h + y * w + x] = running as f32;
        }
        row_sums[y] = running;
        for x in 0..w {
            // A black row is sampled uniformly (it is never chosen by the marginal anyway).
            let v = &mut table[h + y * w + x];
            *v = if running > 0.0 { (f64::from(*v) / running) as f32 } else { (x + 1) as f32 / w as f32 };
        }
    }
    let total: f64 = row_sums.iter().sum();
    let mut running = 0.0f64;
    for y in 0..h {
        running += row_sums[y];
        table[y] = if total > 0.0 { (running / total) as f32 } else { (y + 1) as f32 / h as f32 };
    }
    table
}

/// ∫ luminance dω of an equirectangular RGBA map (rows top to bottom), texel centres as the quadrature.
fn equirect_integral(width: u32, height: u32, rgba: &[f32]) -> f32 {
    let (w, h) = (width as usize, height as usize);
    let texel_angle = (2.0 * std::f64::consts::PI / w as f64) * (std::f64::consts::PI / h as f64);
    let mut sum = 0.0f64;
    for y in 0..h {
        let sin_theta = ((y as f64 + 0.5) / h as f64 * std::f64::consts::PI).sin();
        for x in 0..w {
            let i = (y * w + x) * 4;
            sum += f64::from(luminance(Vec3::new(rgba[i], rgba[i + 1], rgba[i + 2])).max(0.0)) * sin_theta;
        }
    }
    (sum * texel_angle) as f32
}

pub(crate) fn mean_srgb_luminance(t: &crate::scene::Texture) -> f32 {
    let decode = |c: u8| {
        let c = f32::from(c) / 255.0;
        if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
    };
    let n = (t.width * t.height).max(1) as f64;
    let sum: f64 = t
        .rgba8
        .chunks_exact(4)
        .map(|p| f64::from(luminance(Vec3::new(decode(p[0]), decode(p[1]), decode(p[2])))))
        .sum();
    (sum / n) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::frame::{FrameUniforms, ShadowView};
    use crate::shaders::layout::assert_layout;
    use crate::shaders::{Defines, validate};
    use std::mem::offset_of;

    #[test]
    fn scene_storage_buffer_count_matches_the_layout() {
        let storage = |tables| {
            scene_layout_entries(tables)
                .iter()
                .filter(|e| {
                    matches!(
                        e.ty,
                        wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Storage { .. }, .. }
                    )
                })
                .count() as u32
        };
        assert_eq!(storage(BvhTables::Textures), SCENE_STORAGE_BUFFERS);
        assert_eq!(storage(BvhTables::Buffers), SCENE_STORAGE_BUFFERS + 2);
    }

    /// Pipelines that trace get the traversal the scene needs: the instance branches only with moving
    /// meshes, the alpha test only with alpha-tested triangles (lavapipe runs either at full cost even
    /// where no lane takes it: `common/bvh.wgsl`).
    #[test]
    fn the_traversal_variant_follows_the_scene() {
        let ctx = GpuContext::new(&crate::gpu::GpuOptions::default()).expect("a GPU adapter");
        let defines = |gpu: &GpuScene| {
            let text = crate::shaders::compose("t", "", &gpu.bvh_defines(Defines::new())).expect("compose");
            (
                text.contains("const BVH_INSTANCES: bool = true;"),
                text.contains("const BVH_ALPHA_TESTS: bool = true;"),
            )
        };
        let mut scene = crate::scene::builtin::build("cornell", &[]).expect("scene");
        assert_eq!(defines(&GpuScene::new(&ctx, &scene).expect("upload")), (false, false));
        let mut moving = vec![false; scene.meshes.len()];
        moving[0] = true;
        assert_eq!(
            defines(&GpuScene::with_moving_meshes(&ctx, &scene, &moving).expect("upload")),
            (true, false)
        );
        let masked = scene.meshes[0].material as usize;
        scene.materials[masked].alpha_mode = crate::scene::AlphaMode::Mask { cutoff: 0.5 };
        assert_eq!(defines(&GpuScene::new(&ctx, &scene).expect("upload")), (false, true));
        assert_eq!(
            defines(&GpuScene::with_moving_meshes(&ctx, &scene, &moving).expect("upload")),
            (true, true)
        );
    }

    /// Moving meshes in place (a mirrored, rotated box and a scaled, rotated area light) leaves the
    /// vertex, index and emitter buffers and the scene info exactly as a fresh upload of the moved scene
    /// makes them; the BVH differs by design (instances) and is checked in `gpu/bvh`.
    #[test]
    fn moving_meshes_in_place_matches_a_fresh_upload_of_the_moved_scene() {
        use glam::Quat;
        let ctx = GpuContext::new(&crate::gpu::GpuOptions::default()).expect("a GPU adapter");
        let scene = crate::scene::builtin::build("cornell", &[]).expect("scene");
        let n = scene.meshes.len();
        let is_emitter = |m: usize| scene.materials[scene.meshes[m].material as usize].is_emissive();
        let light = (0..n).find(|&m| is_emitter(m)).expect("cornell has an area light");
        let object = (0..n).rev().find(|&m| !is_emitter(m)).expect("cornell has objects");
        let fixed = (0..n).find(|&m| m != light && m != object).expect("a static mesh");
        let mut moving = vec![false; n];
        moving[light] = true;
        moving[object] = true;
        let mut gpu = GpuScene::with_moving_meshes(&ctx, &scene, &moving).expect("upload");

        let mut from_upload = vec![Mat4::IDENTITY; n];
        from_upload[light] = Mat4::from_scale_rotation_translation(
            Vec3::new(1.5, 1.0, 0.5),
            Quat::from_rotation_y(0.3),
            Vec3::new(0.1, -0.05, 0.0),
        );
        from_upload[object] = Mat4::from_scale_rotation_translation(
            Vec3::new(-1.0, 1.0, 1.0),
            Quat::from_rotation_y(0.7),
            Vec3::new(0.05, 0.0, 0.1),
        );
        let mut posed = scene.clone();
        for m in [light, object] {
            posed.meshes[m] = scene.meshes[m].transformed(from_upload[m]);
        }
        let version = gpu.geometry_version;
        assert!(gpu.move_meshes(&ctx, &posed, &[light, object], &from_upload).expect("move"));
        assert_ne!(gpu.geometry_version, version);

        let fresh = GpuScene::new(&ctx, &posed).expect("upload");
        assert_eq!(bytemuck::bytes_of(&gpu.info), bytemuck::bytes_of(&fresh.info), "scene info");
        assert!(gpu.info.emissive_power != GpuScene::new(&ctx, &scene).expect("upload").info.emissive_power);
        for (name, a, b) in [
            ("vertices", &gpu.vertex_buffer, &fresh.vertex_buffer),
            ("indices", &gpu.index_buffer, &fresh.index_buffer),
            ("emissive triangles", &gpu.emissive_buffer, &fresh.emissive_buffer),
            ("emission pdf", &gpu.emission_pdf_buffer, &fresh.emission_pdf_buffer),
        ] {
            let read =
                |b: &wgpu::Buffer| super::super::readback::read_buffer(&ctx, b, 0, b.size()).expect("read");
            assert!(read(a) == read(b), "{name} differ from a fresh upload");
        }
        // A mesh uploaded as static cannot move in place: the caller must upload anew.
        assert!(!gpu.move_meshes(&ctx, &posed, &[fixed], &from_upload).expect("move"));
    }

    #[test]
    fn gpu_structs_match_wgsl() {
        let m = validate("layout", "#import common/frame.wgsl\n", &Defines::new());
        assert_layout(
            &m,
            "Vertex",
            size_of::<GpuVertex>(),
            &[
                ("position", offset_of!(GpuVertex, position)),
                ("material_flags", offset_of!(GpuVertex, material_flags)),
                ("normal_oct", offset_of!(GpuVertex, normal_oct)),
                ("tangent_oct", offset_of!(GpuVertex, tangent_oct)),
                ("uv", offset_of!(GpuVertex, uv)),
            ],
        );
        assert_layout(
            &m,
            "Material",
            size_of::<GpuMaterial>(),
            &[
                ("base_color", offset_of!(GpuMaterial, base_color)),
                ("emissive", offset_of!(GpuMaterial, emissive)),
                ("normal_scale", offset_of!(GpuMaterial, normal_scale)),
                ("metallic", offset_of!(GpuMaterial, metallic)),
                ("roughness", offset_of!(GpuMaterial, roughness)),
                ("alpha_cutoff", offset_of!(GpuMaterial, alpha_cutoff)),
                ("specular", offset_of!(GpuMaterial, specular)),
                ("tex_base", offset_of!(GpuMaterial, tex_base)),
                ("tex_metal_rough", offset_of!(GpuMaterial, tex_metal_rough)),
                ("tex_emissive", offset_of!(GpuMaterial, tex_emissive)),
                ("tex_normal", offset_of!(GpuMaterial, tex_normal)),
                ("medium_absorption", offset_of!(GpuMaterial, medium_absorption)),
                ("medium_eta", offset_of!(GpuMaterial, medium_eta)),
                ("medium_scattering", offset_of!(GpuMaterial, medium_scattering)),
            ],
        );
        assert_layout(
            &m,
            "Light",
            size_of::<GpuLight>(),
            &[
                ("position", offset_of!(GpuLight, position)),
                ("kind", offset_of!(GpuLight, kind)),
                ("direction", offset_of!(GpuLight, direction)),
                ("shadow_layer", offset_of!(GpuLight, shadow_layer)),
                ("intensity", offset_of!(GpuLight, intensity)),
                ("cos_outer", offset_of!(GpuLight, cos_outer)),
                ("cos_inner", offset_of!(GpuLight, cos_inner)),
            ],
        );
        assert_layout(
            &m,
            "EmissiveTriangle",
            size_of::<GpuEmissiveTriangle>(),
            &[
                ("triangle", offset_of!(GpuEmissiveTriangle, triangle)),
                ("cdf", offset_of!(GpuEmissiveTriangle, cdf)),
                ("area", offset_of!(GpuEmissiveTriangle, area)),
                ("power", offset_of!(GpuEmissiveTriangle, power)),
            ],
        );
        assert_layout(
            &m,
            "SceneInfo",
            size_of::<GpuSceneInfo>(),
            &[
                ("triangle_count", offset_of!(GpuSceneInfo, triangle_count)),
                ("env_kind", offset_of!(GpuSceneInfo, env_kind)),
                ("env_radiance", offset_of!(GpuSceneInfo, env_radiance)),
                ("env_intensity", offset_of!(GpuSceneInfo, env_intensity)),
                ("sun_direction", offset_of!(GpuSceneInfo, sun_direction)),
                ("emissive_power", offset_of!(GpuSceneInfo, emissive_power)),
                ("sun_radiance", offset_of!(GpuSceneInfo, sun_radiance)),
                ("ground_radiance", offset_of!(GpuSceneInfo, ground_radiance)),
                ("bounds_min", offset_of!(GpuSceneInfo, bounds_min)),
                ("bounds_max", offset_of!(GpuSceneInfo, bounds_max)),
                ("world_from_environment", offset_of!(GpuSceneInfo, world_from_environment)),
            ],
        );
        assert_layout(
            &m,
            "FrameUniforms",
            size_of::<FrameUniforms>(),
            &[
                ("view_proj", offset_of!(FrameUniforms, view_proj)),
                ("inv_view_proj", offset_of!(FrameUniforms, inv_view_proj)),
                ("camera_position", offset_of!(FrameUniforms, camera_position)),
                ("prev_view_proj", offset_of!(FrameUniforms, prev_view_proj)),
                ("frame_counter", offset_of!(FrameUniforms, frame_counter)),
                ("size", offset_of!(FrameUniforms, size)),
                ("seed", offset_of!(FrameUniforms, seed)),
                ("shadow_filter_radius", offset_of!(FrameUniforms, shadow_filter_radius)),
                ("shadow_depth_bias", offset_of!(FrameUniforms, shadow_depth_bias)),
                ("shadow_normal_offset", offset_of!(FrameUniforms, shadow_normal_offset)),
                ("shadow_map_size", offset_of!(FrameUniforms, shadow_map_size)),
                ("sample_index", offset_of!(FrameUniforms, sample_index)),
                ("jitter", offset_of!(FrameUniforms, jitter)),
                ("time", offset_of!(FrameUniforms, time)),
                ("delta_time", offset_of!(FrameUniforms, delta_time)),
                ("history_valid", offset_of!(FrameUniforms, history_valid)),
            ],
        );
        assert_layout(
            &m,
            "ShadowView",
            size_of::<ShadowView>(),
            &[("view_proj", offset_of!(ShadowView, view_proj)), ("params", offset_of!(ShadowView, params))],
        );
    }

    #[test]
    fn light_and_environment_kinds_agree_with_wgsl() {
        let m = validate("kinds", "#import common/scene.wgsl\n", &Defines::new());
        crate::shaders::layout::assert_u32_constants(
            &m,
            &[
                ("LIGHT_POINT", LIGHT_POINT),
                ("LIGHT_SPOT", LIGHT_SPOT),
                ("LIGHT_DIRECTIONAL", LIGHT_DIRECTIONAL),
                ("ENV_NONE", ENV_NONE),
                ("ENV_UNIFORM", ENV_UNIFORM),
                ("ENV_SKY", ENV_SKY),
                ("ENV_MAP", ENV_MAP),
            ],
        );
    }

    #[test]
    fn unit_vectors_survive_packing() {
        for i in 0..1000 {
            let a = i as f32 * 0.7;
            let b = (i as f32 * 0.37).sin();
            let n = Vec3::new(a.cos() * (1.0 - b * b).sqrt(), b, a.sin() * (1.0 - b * b).sqrt()).normalize();
            let p = pack_unit_vector(n);
            let unpack = |x: u32| (x as u16 as i16) as f32 / 32767.0;
            let e = Vec2::new(unpack(p), unpack(p >> 16));
            // Octahedral decode, as in math.wgsl.
            let mut d = Vec3::new(e.x, e.y, 1.0 - e.x.abs() - e.y.abs());
            let t = (-d.z).clamp(0.0, 1.0);
            d.x += if d.x >= 0.0 { -t } else { t };
            d.y += if d.y >= 0.0 { -t } else { t };
            assert!(d.normalize().dot(n) > 0.99999, "{n} -> {d}");
        }
    }
}
