//! The white furnace: a closed box whose walls are Lambertian with albedo ρ and emit radiance Lₑ.
//!
//! In a closed enclosure where every surface has the same albedo and emission, the radiance leaving
//! every point in every direction solves L = Lₑ + ρ·L, so L = Lₑ / (1 − ρ) exactly — 0.2 / (1 − 0.8) = 1
//! with the defaults. Any deviation in a rendering is an energy bug (a lost bounce, a biased estimator,
//! a light leak), which is what the scene is for. That only holds if the box is watertight, so all six
//! faces are cut from one integer lattice: a vertex shared by two faces is computed from the same integers
//! and lands on exactly the same float position.

use glam::{Vec2, Vec3};

use super::shapes::MeshBuilder;
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::scene::{Camera, Environment, Material, Scene};

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        name: "albedo",
        kind: ParamKind::Float { min: 0.0, max: 0.95 },
        default: "0.8",
        doc: "wall albedo ρ (grey); the exact radiance is emission / (1 − ρ)",
    },
    ParamSpec {
        name: "emission",
        kind: ParamKind::Float { min: 0.0, max: 100.0 },
        default: "0.2",
        doc: "emitted radiance of every wall (grey)",
    },
    ParamSpec {
        name: "subdivisions",
        kind: ParamKind::Int { min: 1, max: 64 },
        default: "4",
        doc: "grid cells per box edge (for techniques that store data per vertex)",
    },
];

/// Half the edge length of the box, metres.
pub const HALF_SIZE: f32 = 1.0;

pub fn build(params: &ParamValues) -> Scene {
    let albedo = params.float("albedo") as f32;
    let emission = params.float("emission") as f32;
    let n = params.int("subdivisions") as u32;

    // Starting from `Material::diffuse` keeps the walls exactly Lambertian (no specular layer), which the
    // closed-form answer assumes.
    let material = Material {
        emissive: Vec3::splat(emission),
        ..Material::diffuse("furnace-wall", Vec3::splat(albedo))
    };

    let coord = |i: u32| -HALF_SIZE + 2.0 * HALF_SIZE * i as f32 / n as f32;
    let mut b = MeshBuilder::new();
    for axis in 0..3 {
        let (a, c) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [0, n] {
            // The walls face the inside: +axis on the low side, −axis on the high side.
            let inward = if side == 0 { 1.0 } else { -1.0 };
            let mut normal = Vec3::ZERO;
            normal[axis] = inward;
            let base = b.positions.len() as u32;
            for j in 0..=n {
                for i in 0..=n {
                    let mut p = Vec3::ZERO;
                    p[axis] = coord(side);
                    p[a] = coord(i);
                    p[c] = coord(j);
                    let uv = Vec2::new(i as f32, j as f32) * (2.0 * HALF_SIZE / n as f32);
                    b.vertex(p, normal, uv);
                }
            }
            for j in 0..n {
                for i in 0..n {
                    let v00 = base + j * (n + 1) + i;
                    let [v10, v01, v11] = [v00 + 1, v00 + n + 1, v00 + n + 2];
                    // (v00, v10, v11) faces e_a × e_c = +axis.
                    if inward > 0.0 {
                        b.triangle(v00, v10, v11);
                        b.triangle(v00, v11, v01);
                    } else {
                        b.triangle(v00, v11, v10);
                        b.triangle(v00, v01, v11);
                    }
                }
            }
        }
    }

    Scene {
        name: "furnace".into(),
        meshes: vec![b.build("furnace-walls", 0)],
        materials: vec![material],
        textures: Vec::new(),
        lights: Vec::new(),
        environment: Environment::None,
        environment_rotation: glam::Quat::IDENTITY,
        camera: Camera {
            position: Vec3::new(0.3, 0.2, 0.7),
            target: Vec3::new(-0.2, -0.1, -1.0),
            up: Vec3::Y,
            yfov: 70f32.to_radians(),
            znear: 0.01,
            zfar: 10.0,
        },
        warnings: Vec::new(),
        animation: None,
    }
}
