//! Two closed rooms joined only by a doorway, one lit and one dark: a light-leak test.
//!
//! Probe grids, voxel cones, radiance caches and screen-space methods all tend to let light through thin
//! walls. Here the only light is a spot in room 1 aimed at its floor away from the doorway, so room 2
//! receives light only after at least one bounce and only through the doorway: anything brighter (light
//! on room 2's side of the 5 cm wall, on its floor out of line with the doorway) is a leak. The camera
//! stands in room 2 and looks through the doorway, so both rooms are in view.

use glam::{Vec2, Vec3};

use super::shapes::MeshBuilder;
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::scene::{Camera, Environment, Light, Material, Scene};

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        name: "door_width",
        kind: ParamKind::Float { min: 0.3, max: 2.0 },
        default: "0.9",
        doc: "width of the doorway in metres (it is 2 m high)",
    },
    super::motion::animate_param(
        &["none", "spot"],
        "spot: the spot light sweeps ±30° about the vertical (6 s), its cone never reaching the doorway",
    ),
];

/// Thickness of the wall between the rooms, metres.
pub const WALL_THICKNESS: f32 = 0.05;
/// Inner width (x) of each room.
pub const ROOM_WIDTH: f32 = 4.0;
/// Inner depth (z) of each room, centred on z = 0.
pub const ROOM_DEPTH: f32 = 4.0;
pub const ROOM_HEIGHT: f32 = 2.7;
pub const DOOR_HEIGHT: f32 = 2.0;

/// Grid cell size: walls are subdivided for techniques that store lighting per vertex.
const CELL: f32 = 0.5;

/// The x extent of room 1 (lit) and room 2 (dark); the dividing wall is centred on x = 0.
pub fn room_x_ranges() -> [(f32, f32); 2] {
    let t = WALL_THICKNESS * 0.5;
    [(-t - ROOM_WIDTH, -t), (t, t + ROOM_WIDTH)]
}

pub fn build(params: &ParamValues) -> Scene {
    let mut scene = rooms(params);
    if params.choice("animate") == "spot" {
        super::motion::sweep_light(
            &mut scene,
            "spot-sweep",
            0,
            Vec3::Y,
            &[0.0, 1.5, 3.0, 4.5, 6.0],
            &[0.0, 30.0, 0.0, -30.0, 0.0],
        );
    }
    scene
}

fn rooms(params: &ParamValues) -> Scene {
    let door_half = params.float("door_width") as f32 * 0.5;
    let t = WALL_THICKNESS * 0.5;
    let [(x0, _), (_, x1)] = room_x_ranges();
    let (z0, z1) = (-ROOM_DEPTH * 0.5, ROOM_DEPTH * 0.5);
    let (h, dh) = (ROOM_HEIGHT, DOOR_HEIGHT);

    let materials = vec![
        Material::diffuse("wall", Vec3::new(0.7, 0.7, 0.7)),
        Material::diffuse("floor", Vec3::new(0.55, 0.42, 0.3)),
        Material::diffuse("ceiling", Vec3::new(0.75, 0.75, 0.75)),
    ];

    // The outer shell is one box spanning both rooms (the divider stands on the floor and meets the
    // ceiling and the long walls), so it is closed by construction.
    let mut floor = MeshBuilder::new();
    floor.axis_rect(1, 0.0, Vec2::new(z0, x0), Vec2::new(z1, x1), 1.0, CELL);
    let mut ceiling = MeshBuilder::new();
    ceiling.axis_rect(1, h, Vec2::new(z0, x0), Vec2::new(z1, x1), -1.0, CELL);

    let mut walls = MeshBuilder::new();
    walls.axis_rect(0, x0, Vec2::new(0.0, z0), Vec2::new(h, z1), 1.0, CELL);
    walls.axis_rect(0, x1, Vec2::new(0.0, z0), Vec2::new(h, z1), -1.0, CELL);
    walls.axis_rect(2, z0, Vec2::new(x0, 0.0), Vec2::new(x1, h), 1.0, CELL);
    walls.axis_rect(2, z1, Vec2::new(x0, 0.0), Vec2::new(x1, h), -1.0, CELL);

    // The dividing wall: each room's face minus the doorway (three rectangles), and the doorway's reveals.
    let mut divider = MeshBuilder::new();
    for (x, facing) in [(-t, -1.0), (t, 1.0)] {
        divider.axis_rect(0, x, Vec2::new(0.0, z0), Vec2::new(h, -door_half), facing, CELL);
        divider.axis_rect(0, x, Vec2::new(0.0, door_half), Vec2::new(h, z1), facing, CELL);
        divider.axis_rect(0, x, Vec2::new(dh, -door_half), Vec2::new(h, door_half), facing, CELL);
    }
    divider.axis_rect(2, -door_half, Vec2::new(-t, 0.0), Vec2::new(t, dh), 1.0, CELL);
    divider.axis_rect(2, door_half, Vec2::new(-t, 0.0), Vec2::new(t, dh), -1.0, CELL);
    divider.axis_rect(1, dh, Vec2::new(-door_half, -t), Vec2::new(door_half, t), -1.0, CELL);

    Scene {
        name: "two-rooms".into(),
        meshes: vec![
            floor.build("floor", 1),
            ceiling.build("ceiling", 2),
            walls.build("outer-walls", 0),
            divider.build("dividing-wall", 0),
        ],
        materials,
        textures: Vec::new(),
        lights: vec![spot_light()],
        environment: Environment::None,
        environment_rotation: glam::Quat::IDENTITY,
        camera: Camera {
            position: Vec3::new(3.5, 1.6, 1.6),
            target: Vec3::new(-2.5, 0.7, -1.0),
            up: Vec3::Y,
            yfov: 55f32.to_radians(),
            znear: 0.02,
            zfar: 20.0,
        },
        warnings: Vec::new(),
        animation: None,
    }
}

/// The only light: high in room 1, aimed at room 1's far corner, about 80° away from the doorway, so the
/// 35° cone never reaches it. 60 W/sr gives about 5 W/m² where it lands (3.1 m away, 35° incidence).
pub fn spot_light() -> Light {
    let position = Vec3::new(-2.0, 2.55, 0.0);
    Light::Spot {
        position,
        direction: (Vec3::new(-3.2, 0.0, -1.3) - position).normalize(),
        intensity: Vec3::new(60.0, 57.0, 50.0),
        inner_angle: 25f32.to_radians(),
        outer_angle: 35f32.to_radians(),
    }
}
