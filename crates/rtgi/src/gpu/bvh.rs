//! TEMPORARY stand-in for the BVH (replaced by the BVH branch): a flat triangle list.

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use super::{GpuContext, GpuError};
use crate::scene::Scene;

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct BvhNode {
    pub aabb_min: [f32; 3],
    pub left_first: u32,
    pub aabb_max: [f32; 3],
    pub count: u32,
}

pub struct Bvh {
    pub nodes: Vec<BvhNode>,
    pub triangles: Vec<[f32; 4]>,
}

pub fn build_for_scene(scene: &Scene) -> Bvh {
    let mut triangles = Vec::new();
    let mut id = 0u32;
    for m in &scene.meshes {
        for tri in m.indices.chunks_exact(3) {
            for (k, &i) in tri.iter().enumerate() {
                let p = m.positions[i as usize];
                let w = if k == 0 { f32::from_bits(id) } else { 0.0 };
                triangles.push([p.x, p.y, p.z, w]);
            }
            id += 1;
        }
    }
    Bvh {
        nodes: vec![BvhNode { aabb_min: [0.0; 3], left_first: 0, aabb_max: [0.0; 3], count: id }],
        triangles,
    }
}

pub struct GpuBvh {
    pub nodes: wgpu::Buffer,
    pub triangles: wgpu::Buffer,
}

impl GpuBvh {
    pub fn new(ctx: &GpuContext, bvh: &Bvh) -> Result<Self, GpuError> {
        let usage = wgpu::BufferUsages::STORAGE;
        Ok(GpuBvh {
            nodes: ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("bvh nodes"),
                contents: bytemuck::cast_slice(&bvh.nodes),
                usage,
            }),
            triangles: ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("bvh triangles"),
                contents: bytemuck::cast_slice(&bvh.triangles),
                usage,
            }),
        })
    }
}
