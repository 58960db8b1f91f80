//! A ring of pillars round a trefoil knot on a finely tessellated ground, under a procedural sky whose
//! sun glow casts directional shadows: self-shadowing geometry lit only by the environment, the test
//! scene of precomputed radiance transfer (the knot shadows itself, the pillars shadow the ground and
//! each other). Every surface is Lambertian, so diffuse transfer can be exact up to its SH order, and
//! the meshes are dense enough for per-vertex transfer to hold the shadows.

use std::f32::consts::TAU;

use glam::{Quat, Vec2, Vec3};

use super::motion;
use super::shapes::MeshBuilder;
use crate::params::{ParamSpec, ParamValues};
use crate::scene::{Camera, Environment, Material, Scene};

pub const PARAMS: &[ParamSpec] = &[motion::ENV_ROTATION_PARAM, motion::ENVIRONMENT_ANIMATE_PARAM];

/// Pillars in the ring, its radius, and each pillar's radius and height (metres).
const PILLARS: u32 = 8;
const RING_RADIUS: f32 = 2.3;
const PILLAR_RADIUS: f32 = 0.22;
const PILLAR_HEIGHT: f32 = 2.4;
/// Half the ground's edge and its cells per edge (9 cm cells: per-vertex transfer resolves the shadows).
const GROUND_HALF: f32 = 3.5;
const GROUND_CELLS: u32 = 80;
/// The knot's centre height and its size: the core circle's radius, the height of its loops and the
/// tube's radius.
const KNOT_HEIGHT: f32 = 1.0;
const KNOT_RADIUS: f32 = 0.7;
const KNOT_SWING: f32 = 0.3;
const KNOT_TUBE: f32 = 0.14;

/// The sky: a broad sun glow 40° above the horizon, front left, bright enough against the dome for
/// clear shadows (≈ 2.3 W/m² from the glow on a surface facing it, ≈ 1.3 from the rest of the dome;
/// see `shaders/common/environment.wgsl` for the model).
pub fn sky() -> Environment {
    Environment::Sky {
        sun_direction: Vec3::new(-0.55, 0.64, 0.53).normalize(),
        sun_radiance: Vec3::new(12.0, 11.2, 9.6),
        sky_radiance: Vec3::new(0.4, 0.48, 0.64),
        ground_radiance: Vec3::new(0.15, 0.14, 0.12),
    }
}

/// The (2, 3) torus knot (a trefoil) about +Y through `centre`: the core circle's radius `radius`,
/// loops `swing` above and below it.
fn knot_curve(centre: Vec3, radius: f32, swing: f32, t: f32) -> Vec3 {
    let r = radius + swing * (3.0 * t).cos();
    centre + Vec3::new(r * (2.0 * t).cos(), swing * (3.0 * t).sin(), -r * (2.0 * t).sin())
}

/// A closed tube of radius `tube` round the closed curve `curve(t)`, t in [0, 2π): `along` × `around`
/// vertices with analytic normals (the tube's frame: the curve's tangent, and the part of the position
/// relative to `centre` across it, which never vanishes for a torus knot).
fn tube(b: &mut MeshBuilder, centre: Vec3, curve: impl Fn(f32) -> Vec3, tube: f32, along: u32, around: u32) {
    let base = b.positions.len() as u32;
    let step = TAU / along as f32;
    for i in 0..along {
        let t = i as f32 * step;
        let p = curve(t);
        let tangent = (curve(t + 0.5 * step) - curve(t - 0.5 * step)).normalize();
        let outward = p - centre;
        let normal = (outward - tangent * outward.dot(tangent)).normalize();
        let binormal = tangent.cross(normal);
        for j in 0..around {
            let a = TAU * j as f32 / around as f32;
            let n = normal * a.cos() + binormal * a.sin();
            b.vertex(p + n * tube, n, Vec2::new(i as f32 / along as f32, j as f32 / around as f32));
        }
    }
    let index = |i: u32, j: u32| base + (i % along) * around + j % around;
    for i in 0..along {
        for j in 0..around {
            // ∂P/∂j × ∂P/∂i points out of the tube (∂i runs along the tangent, ∂j round it).
            let (a, b2, c, d) = (index(i, j), index(i + 1, j), index(i + 1, j + 1), index(i, j + 1));
            b.triangle(a, d, c);
            b.triangle(a, c, b2);
        }
    }
}

pub fn build(params: &ParamValues) -> Scene {
    let materials = vec![
        Material::diffuse("ground", Vec3::splat(0.6)),
        Material::diffuse("pillar", Vec3::new(0.75, 0.72, 0.68)),
        Material::diffuse("knot", Vec3::new(0.8, 0.55, 0.3)),
    ];
    let mut ground = MeshBuilder::new();
    let edge = 2.0 * GROUND_HALF;
    ground.grid(
        Vec3::new(-GROUND_HALF, 0.0, GROUND_HALF),
        Vec3::new(edge, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -edge),
        GROUND_CELLS,
        GROUND_CELLS,
        1.0,
    );
    let mut pillars = MeshBuilder::new();
    for k in 0..PILLARS {
        let phi = TAU * (k as f32 + 0.5) / PILLARS as f32;
        let at = Vec3::new(RING_RADIUS * phi.cos(), 0.0, RING_RADIUS * phi.sin());
        pillars.cylinder(at, PILLAR_RADIUS, PILLAR_HEIGHT, 24, true, 1.0);
    }
    let mut knot = MeshBuilder::new();
    let centre = Vec3::new(0.0, KNOT_HEIGHT, 0.0);
    tube(&mut knot, centre, |t| knot_curve(centre, KNOT_RADIUS, KNOT_SWING, t), KNOT_TUBE, 240, 16);

    let mut scene = Scene {
        name: "pillars".into(),
        meshes: vec![ground.build("ground", 0), pillars.build("pillars", 1), knot.build("knot", 2)],
        materials,
        textures: Vec::new(),
        lights: Vec::new(),
        environment: sky(),
        environment_rotation: Quat::IDENTITY,
        camera: Camera {
            position: Vec3::new(0.0, 3.4, 6.4),
            target: Vec3::new(0.0, 0.8, 0.0),
            up: Vec3::Y,
            yfov: 45f32.to_radians(),
            znear: 0.05,
            zfar: 100.0,
        },
        warnings: Vec::new(),
        animation: None,
    };
    motion::turn_environment(&mut scene, params);
    scene
}
