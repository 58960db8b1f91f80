//! Light paths of instant radiosity (Keller 1997), shared by the techniques that need light leaving the
//! sources: `igi`'s virtual point lights and the photons of `photon-irradiance-cache`. The
//! `vpl generation` sub-pass traces quasi-random paths from the lights, chosen in proportion to their
//! power, and stores their vertices as VPLs (`vpl.wgsl`): a VPL on a surface is also a photon, the flux
//! that arrived there from `incoming`.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use wgpu::util::DeviceExt;

use crate::gpu::scene::{LIGHT_DIRECTIONAL, LIGHT_SPOT, luminance, mean_srgb_luminance};
use crate::gpu::{GpuContext, Profiler};
use crate::scene::Scene;
use crate::shaders::Defines;
use crate::techniques::RenderError;

use super::compute::{self, storage_buffer_entry, uniform_entry};
use super::{FrameContext, TechniqueSetup};

/// The VPL struct and the light a VPL delivers to a point; prepended to every pass that reads VPLs.
pub const VPL_WGSL: &str = include_str!("vpl.wgsl");
const GENERATE_WGSL: &str = include_str!("generate.wgsl");

/// Light-path vertices beyond this are not stored (the Halton dimensions run out at 32).
pub const MAX_DEPTH: u32 = 8;

/// Mirrors `Vpl` in vpl.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuVpl {
    pub position: [f32; 3],
    pub kind: u32,
    pub normal: [f32; 3],
    pub light: u32,
    pub flux: [f32; 3],
    pub roughness: f32,
    pub incoming: [f32; 3],
    pub metallic: f32,
    pub base_color: [f32; 3],
    pub specular: f32,
}

/// Mirrors `LightEntry` in generate.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct LightEntry {
    pub cdf: f32,
    pub probability: f32,
    pub kind: u32,
    pub index: u32,
}

pub(crate) const ENTRY_LIGHT: u32 = 0;
pub(crate) const ENTRY_EMISSIVE: u32 = 1;
pub(crate) const ENTRY_ENVIRONMENT: u32 = 2;

/// Mirrors `VplGeneration` in generate.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct VplGeneration {
    pub sets: u32,
    pub paths: u32,
    pub slots_per_set: u32,
    pub max_depth: u32,
    pub entry_count: u32,
    pub fixed_lights: u32,
    pub _pad: [u32; 2],
    pub sphere: [f32; 4],
}

/// How one set's VPL slots are spent: first `fixed` slots, one per analytic light, then `paths` light
/// paths, `alive[j]` of them reaching vertex j (round(paths · ρ̄^j), instant radiosity's quasi-random
/// roulette), vertex j's slots at `offset[j]` (`None` where vertex j is not stored: on the lights when
/// direct light comes from rasterisation).
///
/// Analytic (point, spot, directional) lights get a slot of their own in every set when VPLs carry the
/// direct light: every VPL instant radiosity would place on a point light is the light itself, so one
/// exact VPL replaces them all and removes their sampling noise; paths still start from every light in
/// proportion to power, and only their vertex 0 on emissive triangles and the environment is stored.
#[derive(Clone, Debug, PartialEq)]
pub struct SetLayout {
    pub fixed: u32,
    pub paths: u32,
    pub alive: Vec<u32>,
    pub offset: Vec<Option<u32>>,
    /// Slots used (≤ the slots per set; the rest stay empty).
    pub used: u32,
}

/// The set layout with the most paths whose stored vertices fit in `slots` after `fixed` light slots
/// (vertex 0 stored only when `store_vertex0`), or `None` when neither a light nor a path fits.
pub fn set_layout(
    slots: u32,
    survival: f32,
    depth: u32,
    fixed: u32,
    store_vertex0: bool,
) -> Option<SetLayout> {
    if fixed > slots {
        return None;
    }
    let build = |paths: u32| {
        let alive: Vec<u32> = (0..=depth)
            .map(|j| (f64::from(paths) * f64::from(survival).powi(j as i32)).round() as u32)
            .map(|n| n.min(paths))
            .collect();
        let mut offset = Vec::with_capacity(alive.len());
        let mut used = fixed;
        for (j, &n) in alive.iter().enumerate() {
            if j == 0 && !store_vertex0 {
                offset.push(None);
            } else {
                offset.push(Some(used));
                used += n;
            }
        }
        SetLayout { fixed, paths, alive, offset, used }
    };
    // `used` grows with `paths`, so search for the largest that fits.
    let (mut lo, mut hi) = (0u32, slots.max(1));
    while lo < hi {
        let mid = lo + (hi - lo).div_ceil(2);
        if build(mid).used <= slots { lo = mid } else { hi = mid - 1 }
    }
    let layout = build(lo);
    (layout.used > 0 && (lo > 0 || fixed > 0)).then_some(layout)
}

/// Area-weighted mean albedo (luminance of the BRDF's directional albedo at normal incidence) of the
/// scene's surfaces: the survival rate of light paths, clamped to [0.05, 0.95].
pub fn mean_albedo(scene: &Scene) -> f32 {
    let mut weighted = 0.0f64;
    let mut area = 0.0f64;
    for mesh in &scene.meshes {
        let Some(m) = scene.materials.get(mesh.material as usize) else { continue };
        let tex = m
            .base_color_texture
            .map_or(1.0, |t| scene.textures.get(t.texture as usize).map_or(1.0, mean_srgb_luminance));
        let base = luminance(m.base_color.truncate()) * tex;
        let dielectric = base * (1.0 - m.specular * 0.04) + m.specular * 0.04;
        let albedo = dielectric + (base - dielectric) * m.metallic;
        let mesh_area: f64 = mesh
            .indices
            .chunks_exact(3)
            .map(|t| {
                let p = |i: u32| mesh.positions[i as usize];
                f64::from((p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0])).length() * 0.5)
            })
            .sum();
        weighted += f64::from(albedo) * mesh_area;
        area += mesh_area;
    }
    if area <= 0.0 {
        return 0.5;
    }
    ((weighted / area) as f32).clamp(0.05, 0.95)
}

/// The light sources paths start from, with probabilities proportional to their (luminance) power.
pub fn light_entries(
    lights: &[crate::gpu::scene::GpuLight],
    emissive_power: f32,
    environment_power: f32,
    scene_radius: f32,
) -> Vec<LightEntry> {
    let disc = std::f32::consts::PI * scene_radius * scene_radius;
    let mut entries: Vec<(u32, u32, f32)> = lights
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let lum = luminance(Vec3::from(l.intensity));
            let power = match l.kind {
                LIGHT_DIRECTIONAL => lum * disc,
                LIGHT_SPOT => lum * 2.0 * std::f32::consts::PI * (1.0 - l.cos_outer),
                _ => lum * 4.0 * std::f32::consts::PI,
            };
            (ENTRY_LIGHT, i as u32, power)
        })
        .collect();
    // Emitters are two-sided: twice the one-sided power π·A·L.
    entries.push((ENTRY_EMISSIVE, 0, 2.0 * emissive_power));
    entries.push((ENTRY_ENVIRONMENT, 0, environment_power * disc));
    entries.retain(|e| e.2 > 0.0 && e.2.is_finite());
    let total: f32 = entries.iter().map(|e| e.2).sum();
    let mut running = 0.0;
    let mut out: Vec<LightEntry> = entries
        .iter()
        .map(|&(kind, index, power)| {
            running += power;
            LightEntry { cdf: running / total, probability: power / total, kind, index }
        })
        .collect();
    if let Some(last) = out.last_mut() {
        last.cdf = 1.0;
    }
    out
}

/// The `vpl generation` sub-pass: `paths` light paths per set of `sets` into a VPL buffer laid out by a
/// [`SetLayout`]. The light entries (which source a path starts from, by power) hold light indices and
/// powers, not positions, so moved lights keep them valid; they are rewritten in place when powers change.
pub struct LightPaths {
    /// The pipeline, its bind group, workgroups and the light entries on the GPU (`None` when no path is
    /// traced: no light, or no slot for one path).
    generate: Option<(wgpu::ComputePipeline, wgpu::BindGroup, u32, wgpu::Buffer)>,
    entries: Vec<LightEntry>,
    /// The scene's bounding sphere the entries and directional sources were set up with.
    radius: f32,
}

/// The bounding sphere (centre, radius) of the scene.
pub fn scene_sphere(scene: &Scene) -> (Vec3, f32) {
    let bounds = scene.bounds();
    (bounds.center(), bounds.bounding_radius())
}

impl LightPaths {
    pub fn new(
        setup: &TechniqueSetup,
        vpls: &wgpu::Buffer,
        sets: u32,
        slots_per_set: u32,
        depth: u32,
        layout: Option<&SetLayout>,
    ) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let device = &ctx.device;
        let (centre, radius) = scene_sphere(setup.scene);
        let entries = light_entries(
            &setup.gpu_scene.lights,
            setup.gpu_scene.info.emissive_power,
            setup.gpu_scene.environment_power,
            radius,
        );
        let layout = match layout {
            Some(l) if !(entries.is_empty() && setup.gpu_scene.lights.is_empty()) => l,
            _ => return Ok(LightPaths { generate: None, entries, radius }),
        };
        let mut table: Vec<u32> = layout.alive.clone();
        table.extend(layout.offset.iter().map(|o| o.unwrap_or(u32::MAX)));
        let table_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("vpl layout"),
            contents: bytemuck::cast_slice(&table),
            usage: wgpu::BufferUsages::STORAGE,
        });
        // A zero-length binding is invalid: with no entry (analytic lights alone) one unused entry.
        let entry_contents = if entries.is_empty() { vec![LightEntry::zeroed()] } else { entries.clone() };
        let entry_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("light entries"),
            contents: bytemuck::cast_slice(&entry_contents),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        });
        let params = VplGeneration {
            sets,
            paths: layout.paths,
            slots_per_set,
            max_depth: depth,
            entry_count: entries.len() as u32,
            fixed_lights: layout.fixed,
            _pad: [0; 2],
            sphere: [centre.x, centre.y, centre.z, radius],
        };
        let params_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("vpl generation"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let group_layout = compute::layout(
            ctx,
            "vpl generation",
            &[
                storage_buffer_entry(0, false),
                storage_buffer_entry(1, true),
                storage_buffer_entry(2, true),
                uniform_entry(3),
            ],
        );
        let group = compute::bind_group(
            ctx,
            "vpl generation",
            &group_layout,
            &[
                vpls.as_entire_binding(),
                table_buffer.as_entire_binding(),
                entry_buffer.as_entire_binding(),
                params_buffer.as_entire_binding(),
            ],
        );
        let pipeline = compute::pipeline(
            ctx,
            "vpl generation",
            &format!("{VPL_WGSL}\n{GENERATE_WGSL}"),
            setup.gpu_scene.bvh_defines(Defines::new()),
            "main",
            &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &group_layout],
        )?;
        let workgroups = (sets * layout.paths.max(layout.fixed)).div_ceil(64);
        Ok(LightPaths { generate: Some((pipeline, group, workgroups, entry_buffer)), entries, radius })
    }

    /// Whether paths are traced at all.
    pub fn traces(&self) -> bool {
        self.generate.is_some()
    }

    /// Traces the paths into the VPL buffer (nothing when none are traced).
    pub fn dispatch(
        &self,
        fc: &FrameContext,
        profiler: &mut Profiler,
        label: &str,
    ) -> Result<(), RenderError> {
        if let Some((pipeline, group, workgroups, _)) = &self.generate {
            let groups = [&fc.gpu_scene.bind_group, &fc.frame.bind_group, group];
            profiler.pass(fc.ctx, label, |encoder| {
                compute::dispatch(encoder, label, pipeline, &groups, [*workgroups, 1, 1]);
            })?;
        }
        Ok(())
    }

    /// Rewrites the light entries for `gpu_scene`'s sources as they are now; `false` when their number
    /// changed (a source's power reached or left zero), which needs a new technique.
    pub fn update_entries(&mut self, ctx: &GpuContext, gpu_scene: &crate::gpu::GpuScene) -> bool {
        let entries = light_entries(
            &gpu_scene.lights,
            gpu_scene.info.emissive_power,
            gpu_scene.environment_power,
            self.radius,
        );
        if entries == self.entries {
            return true;
        }
        match &self.generate {
            Some((.., buffer)) if entries.len() == self.entries.len() && !entries.is_empty() => {
                ctx.queue.write_buffer(buffer, 0, bytemuck::cast_slice(&entries));
                self.entries = entries;
                true
            }
            _ => false,
        }
    }
}

#[cfg(test)]
mod tests;
