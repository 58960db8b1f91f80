//! Translucent objects for the `subsurface` technique: a sphere and a thin upright slab of measured
//! media (Jensen et al. 2001) on a diffuse floor before a wall, lit from the front by a point light
//! and from behind by a spot light, so that light bleeding into shadows (the sphere's terminator) and
//! light shining through a thin object (the slab's unlit front) both show.
//!
//! The media are measured in mm⁻¹ for objects a few centimetres across; the scene's objects are about
//! a metre, so `enlarge` scales the coefficients as if the objects were that much smaller.

use glam::{Quat, Vec2, Vec3, Vec4};

use super::motion;
use super::shapes::MeshBuilder;
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::scene::animation::{Interpolation, Property, Sampler, Trs};
use crate::scene::{Camera, Environment, Light, Material, Scene, Subsurface};

/// The names of `scene::subsurface::MEASURED_MEDIA` (a test checks they agree).
const MEDIA: &[&str] =
    &["apple", "cream", "ketchup", "marble", "potato", "skimmilk", "skin1", "skin2", "wholemilk"];

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        name: "sphere",
        kind: ParamKind::Choice(MEDIA),
        default: "skin1",
        doc: "measured medium of the sphere (Jensen et al. 2001)",
    },
    ParamSpec {
        name: "slab",
        kind: ParamKind::Choice(MEDIA),
        default: "marble",
        doc: "measured medium of the 12 cm slab",
    },
    ParamSpec {
        name: "enlarge",
        kind: ParamKind::Float { min: 1.0, max: 1000.0 },
        default: "40",
        doc: "how many times larger than the measured material the objects are (coefficients ÷ this)",
    },
    motion::animate_param(
        &["none", "sphere"],
        "sphere: the sphere slides 0.4 m towards the slab and back while turning once about the vertical (4 s)",
    ),
];

pub const SPHERE_CENTER: Vec3 = Vec3::new(-0.7, 0.5, 0.0);
pub const SPHERE_RADIUS: f32 = 0.5;
/// The slab's centre and half extents (x, y, z): 12 cm thick along z.
pub const SLAB_CENTER: Vec3 = Vec3::new(0.75, 0.55, -0.1);
pub const SLAB_HALF: Vec3 = Vec3::new(0.4, 0.55, 0.06);

pub fn build(params: &ParamValues) -> Scene {
    let enlarge = params.float("enlarge") as f32;
    let medium = |name: &str| Subsurface::measured(name, enlarge).expect("a measured medium");
    let materials = vec![
        Material::diffuse("floor", Vec3::new(0.5, 0.5, 0.5)),
        Material::diffuse("wall", Vec3::new(0.6, 0.62, 0.65)),
        Material::translucent("sphere", medium(params.choice("sphere"))),
        Material::translucent("slab", medium(params.choice("slab"))),
    ];
    let mut floor = MeshBuilder::new();
    floor.grid(Vec3::new(-4.0, 0.0, 4.0), Vec3::new(8.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -8.0), 8, 8, 1.0);
    let mut wall = MeshBuilder::new();
    wall.grid(Vec3::new(-4.0, 0.0, -2.0), Vec3::new(8.0, 0.0, 0.0), Vec3::new(0.0, 4.0, 0.0), 8, 4, 1.0);
    let mut sphere = MeshBuilder::new();
    sphere.uv_sphere(SPHERE_CENTER, SPHERE_RADIUS, 64, 32, Vec2::ONE);
    let mut slab = MeshBuilder::new();
    slab.aabb(SLAB_CENTER - SLAB_HALF, SLAB_CENTER + SLAB_HALF, 1.0);
    let mut scene = Scene {
        name: "translucent".into(),
        meshes: vec![
            floor.build("floor", 0),
            wall.build("wall", 1),
            sphere.build("sphere", 2),
            slab.build("slab", 3),
        ],
        materials,
        lights: vec![
            Light::Point { position: Vec3::new(-2.2, 2.4, 2.0), intensity: Vec3::new(9.0, 8.6, 8.0) },
            // Behind the slab, aimed through it at the camera's side of the scene.
            Light::Spot {
                position: Vec3::new(1.0, 1.4, -1.6),
                direction: (SLAB_CENTER - Vec3::new(1.0, 1.4, -1.6)).normalize(),
                intensity: Vec3::new(14.0, 13.0, 12.0),
                inner_angle: 20f32.to_radians(),
                outer_angle: 30f32.to_radians(),
            },
        ],
        environment: Environment::None,
        camera: Camera {
            position: Vec3::new(0.2, 1.3, 3.2),
            target: Vec3::new(0.0, 0.45, 0.0),
            up: Vec3::Y,
            yfov: 40f32.to_radians(),
            znear: 0.02,
            zfar: 20.0,
        },
        ..Default::default()
    };
    if params.choice("animate") == "sphere" {
        let times = [0.0, 1.0, 2.0, 3.0, 4.0];
        let node = motion::add_root(
            &mut scene,
            "sphere-slide",
            "sphere",
            Trs { translation: SPHERE_CENTER, ..Default::default() },
        );
        let path = [0.0, 0.2, 0.4, 0.2, 0.0].map(|dx| (SPHERE_CENTER + Vec3::X * dx).extend(0.0));
        motion::keys(
            &mut scene,
            node,
            Property::Translation,
            Sampler::new(Interpolation::Linear, times.to_vec(), path.to_vec() as Vec<Vec4>),
        );
        motion::keys(
            &mut scene,
            node,
            Property::Rotation,
            motion::turns(Quat::IDENTITY, Vec3::Y, &times, &[0.0, 90.0, 180.0, 270.0, 360.0]),
        );
        motion::bind_mesh(&mut scene, 2, node);
    }
    scene
}
