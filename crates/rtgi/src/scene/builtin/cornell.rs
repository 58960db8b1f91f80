//! The Cornell box, from its published measurements.
//!
//! Geometry and camera: Cornell University Program of Computer Graphics, "Cornell Box Data"
//! (<https://www.graphics.cornell.edu/online/box/data.html>), coordinates in millimetres converted to metres.
//! The published quads are kept as they are, including the slightly skewed red wall (its floor edge runs
//! from x = 552.8 to 549.6 mm while the ceiling is 556 mm wide): renderers that compare against the
//! classic reference images use the same data. The floor-level faces of the blocks are not published (they
//! rest on the floor) and are left out.
//!
//! Materials and light: the diffuse albedos and the light's radiance (17, 12, 4) are the RGB values of the
//! widely used Mitsuba/PBRT conversion of the scene (Bitterli's rendering resources), not the measured
//! spectra. The light quad sits 0.1 mm below the ceiling (the data puts it in the ceiling plane) so it never
//! shares a depth with the ceiling in a rasteriser.

use glam::{Quat, Vec3, Vec4};

use super::motion;
use super::shapes::MeshBuilder;
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::scene::animation::{Interpolation, Property, Sampler, Trs};
use crate::scene::{Camera, Environment, Light, Material, Mesh, Scene};

pub const PARAMS: &[ParamSpec] = &[
    motion::animate_param(
        &["none", "box"],
        "box: a 12 cm box flies a loop above the blocks, turning once (4 s, LINEAR)",
    ),
    BACK_WALL,
];
pub const SPOT_PARAMS: &[ParamSpec] = &[
    motion::animate_param(
        &["none", "box", "spot"],
        "box: a 12 cm box flies a loop above the blocks, turning once (4 s, LINEAR); spot: the spot light \
         sweeps ±25° from side to side (about the view axis, 4 s)",
    ),
    BACK_WALL,
];

const BACK_WALL: ParamSpec = ParamSpec {
    name: "back_wall",
    kind: ParamKind::Choice(&["diffuse", "glossy"]),
    default: "diffuse",
    doc: "glossy: the back wall a white metal of roughness 0.55 (GGX α 0.3, about the Phong-20 lobe of the \
          radiance-caching thesis's glossy Cornell box)",
};

/// The glossy back wall's roughness: GGX α = 0.55² ≈ 0.30, the Beckmann α √(2 / (n + 2)) of a Phong
/// exponent n = 20.
pub const GLOSSY_BACK_WALL_ROUGHNESS: f32 = 0.55;

/// Duration of the animated variants' loops, seconds.
pub const LOOP_SECONDS: f32 = 4.0;

/// Emitted radiance of the ceiling light (Mitsuba/PBRT value).
pub const LIGHT_RADIANCE: Vec3 = Vec3::new(17.0, 12.0, 4.0);

/// Published light rectangle, millimetres: x 213–343, z 227–332, in the ceiling plane y = 548.8.
const LIGHT_MIN_MM: [f32; 2] = [213.0, 227.0];
const LIGHT_MAX_MM: [f32; 2] = [343.0, 332.0];
const CEILING_MM: f32 = 548.8;
/// Height of the emitting quad: just below the ceiling, see the module documentation.
pub const LIGHT_Y: f32 = (CEILING_MM - 0.1) * MM;

const MM: f32 = 0.001;

fn mm(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z) * MM
}

/// How the box is lit.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Lighting {
    /// The published emissive quad.
    AreaLight,
    /// One spot light near the ceiling instead of the quad (for techniques that only handle punctual
    /// lights, and to compare the two).
    Spot,
}

pub fn build(params: &ParamValues) -> Scene {
    let scene = cornell_box("cornell", Lighting::AreaLight, params.choice("back_wall") == "glossy");
    animate(scene, params.choice("animate"))
}

pub fn build_spot(params: &ParamValues) -> Scene {
    let scene = cornell_box("cornell-spot", Lighting::Spot, params.choice("back_wall") == "glossy");
    animate(scene, params.choice("animate"))
}

fn animate(mut scene: Scene, motion: &str) -> Scene {
    let times: Vec<f32> = (0..5).map(|k| k as f32 * LOOP_SECONDS / 4.0).collect();
    match motion {
        "box" => moving_box(&mut scene, &times),
        "spot" => {
            motion::sweep_light(&mut scene, "spot-sweep", 0, Vec3::Z, &times, &[0.0, 25.0, 0.0, -25.0, 0.0]);
        }
        _ => {}
    }
    scene
}

/// The loop of `cornell:animate=box`: corners of a square at 0.42 m, above both blocks (the tall one
/// is 0.33 m high) and below the light, so the box never touches anything.
pub const BOX_LOOP: [Vec3; 4] = [
    Vec3::new(0.15, 0.42, 0.15),
    Vec3::new(0.40, 0.42, 0.15),
    Vec3::new(0.40, 0.42, 0.40),
    Vec3::new(0.15, 0.42, 0.40),
];
pub const BOX_HALF: f32 = 0.06;

fn moving_box(scene: &mut Scene, times: &[f32]) {
    let centre = BOX_LOOP[0];
    let mut b = MeshBuilder::new();
    b.aabb(centre - Vec3::splat(BOX_HALF), centre + Vec3::splat(BOX_HALF), 1.0);
    scene.materials.push(Material::diffuse("box", Vec3::new(0.75, 0.6, 0.2)));
    scene.meshes.push(b.build("moving-box", scene.materials.len() as u32 - 1));
    let node =
        motion::add_root(scene, "box-loop", "moving-box", Trs { translation: centre, ..Default::default() });
    let path = BOX_LOOP.iter().chain([&centre]).map(|p| p.extend(0.0)).collect::<Vec<Vec4>>();
    motion::keys(
        scene,
        node,
        Property::Translation,
        Sampler::new(Interpolation::Linear, times.to_vec(), path),
    );
    motion::keys(
        scene,
        node,
        Property::Rotation,
        motion::turns(Quat::IDENTITY, Vec3::Y, times, &[0.0, 90.0, 180.0, 270.0, 360.0]),
    );
    motion::bind_mesh(scene, scene.meshes.len() - 1, node);
}

/// The spot light of `cornell-spot`.
///
/// Intensity: a Lambertian emitter of radiance L and area A has radiant intensity L·A along its normal,
/// so giving the spot I = L·A (same colour as the quad) makes the floor straight below it receive the
/// same irradiance E ≈ I / h² as under the area light (the spot hangs 1 cm lower, a 4 % difference).
/// It hangs at the ceiling centre and is tilted about 13° towards the tall block at the back, so the
/// block's front and the back wall are in the full (30°) cone, and the cone fades out by 40°.
pub fn spot_light() -> Light {
    let area = (LIGHT_MAX_MM[0] - LIGHT_MIN_MM[0]) * (LIGHT_MAX_MM[1] - LIGHT_MIN_MM[1]) * MM * MM;
    let position = mm(278.0, CEILING_MM - 10.0, 279.6);
    let aim = mm(340.0, 0.0, 390.0);
    Light::Spot {
        position,
        direction: (aim - position).normalize(),
        intensity: LIGHT_RADIANCE * area,
        inner_angle: 30f32.to_radians(),
        outer_angle: 40f32.to_radians(),
    }
}

fn cornell_box(name: &str, lighting: Lighting, glossy_back_wall: bool) -> Scene {
    const WHITE: u32 = 0;
    const RED: u32 = 1;
    const GREEN: u32 = 2;
    let white = Vec3::new(0.725, 0.71, 0.68);
    let mut materials = vec![
        Material::diffuse("white", white),
        Material::diffuse("red", Vec3::new(0.63, 0.065, 0.05)),
        Material::diffuse("green", Vec3::new(0.14, 0.45, 0.091)),
    ];
    let back = if glossy_back_wall {
        materials.push(Material {
            name: "glossy-white-metal".into(),
            base_color: white.extend(1.0),
            metallic: 1.0,
            roughness: GLOSSY_BACK_WALL_ROUGHNESS,
            ..Default::default()
        });
        materials.len() as u32 - 1
    } else {
        WHITE
    };
    // The walls face the inside of the box; UVs in metres.
    let inside = mm(278.0, 274.4, 279.6);
    let mut meshes = Vec::new();
    let mut wall = |name: &str, corners: [Vec3; 4], material: u32| {
        let mut b = MeshBuilder::new();
        let centre = corners.iter().copied().sum::<Vec3>() / 4.0;
        b.polygon(&corners, inside - centre, 1.0);
        meshes.push(b.build(name, material));
    };
    wall(
        "floor",
        [mm(552.8, 0.0, 0.0), mm(0.0, 0.0, 0.0), mm(0.0, 0.0, 559.2), mm(549.6, 0.0, 559.2)],
        WHITE,
    );
    wall(
        "ceiling",
        [
            mm(556.0, CEILING_MM, 0.0),
            mm(556.0, CEILING_MM, 559.2),
            mm(0.0, CEILING_MM, 559.2),
            mm(0.0, CEILING_MM, 0.0),
        ],
        WHITE,
    );
    wall(
        "back-wall",
        [
            mm(549.6, 0.0, 559.2),
            mm(0.0, 0.0, 559.2),
            mm(0.0, CEILING_MM, 559.2),
            mm(556.0, CEILING_MM, 559.2),
        ],
        back,
    );
    // The data's "left wall" is at x ≈ 0.55 m: with a right-handed camera looking along +z, +x is on the left.
    wall(
        "left-wall-red",
        [
            mm(552.8, 0.0, 0.0),
            mm(549.6, 0.0, 559.2),
            mm(556.0, CEILING_MM, 559.2),
            mm(556.0, CEILING_MM, 0.0),
        ],
        RED,
    );
    wall(
        "right-wall-green",
        [mm(0.0, 0.0, 559.2), mm(0.0, 0.0, 0.0), mm(0.0, CEILING_MM, 0.0), mm(0.0, CEILING_MM, 559.2)],
        GREEN,
    );
    let short_top = [[130.0, 65.0], [82.0, 225.0], [240.0, 272.0], [290.0, 114.0]];
    meshes.push(block("short-block", &short_top, 165.0, WHITE));
    let tall_top = [[423.0, 247.0], [265.0, 296.0], [314.0, 456.0], [472.0, 406.0]];
    meshes.push(block("tall-block", &tall_top, 330.0, WHITE));

    let mut lights = Vec::new();
    match lighting {
        Lighting::AreaLight => {
            let light = materials.len() as u32;
            materials.push(Material::emitter("light", LIGHT_RADIANCE));
            let [x0, z0] = LIGHT_MIN_MM.map(|v| v * MM);
            let [x1, z1] = LIGHT_MAX_MM.map(|v| v * MM);
            let corners = [
                Vec3::new(x0, LIGHT_Y, z0),
                Vec3::new(x1, LIGHT_Y, z0),
                Vec3::new(x1, LIGHT_Y, z1),
                Vec3::new(x0, LIGHT_Y, z1),
            ];
            let mut b = MeshBuilder::new();
            b.polygon(&corners, Vec3::NEG_Y, 1.0);
            meshes.push(b.build("light", light));
        }
        Lighting::Spot => lights.push(spot_light()),
    }

    Scene {
        name: name.into(),
        meshes,
        materials,
        textures: Vec::new(),
        lights,
        environment: Environment::None,
        environment_rotation: glam::Quat::IDENTITY,
        camera: camera(),
        warnings: Vec::new(),
        animation: None,
    }
}

/// The published camera: at (278, 273, −800) mm looking along +z, a 35 mm lens on a 25 mm × 25 mm
/// sensor, so the vertical field of view is 2·atan(12.5 / 35) = 39.3077°.
pub fn camera() -> Camera {
    Camera {
        position: mm(278.0, 273.0, -800.0),
        target: mm(278.0, 273.0, 0.0),
        up: Vec3::Y,
        yfov: 2.0 * (12.5f32 / 35.0).atan(),
        znear: 0.05,
        zfar: 10.0,
    }
}

/// A block from its published top face (x, z in mm) and height: the top and four sides, facing out.
fn block(name: &str, top_xz: &[[f32; 2]; 4], height_mm: f32, material: u32) -> Mesh {
    let top: Vec<Vec3> = top_xz.iter().map(|&[x, z]| mm(x, height_mm, z)).collect();
    let centre = top.iter().copied().sum::<Vec3>() / 4.0 - Vec3::Y * height_mm * MM * 0.5;
    let mut b = MeshBuilder::new();
    b.polygon(&top, Vec3::Y, 1.0);
    for i in 0..4 {
        let (p, q) = (top[i], top[(i + 1) % 4]);
        let side = [p, q, q.with_y(0.0), p.with_y(0.0)];
        let mid = (p + q) * 0.5 - Vec3::Y * height_mm * MM * 0.5;
        b.polygon(&side, mid - centre, 1.0);
    }
    b.build(name, material)
}
