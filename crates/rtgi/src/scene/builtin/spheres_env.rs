//! Two rows of spheres, roughness 0 → 1 left to right, dielectric in front and metal behind, on a grey
//! ground under a procedural sky: the material-response chart for environment lighting (prefiltered
//! environment maps, SH irradiance, specular occlusion).

use glam::{Quat, Vec2, Vec3};

use super::motion;
use super::shapes::MeshBuilder;
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::scene::{Camera, Environment, Material, Scene};

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        name: "count",
        kind: ParamKind::Int { min: 2, max: 10 },
        default: "5",
        doc: "spheres per row (roughness steps evenly from 0 to 1)",
    },
    motion::ENV_ROTATION_PARAM,
    motion::ENVIRONMENT_ANIMATE_PARAM,
];

const RADIUS: f32 = 0.45;
const SPACING: f32 = 1.1;

/// Dielectric base colours (linear), cycled along the front row: saturated but not pure, so the diffuse
/// lobe and the white specular lobe stay distinguishable.
const DIELECTRIC: [Vec3; 5] = [
    Vec3::new(0.8, 0.1, 0.08),
    Vec3::new(0.85, 0.45, 0.1),
    Vec3::new(0.75, 0.75, 0.72),
    Vec3::new(0.12, 0.55, 0.15),
    Vec3::new(0.1, 0.2, 0.75),
];

/// Metal F0 (linear): gold, copper, silver, aluminium, iron, from the usual measured-data tables.
const METAL: [Vec3; 5] = [
    Vec3::new(1.0, 0.766, 0.336),
    Vec3::new(0.955, 0.638, 0.538),
    Vec3::new(0.972, 0.96, 0.915),
    Vec3::new(0.913, 0.922, 0.924),
    Vec3::new(0.56, 0.57, 0.58),
];

/// The sky, the only light. `sun_radiance` is the peak of the sky model's broad glow around the sun
/// (`sun_radiance · max(0, d·sun)³²`, see `shaders/common/environment.wgsl`; about 0.19 sr wide), not a
/// disc: 10 adds ≈ 1.8 W/m² on a surface facing the sun, over ≈ 3.3 W/m² from the rest of the dome, enough
/// for a clear directional highlight and shading gradient without the firefly-prone variance of a real
/// sun disc. The sun stands about 49° above the horizon behind the camera's left shoulder, so the
/// spheres' fronts face it.
pub fn sky() -> Environment {
    Environment::Sky {
        sun_direction: Vec3::new(-0.4, 0.75, 0.5).normalize(),
        sun_radiance: Vec3::new(10.0, 9.2, 8.0),
        sky_radiance: Vec3::new(0.85, 0.95, 1.1),
        ground_radiance: Vec3::new(0.3, 0.28, 0.25),
    }
}

pub fn build(params: &ParamValues) -> Scene {
    let count = params.int("count") as usize;
    let mut materials = vec![Material::diffuse("ground", Vec3::splat(0.5))];
    let mut meshes = Vec::new();

    let mut ground = MeshBuilder::new();
    ground.axis_rect(1, 0.0, Vec2::splat(-15.0), Vec2::splat(15.0), 1.0, 1.0);
    meshes.push(ground.build("ground", 0));

    let x0 = -(count as f32 - 1.0) * 0.5 * SPACING;
    for (row, (z, metallic)) in [(0.7, 0.0), (-0.7, 1.0)].into_iter().enumerate() {
        for i in 0..count {
            let roughness = i as f32 / (count - 1) as f32;
            let base = if metallic > 0.0 { METAL[i % METAL.len()] } else { DIELECTRIC[i % DIELECTRIC.len()] };
            let kind = if metallic > 0.0 { "metal" } else { "dielectric" };
            let name = format!("{kind}-roughness-{roughness:.2}");
            materials.push(Material {
                name: name.clone(),
                base_color: base.extend(1.0),
                metallic,
                roughness,
                ..Default::default()
            });
            let mut sphere = MeshBuilder::new();
            let centre = Vec3::new(x0 + i as f32 * SPACING, RADIUS, z);
            sphere.uv_sphere(centre, RADIUS, 64, 32, Vec2::new(std::f32::consts::TAU * RADIUS, 1.5));
            meshes.push(sphere.build(&name, (1 + row * count + i) as u32));
        }
    }

    let mut scene = Scene {
        name: "spheres-env".into(),
        meshes,
        materials,
        textures: Vec::new(),
        lights: Vec::new(),
        environment: sky(),
        environment_rotation: Quat::IDENTITY,
        camera: Camera {
            // Back off for long rows so both ends stay in a 16:9 frame.
            // High enough that the metal row shows above the dielectric one.
            position: Vec3::new(0.0, 3.0, 5.8) * (count as f32 / 5.0).max(1.0),
            target: Vec3::new(0.0, 0.3, -0.2),
            up: Vec3::Y,
            yfov: 40f32.to_radians(),
            znear: 0.05,
            zfar: 100.0,
        },
        warnings: Vec::new(),
        animation: None,
    };
    motion::turn_environment(&mut scene, params);
    scene
}
