//! A floor and a sphere of metallic flakes under two small lights: the test case for glints, where a
//! pixel's footprint holds many flakes of different orientation, so the reflection of a point light
//! is a sparkle pattern that a shader sampling one normal per pixel aliases and a footprint filter
//! converges in one frame.
//!
//! The flakes are a jittered grid of cells (`flake` texels apart) in a 256² normal map, each tilted by
//! a hashed angle up to `tilt` degrees in a hashed direction; the map tiles seamlessly. The floor
//! repeats it `tiling` times along each side, so pixels near the camera see a few texels and those far
//! away hundreds.

use glam::{Vec2, Vec3};

use super::shapes::{MeshBuilder, hash_unit};
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::scene::{Camera, Environment, Light, Material, Scene, Texture, TextureRef};

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        name: "roughness",
        kind: ParamKind::Float { min: 0.05, max: 1.0 },
        default: "0.25",
        doc: "GGX roughness of each flake (α = roughness²)",
    },
    ParamSpec {
        name: "flake",
        kind: ParamKind::Float { min: 1.0, max: 64.0 },
        default: "4",
        doc: "mean distance between flake centres, texels of the 256² normal map",
    },
    ParamSpec {
        name: "tilt",
        kind: ParamKind::Float { min: 0.0, max: 60.0 },
        default: "20",
        doc: "largest tilt of a flake from the surface normal, degrees",
    },
    ParamSpec {
        name: "tiling",
        kind: ParamKind::Float { min: 0.25, max: 256.0 },
        default: "6",
        doc: "repetitions of the normal map along each side of the 6 m floor",
    },
    ParamSpec {
        name: "sky",
        kind: ParamKind::Choice(&["none", "sky"]),
        default: "none",
        doc: "environment: none (the two lights alone) or the procedural sky",
    },
];

/// Side of the flake normal map, texels.
pub const MAP_SIZE: u32 = 256;
const FLOOR_HALF: f32 = 3.0;

pub fn build(params: &ParamValues) -> Scene {
    let roughness = params.float("roughness") as f32;
    let tiling = params.float("tiling") as f32;
    let flakes = TextureRef::new(0);
    let metal = |name: &str, base: Vec3| Material {
        name: name.into(),
        base_color: base.extend(1.0),
        metallic: 1.0,
        roughness,
        normal_texture: Some(flakes),
        normal_scale: 1.0,
        ..Default::default()
    };
    let materials = vec![
        metal("flakes-silver", Vec3::new(0.91, 0.92, 0.92)),
        metal("flakes-copper", Vec3::new(0.95, 0.64, 0.54)),
    ];
    let mut floor = MeshBuilder::new();
    let side = 2.0 * FLOOR_HALF;
    floor.grid(
        Vec3::new(-FLOOR_HALF, 0.0, FLOOR_HALF),
        Vec3::new(side, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -side),
        4,
        4,
        tiling / side,
    );
    let mut sphere = MeshBuilder::new();
    sphere.uv_sphere(Vec3::new(0.4, 0.5, -0.6), 0.5, 64, 32, Vec2::new(4.0, 2.0));
    let sky = params.choice("sky") == "sky";
    Scene {
        name: "glints".into(),
        meshes: vec![floor.build("floor", 0), sphere.build("sphere", 1)],
        materials,
        textures: vec![flake_normal_map(
            params.float("flake") as f32,
            (params.float("tilt") as f32).to_radians(),
        )],
        lights: vec![
            // Behind the objects, so the floor's mirror region faces the camera.
            Light::Point { position: Vec3::new(-1.2, 1.6, -2.6), intensity: Vec3::new(6.0, 5.6, 5.0) },
            Light::Point { position: Vec3::new(1.8, 2.4, -1.2), intensity: Vec3::new(3.0, 3.4, 4.2) },
        ],
        environment: if sky {
            Environment::Sky {
                sun_direction: Vec3::new(0.3, 0.8, -0.5).normalize(),
                sun_radiance: Vec3::new(0.6, 0.55, 0.45),
                sky_radiance: Vec3::new(0.12, 0.16, 0.24),
                ground_radiance: Vec3::splat(0.03),
            }
        } else {
            Environment::None
        },
        camera: Camera {
            position: Vec3::new(0.0, 1.2, 3.0),
            target: Vec3::new(0.0, 0.2, -0.8),
            up: Vec3::Y,
            yfov: 45f32.to_radians(),
            znear: 0.02,
            zfar: 30.0,
        },
        ..Default::default()
    }
}

/// Flakes: a jittered grid of cells `cell` texels apart, each texel taking the normal of the nearest
/// cell centre (3 × 3 neighbouring cells, wrapping, so the map tiles); each cell's normal is tilted by
/// up to `max_tilt`, uniformly over the disc of projected normals. Encoded in glTF's convention.
pub fn flake_normal_map(cell: f32, max_tilt: f32) -> Texture {
    let n = MAP_SIZE as usize;
    let cells = ((MAP_SIZE as f32 / cell).round() as i32).max(1);
    let cell = MAP_SIZE as f32 / cells as f32;
    let id = |kx: i32, ky: i32| [kx.rem_euclid(cells) as u32, ky.rem_euclid(cells) as u32];
    let centre = |kx: i32, ky: i32| {
        let [a, b] = id(kx, ky);
        Vec2::new(
            (kx as f32 + 0.1 + 0.8 * hash_unit(&[a, b, 11])) * cell,
            (ky as f32 + 0.1 + 0.8 * hash_unit(&[a, b, 12])) * cell,
        )
    };
    let mut rgba8 = Vec::with_capacity(n * n * 4);
    for y in 0..n {
        for x in 0..n {
            let p = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let (cx, cy) = ((p.x / cell) as i32, (p.y / cell) as i32);
            let mut best = (f32::MAX, [0u32; 2]);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let d = (p - centre(cx + dx, cy + dy)).length_squared();
                    if d < best.0 {
                        best = (d, id(cx + dx, cy + dy));
                    }
                }
            }
            let [a, b] = best.1;
            let r = max_tilt.sin() * hash_unit(&[a, b, 13]).sqrt();
            let phi = std::f32::consts::TAU * hash_unit(&[a, b, 14]);
            let normal = Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - r * r).sqrt());
            let enc = (normal * 0.5 + 0.5) * 255.0;
            rgba8.extend([enc.x.round() as u8, enc.y.round() as u8, enc.z.round() as u8, 255]);
        }
    }
    Texture { name: "flake-normal-map".into(), width: MAP_SIZE, height: MAP_SIZE, rgba8, srgb: false }
}
