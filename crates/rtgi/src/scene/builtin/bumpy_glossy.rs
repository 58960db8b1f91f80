//! Glossy, finely normal-mapped surfaces under three coloured point lights, inside a diffuse room.
//!
//! This is the normal-mapped test case for filtering incoming radiance in spherical harmonics: a normal map
//! with detail far smaller than a pixel's footprint in screen-space or probe-based lighting makes the
//! outgoing radiance vary per texel, so a technique that filters irradiance but shades with the mapped
//! normal must keep that detail, and a glossy lobe (roughness 0.2–0.3) exposes any blurring of the
//! incoming radiance. Three differently coloured lights make direction errors show up as colour errors,
//! and the room's walls provide indirect light from every side.

use std::f32::consts::TAU;

use glam::{Vec2, Vec3};

use super::shapes::{MeshBuilder, hash_unit};
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::scene::{Camera, Environment, Light, Material, Scene, Texture, TextureRef};

pub const PARAMS: &[ParamSpec] = &[ParamSpec {
    name: "normal_scale",
    kind: ParamKind::Float { min: 0.0, max: 2.0 },
    default: "1",
    doc: "glTF normal-map scale of the glossy surfaces (0 = flat, to compare with and without bumps)",
}];

/// Normal-map resolution and the number of bump cells along each side.
const MAP_SIZE: u32 = 512;
const MAP_CELLS: u32 = 32;

/// Half extents of the room, metres.
const ROOM_HALF: f32 = 4.0;
const ROOM_HEIGHT: f32 = 3.2;

pub fn build(params: &ParamValues) -> Scene {
    let normal_scale = params.float("normal_scale") as f32;
    let normal_map = TextureRef::new(0);
    let glossy = |name: &str, base: Vec3, metallic: f32, roughness: f32| Material {
        name: name.into(),
        base_color: base.extend(1.0),
        metallic,
        roughness,
        normal_texture: Some(normal_map),
        normal_scale,
        ..Default::default()
    };
    const WALL: u32 = 0;
    const FLOOR: u32 = 1;
    const CEILING: u32 = 2;
    const PANEL: u32 = 3;
    const GOLD: u32 = 4;
    const BLUE: u32 = 5;
    const IVORY: u32 = 6;
    let materials = vec![
        Material::diffuse("wall", Vec3::splat(0.7)),
        Material::diffuse("floor", Vec3::splat(0.45)),
        Material::diffuse("ceiling", Vec3::splat(0.8)),
        glossy("glossy-panel", Vec3::new(0.3, 0.3, 0.32), 0.0, 0.25),
        // Gold's F0 from the usual measured-data tables.
        glossy("glossy-gold", Vec3::new(1.0, 0.78, 0.34), 1.0, 0.3),
        glossy("glossy-blue", Vec3::new(0.15, 0.3, 0.7), 0.0, 0.25),
        glossy("glossy-ivory", Vec3::new(0.8, 0.78, 0.72), 0.0, 0.2),
    ];

    let (r, hgt) = (ROOM_HALF, ROOM_HEIGHT);
    let mut floor = MeshBuilder::new();
    floor.axis_rect(1, 0.0, Vec2::splat(-r), Vec2::splat(r), 1.0, 1.0);
    let mut ceiling = MeshBuilder::new();
    ceiling.axis_rect(1, hgt, Vec2::splat(-r), Vec2::splat(r), -1.0, 1.0);
    let mut walls = MeshBuilder::new();
    for (axis, at, facing) in [(0, -r, 1.0), (0, r, -1.0), (2, -r, 1.0), (2, r, -1.0)] {
        let (min, max) = if axis == 0 {
            (Vec2::new(0.0, -r), Vec2::new(hgt, r))
        } else {
            (Vec2::new(-r, 0.0), Vec2::new(r, hgt))
        };
        walls.axis_rect(axis, at, min, max, facing, 1.0);
    }

    // A 5 m × 5 m glossy slab on the floor; the normal map repeats every metre (bumps about 3 cm wide).
    let mut panel = MeshBuilder::new();
    panel.aabb(Vec3::new(-2.5, 0.0, -2.5), Vec3::new(2.5, 0.04, 2.5), 1.0);
    let top = 0.04;

    let mut sphere = MeshBuilder::new();
    let radius = 0.5;
    // UV scale ≈ circumference and half-circumference, so the bumps keep their size on the sphere.
    sphere.uv_sphere(Vec3::new(-1.1, top + radius, -0.4), radius, 96, 48, Vec2::new(TAU * radius, 1.6));

    let mut cube = MeshBuilder::new();
    let (sin, cos) = 30f32.to_radians().sin_cos();
    let half = 0.4;
    let axes = [Vec3::new(cos, 0.0, -sin) * half, Vec3::Y * half, Vec3::new(sin, 0.0, cos) * half];
    cube.cuboid(Vec3::new(1.1, top + half, -0.6), axes, true, f32::INFINITY, 1.0);

    let mut cylinder = MeshBuilder::new();
    cylinder.cylinder(Vec3::new(0.1, top, 1.0), 0.3, 1.2, 96, true, 1.0);

    let meshes = vec![
        floor.build("floor", FLOOR),
        ceiling.build("ceiling", CEILING),
        walls.build("walls", WALL),
        panel.build("glossy-panel", PANEL),
        sphere.build("gold-sphere", GOLD),
        cube.build("blue-box", BLUE),
        cylinder.build("ivory-cylinder", IVORY),
    ];

    // Red-, green- and blue-ish lights around the objects, 2.4–2.6 m high. 20 W/sr gives 2–5 W/m² on the
    // floor and walls, so diffuse radiance is around 0.2–1 and highlights well above 1.
    let lights = [
        (Vec3::new(-2.2, 2.4, 1.8), Vec3::new(20.0, 5.0, 4.0)),
        (Vec3::new(2.2, 2.4, 1.8), Vec3::new(5.0, 20.0, 6.0)),
        (Vec3::new(0.0, 2.6, -2.6), Vec3::new(5.0, 7.0, 20.0)),
    ]
    .map(|(position, intensity)| Light::Point { position, intensity })
    .to_vec();

    Scene {
        name: "bumpy-glossy".into(),
        meshes,
        materials,
        textures: vec![bump_normal_map()],
        lights,
        environment: Environment::None,
        environment_rotation: glam::Quat::IDENTITY,
        camera: Camera {
            position: Vec3::new(0.0, 1.7, 3.8),
            target: Vec3::new(0.0, 0.35, -0.3),
            up: Vec3::Y,
            yfov: 50f32.to_radians(),
            znear: 0.02,
            zfar: 30.0,
        },
        warnings: Vec::new(),
        animation: None,
    }
}

/// A tiling tangent-space normal map of many small round bumps over fine diagonal ridges.
///
/// Built from a height field so the normals are integrable (a real surface), then encoded in glTF's
/// convention: +X along +u, +Y towards the top of the image (decreasing v), n·0.5 + 0.5. Each bump cell
/// has a hashed centre and radius, so the pattern is irregular but deterministic; bumps are evaluated in
/// the 3 × 3 neighbouring cells with wrap-around, so the map tiles seamlessly. Slopes reach about 40°.
pub fn bump_normal_map() -> Texture {
    let n = MAP_SIZE as usize;
    let cell = (MAP_SIZE / MAP_CELLS) as f32;
    let size = MAP_SIZE as f32;
    let mut height = vec![0.0f32; n * n];
    for y in 0..n {
        for x in 0..n {
            let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
            let (cx, cy) = ((px / cell) as i32, (py / cell) as i32);
            let mut h = 0.0;
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (kx, ky) = (cx + dx, cy + dy);
                    let id = [kx.rem_euclid(MAP_CELLS as i32) as u32, ky.rem_euclid(MAP_CELLS as i32) as u32];
                    let centre = Vec2::new(
                        (kx as f32 + 0.2 + 0.6 * hash_unit(&[id[0], id[1], 1])) * cell,
                        (ky as f32 + 0.2 + 0.6 * hash_unit(&[id[0], id[1], 2])) * cell,
                    );
                    let radius = cell * (0.35 + 0.3 * hash_unit(&[id[0], id[1], 3]));
                    let s2 = (Vec2::new(px, py) - centre).length_squared() / (radius * radius);
                    if s2 < 1.0 {
                        // (1 − s²)² has zero slope at the rim; peak slope ≈ 1.54 · amplitude / radius.
                        h += 0.55 * radius * (1.0 - s2) * (1.0 - s2);
                    }
                }
            }
            // Ridges: an integer number of periods across the map keeps it tileable.
            h += 0.6 * (TAU * (48.0 * px + 16.0 * py) / size).sin();
            height[y * n + x] = h;
        }
    }
    let rgba8 = encode_normals_from_height(&height, n);
    Texture { name: "bump-normal-map".into(), width: MAP_SIZE, height: MAP_SIZE, rgba8, srgb: false }
}

/// Encodes the normals of a tiling `n × n` height field (rows top to bottom, heights in texels) as an
/// RGBA8 tangent-space normal map in glTF's convention.
pub fn encode_normals_from_height(height: &[f32], n: usize) -> Vec<u8> {
    let at = |x: usize, y: usize| height[(y % n) * n + (x % n)];
    let mut rgba8 = Vec::with_capacity(n * n * 4);
    for y in 0..n {
        for x in 0..n {
            let dhdx = (at(x + 1, y) - at(x + n - 1, y)) * 0.5;
            let dh_drow = (at(x, y + 1) - at(x, y + n - 1)) * 0.5;
            // Image up is −row, so the +Y (up) component of the normal is −∂h/∂up = +∂h/∂row.
            let normal = Vec3::new(-dhdx, dh_drow, 1.0).normalize();
            let enc = (normal * 0.5 + 0.5) * 255.0;
            rgba8.extend([enc.x.round() as u8, enc.y.round() as u8, enc.z.round() as u8, 255]);
        }
    }
    rgba8
}
