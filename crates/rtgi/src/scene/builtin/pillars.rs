//! A ring of pillars round a trefoil knot on a finely tessellated ground, under a procedural sky whose
//! sun glow casts directional shadows: self-shadowing geometry lit only by the environment, the test
//! scene of precomputed radiance transfer (the knot shadows itself, the pillars shadow the ground and
//! each other). Every surface is Lambertian, so diffuse transfer can be exact up to its SH order, and
//! the meshes are dense enough for per-vertex transfer to hold the shadows.

use std::f32::consts::TAU;

use glam::{Quat, Vec2, Vec3};

use super::motion;
use super::shapes::MeshBuilder;
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::scene::{Camera, Environment, EnvironmentMap, Material, Scene};

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        name: "sky",
        kind: ParamKind::Choice(&["glow", "patch"]),
        default: "glow",
        doc: "glow: the procedural sky with its broad sun glow (soft shadows); patch: the same dome without \
              the glow, as an equirectangular map, plus a small bright disc 4° across in the glow's \
              direction giving a surface facing it the glow's irradiance (hard shadows: the \
              all-frequency case SH transfer blurs)",
    },
    motion::ENV_ROTATION_PARAM,
    motion::animate_param(
        &["none", "environment", "knot"],
        "environment: the environment turns once about +Y (12 s, LINEAR); knot: the knot, raised to 1.35 \
         m, tumbles once about a horizontal axis through its centre (8 s, LINEAR), so its self-shadowing \
         changes (a rigid moving mesh for PRT's self-transfer)",
    ),
];

/// Seconds per tumble of `animate=knot`, and the knot's centre height then: it reaches 1.14 m from its
/// centre (core radius and swing, plus the tube), so turning about any axis through a centre 1.35 m up
/// it clears the ground, and the ring's inner side 2.08 m away.
const KNOT_TUMBLE_SECONDS: f32 = 8.0;
const TUMBLE_HEIGHT: f32 = 1.35;

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

/// `sky=patch`'s map: texels per row and rows, and each texel's sub-samples per side (the disc's rim
/// is antialiased; 0.35° texels put about 11 texels across the disc).
const PATCH_MAP_WIDTH: u32 = 1024;
const PATCH_MAP_HEIGHT: u32 = 512;
const PATCH_SUBSAMPLES: u32 = 3;
/// The disc's angular radius.
const PATCH_RADIUS_DEGREES: f32 = 2.0;

/// The sky of `sky=patch`: [`sky`]'s dome and ground without the glow, and a disc of
/// `PATCH_RADIUS_DEGREES` about the glow's direction whose radiance gives a surface facing it the
/// glow's irradiance: sun_radiance · 2π/34 (∫ max(0, cos)³² cos dω about the axis) against the disc's
/// L · π sin² r.
pub fn patch_sky() -> Environment {
    let Environment::Sky { sun_direction, sun_radiance, sky_radiance, ground_radiance } = sky() else {
        unreachable!("pillars' sky is procedural")
    };
    let radius = PATCH_RADIUS_DEGREES.to_radians();
    let cos_radius = radius.cos();
    let disc_radiance = sun_radiance * (TAU / 34.0) / (std::f32::consts::PI * radius.sin().powi(2));
    let radiance = |d: Vec3| {
        if d.y < 0.0 {
            return ground_radiance;
        }
        let h = 1.0 - d.y;
        let disc = if d.dot(sun_direction) >= cos_radius { disc_radiance } else { Vec3::ZERO };
        sky_radiance * (1.0 + 0.5 * h * h) + disc
    };
    let (w, h, n) = (PATCH_MAP_WIDTH, PATCH_MAP_HEIGHT, PATCH_SUBSAMPLES);
    let mut rgb = Vec::with_capacity((w * h * 3) as usize);
    for row in 0..h {
        for column in 0..w {
            let mut sum = Vec3::ZERO;
            for (i, j) in (0..n).flat_map(|i| (0..n).map(move |j| (i, j))) {
                let u = (column as f32 + (i as f32 + 0.5) / n as f32) / w as f32;
                let v = (row as f32 + (j as f32 + 0.5) / n as f32) / h as f32;
                sum += radiance(EnvironmentMap::direction(u, v));
            }
            rgb.extend_from_slice(&(sum / (n * n) as f32).to_array());
        }
    }
    Environment::Map(EnvironmentMap {
        path: "pillars:sky=patch (generated)".into(),
        width: w,
        height: h,
        rgb,
        intensity: 1.0,
    })
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
    let tumbling = params.choice("animate") == "knot";
    let centre = Vec3::new(0.0, if tumbling { TUMBLE_HEIGHT } else { KNOT_HEIGHT }, 0.0);
    tube(&mut knot, centre, |t| knot_curve(centre, KNOT_RADIUS, KNOT_SWING, t), KNOT_TUBE, 240, 16);

    let mut scene = Scene {
        name: "pillars".into(),
        meshes: vec![ground.build("ground", 0), pillars.build("pillars", 1), knot.build("knot", 2)],
        materials,
        textures: Vec::new(),
        lights: Vec::new(),
        environment: if params.choice("sky") == "patch" { patch_sky() } else { sky() },
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
    if tumbling {
        let node = motion::add_root(
            &mut scene,
            "knot-tumble",
            "knot",
            crate::scene::animation::Trs { translation: centre, ..Default::default() },
        );
        let times: Vec<f32> = (0..=4).map(|k| KNOT_TUMBLE_SECONDS * k as f32 / 4.0).collect();
        let axis = Vec3::new(1.0, 0.0, 0.5).normalize();
        motion::keys(
            &mut scene,
            node,
            crate::scene::animation::Property::Rotation,
            motion::turns(Quat::IDENTITY, axis, &times, &[0.0, 90.0, 180.0, 270.0, 360.0]),
        );
        motion::bind_mesh(&mut scene, 2, node);
    }
    scene
}
