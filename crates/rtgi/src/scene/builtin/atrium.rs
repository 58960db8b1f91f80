//! A procedural courtyard building in the spirit of Crytek Sponza: an open court of 30 m × 12 m ringed by
//! two storeys of round-arched arcades on columns, galleries with floors and ceilings behind them, outer
//! walls, and coloured cloths hanging from the upper balustrade, lit by a steep sun and the sky through the
//! open court.
//!
//! It exists to give techniques a Sponza-like workload (lots of indirect light in the galleries, thin
//! occluders, coloured bleeding from the cloths) with no asset files and a tunable size: `detail` scales
//! the tessellation from about 50 K triangles to over 1 M, for measuring how a technique's cost grows with
//! geometry.
//!
//! Layout (metres): the arcades' centre lines run at x = ±15 and z = ±6, with 3 m bays (10 along x, 4
//! along z). Arcade walls are 0.6 m thick; round columns carry 2.2 m-wide semicircular arches, square
//! piers stand at the corners. Ground storey: floor 0, arches spring at 3.2, gallery ceiling 5.0, upper
//! floor 5.3. Upper storey: arches spring at 8.2, gallery ceiling 10.0, roof 10.3. Galleries are 2.7 m
//! deep, to outer walls at x = ±18 and z = ±9 (0.5 m thick).

use std::f32::consts::{FRAC_PI_2, PI, TAU};

use glam::{Vec2, Vec3};

use super::shapes::{MeshBuilder, hash_unit, subdivide};
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::scene::{Camera, Environment, Light, Material, Scene};

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        name: "detail",
        kind: ParamKind::Int { min: 1, max: 5 },
        default: "1",
        doc: "tessellation level: 1 ≈ 55 K triangles, 2 ≈ 170 K, 3 ≈ 350 K, 4 ≈ 760 K, 5 ≈ 1.4 M",
    },
    super::motion::animate_param(
        &["none", "camera", "sun"],
        "camera: a 10 s camera flight around the court (CUBICSPLINE path, LINEAR turns); sun: the sun (and \
         the sky's sun glow) turns once about the vertical in 8 s",
    ),
];

/// The camera flight of `atrium:animate=camera`: key positions and the points looked at, every
/// [`FLIGHT_SECONDS`] / 6 s, a loop around the court at 1.7–3.5 m, 2 m or more from the arcades.
const FLIGHT: [(Vec3, Vec3); 6] = [
    (Vec3::new(-13.0, 1.7, 0.0), Vec3::new(10.0, 4.5, 0.0)),
    (Vec3::new(-5.0, 2.5, -3.5), Vec3::new(4.0, 3.0, 0.5)),
    (Vec3::new(6.0, 3.5, -3.0), Vec3::new(13.0, 2.5, 2.0)),
    (Vec3::new(12.0, 2.5, 0.0), Vec3::new(0.0, 3.0, 0.0)),
    (Vec3::new(5.0, 2.0, 3.5), Vec3::new(-6.0, 2.5, 0.0)),
    (Vec3::new(-6.0, 2.0, 3.5), Vec3::new(-15.0, 3.0, -3.0)),
];
pub const FLIGHT_SECONDS: f32 = 10.0;
pub const SUN_TURN_SECONDS: f32 = 8.0;

/// Tessellation per detail level.
struct Detail {
    /// Segments around a column (a multiple of [`FLUTES`] once fluted).
    column_segments: u32,
    /// Rings of the base moulding, the shaft and the capital.
    base_rings: u32,
    shaft_rings: u32,
    capital_rings: u32,
    fluted: bool,
    /// Segments of each semicircular arch (a multiple of 4, see [`arch_face`]).
    arch_segments: u32,
    /// Cloth grid: across, down.
    cloth: (u32, u32),
    /// Largest grid cell of floors, ceilings and walls, metres.
    cell: f32,
}

const DETAILS: [Detail; 5] = [
    Detail {
        column_segments: 24,
        base_rings: 4,
        shaft_rings: 8,
        capital_rings: 4,
        fluted: false,
        arch_segments: 16,
        cloth: (8, 20),
        cell: 1.0,
    },
    Detail {
        column_segments: 48,
        base_rings: 6,
        shaft_rings: 16,
        capital_rings: 6,
        fluted: true,
        arch_segments: 24,
        cloth: (16, 40),
        cell: 0.7,
    },
    Detail {
        column_segments: 64,
        base_rings: 8,
        shaft_rings: 28,
        capital_rings: 8,
        fluted: true,
        arch_segments: 32,
        cloth: (24, 60),
        cell: 0.5,
    },
    Detail {
        column_segments: 96,
        base_rings: 10,
        shaft_rings: 44,
        capital_rings: 10,
        fluted: true,
        arch_segments: 48,
        cloth: (36, 88),
        cell: 0.35,
    },
    Detail {
        column_segments: 128,
        base_rings: 12,
        shaft_rings: 64,
        capital_rings: 12,
        fluted: true,
        arch_segments: 64,
        cloth: (48, 112),
        cell: 0.25,
    },
];

/// Half extents (x, z) of the arcade centre lines and of the outer walls.
const COURT: Vec2 = Vec2::new(15.0, 6.0);
const OUTER: Vec2 = Vec2::new(18.0, 9.0);
/// Half extents of the outside of the 0.5 m-thick outer walls.
const EXTERIOR: Vec2 = Vec2::new(18.5, 9.5);
const BAY: f32 = 3.0;
/// Half thickness of the arcade walls.
const WALL: f32 = 0.3;
const ARCH_RADIUS: f32 = 1.1;
/// Half width of the column's abacus and of the corner piers: the arch openings start at its edge.
const ABACUS: f32 = 0.4;
const FLUTES: u32 = 16;

/// Per storey: floor level, arch springing, gallery ceiling, top of the arcade wall (next floor level).
const STOREYS: [[f32; 4]; 2] = [[0.0, 3.2, 5.0, 5.3], [5.3, 8.2, 10.0, 10.3]];
const BALUSTRADE_HEIGHT: f32 = 1.0;

/// The sun: direction towards it (60° above the horizon, leaning towards +z so one long arcade is sunlit
/// and the other in shadow) and its irradiance, 3·π-ish W/m², i.e. a white diffuser facing the sun has
/// radiance ≈ 3 × albedo.
const SUN_TOWARDS: Vec3 = Vec3::new(0.35, 1.0, 0.45);
const SUN_IRRADIANCE: Vec3 = Vec3::new(3.0 * PI, 2.8 * PI, 2.5 * PI);

const STONE: u32 = 0;
const PAVING: u32 = 1;
const GALLERY_FLOOR: u32 = 2;
const CEILING: u32 = 3;
const PLASTER: u32 = 4;
const ROOF: u32 = 5;
const CLOTH: [u32; 3] = [6, 7, 8];

pub fn build(params: &ParamValues) -> Scene {
    let mut scene = courtyard(params);
    match params.choice("animate") {
        "camera" => camera_flight(&mut scene),
        "sun" => {
            let times: Vec<f32> = (0..5).map(|k| k as f32 * SUN_TURN_SECONDS / 4.0).collect();
            let node = super::motion::sweep_light(
                &mut scene,
                "sun-turn",
                0,
                Vec3::Y,
                &times,
                &[0.0, 90.0, 180.0, 270.0, 360.0],
            );
            if let Some(anim) = scene.animation.as_mut() {
                anim.bindings.sun = Some(node);
            }
        }
        _ => {}
    }
    scene
}

/// Binds the camera to a node flying [`FLIGHT`] as a closed loop: positions on a Catmull-Rom spline
/// (CUBICSPLINE keys with tangents (p[k+1] − p[k−1]) / 2Δt, wrapping around), orientations slerped.
fn camera_flight(scene: &mut Scene) {
    use crate::scene::animation::{Interpolation, Property, Sampler, Trs, look_rotation};
    let n = FLIGHT.len();
    let dt = FLIGHT_SECONDS / n as f32;
    let times: Vec<f32> = (0..=n).map(|k| k as f32 * dt).collect();
    let position = |k: usize| FLIGHT[k % n].0;
    let mut path = Vec::new();
    for k in 0..=n {
        let tangent = (position(k + 1) - position(k + n - 1)) / (2.0 * dt);
        path.extend([tangent.extend(0.0), position(k).extend(0.0), tangent.extend(0.0)]);
    }
    let cam = scene.camera;
    let rest = Trs::looking(cam.position, cam.target - cam.position, cam.up);
    let turns = (0..=n)
        .map(|k| {
            let (p, target) = FLIGHT[k % n];
            // Key 0 is the rest camera itself, so that t = 0 shows the static scene.
            if k % n == 0 { rest.rotation } else { look_rotation(target - p, Vec3::Y) }
        })
        .map(glam::Vec4::from)
        .collect();
    let node = super::motion::add_root(scene, "camera-flight", "camera", rest);
    super::motion::keys(
        scene,
        node,
        Property::Translation,
        Sampler::new(Interpolation::CubicSpline, times.clone(), path),
    );
    super::motion::keys(scene, node, Property::Rotation, Sampler::new(Interpolation::Linear, times, turns));
    if let Some(anim) = scene.animation.as_mut() {
        anim.bindings.camera = Some(node);
    }
}

fn courtyard(params: &ParamValues) -> Scene {
    // The spec bounds detail to 1..=5; clamping keeps a direct caller from indexing out of range.
    let detail = &DETAILS[(params.int("detail").clamp(1, 5) - 1) as usize];
    let cloth = |name: &str, albedo: Vec3| Material { double_sided: true, ..Material::diffuse(name, albedo) };
    let materials = vec![
        Material::diffuse("stone", Vec3::new(0.58, 0.52, 0.44)),
        Material::diffuse("paving", Vec3::new(0.45, 0.42, 0.38)),
        Material::diffuse("gallery-floor", Vec3::new(0.4, 0.34, 0.3)),
        Material::diffuse("ceiling", Vec3::new(0.6, 0.56, 0.5)),
        Material::diffuse("plaster", Vec3::new(0.62, 0.56, 0.48)),
        Material::diffuse("roof", Vec3::new(0.35, 0.2, 0.15)),
        cloth("cloth-red", Vec3::new(0.6, 0.06, 0.05)),
        cloth("cloth-green", Vec3::new(0.08, 0.4, 0.1)),
        cloth("cloth-blue", Vec3::new(0.06, 0.12, 0.5)),
    ];

    let mut columns = MeshBuilder::new();
    let mut arcades = MeshBuilder::new();
    let mut balustrades = MeshBuilder::new();
    let mut cloths = [MeshBuilder::new(), MeshBuilder::new(), MeshBuilder::new()];
    for side in sides() {
        for (storey, levels) in STOREYS.iter().enumerate() {
            side.supports(&mut columns, levels[0], levels[1], detail);
            side.arches(&mut arcades, levels, detail);
            if storey == 1 {
                side.balustrade(&mut balustrades, levels[0]);
            }
        }
        side.cloths(&mut cloths, STOREYS[1][0] + BALUSTRADE_HEIGHT, detail);
    }

    let (floors, ceilings, roof) = floors_and_ceilings(detail.cell);
    // Outer walls: the inner faces, and the outside of the building (coarse: it is only seen from above,
    // and it keeps every surface a ray can reach single-sided and properly oriented).
    let mut walls = MeshBuilder::new();
    let top = STOREYS[1][3];
    for (half, facing, cell) in [(OUTER, 1.0, detail.cell), (EXTERIOR, -1.0, 4.0)] {
        walls.axis_rect(0, -half.x, Vec2::new(0.0, -half.y), Vec2::new(top, half.y), facing, cell);
        walls.axis_rect(0, half.x, Vec2::new(0.0, -half.y), Vec2::new(top, half.y), -facing, cell);
        walls.axis_rect(2, -half.y, Vec2::new(-half.x, 0.0), Vec2::new(half.x, top), facing, cell);
        walls.axis_rect(2, half.y, Vec2::new(-half.x, 0.0), Vec2::new(half.x, top), -facing, cell);
    }

    let [red, green, blue] = cloths;
    let meshes = vec![
        floors.0.build("court-floor", PAVING),
        floors.1.build("gallery-floors", GALLERY_FLOOR),
        ceilings.build("gallery-ceilings", CEILING),
        roof.build("roof", ROOF),
        walls.build("outer-walls", PLASTER),
        columns.build("columns", STONE),
        arcades.build("arcades", STONE),
        balustrades.build("balustrades", STONE),
        red.build("cloths-red", CLOTH[0]),
        green.build("cloths-green", CLOTH[1]),
        blue.build("cloths-blue", CLOTH[2]),
    ];

    let sun = SUN_TOWARDS.normalize();
    Scene {
        name: "atrium".into(),
        meshes,
        materials,
        textures: Vec::new(),
        lights: vec![Light::Directional { direction: -sun, irradiance: SUN_IRRADIANCE }],
        // The sky model has no sun disc, only a broad glow around `sun_direction` (see
        // `shaders/common/environment.wgsl`): the directional light carries the sun, and the glow is kept
        // faint (≈ 0.3 W/m²) so the sun's energy is not counted twice. Sky ≈ 0.6 gives ≈ 2 W/m² on the
        // open ground against ≈ 8 W/m² from the sun, a clear-day ratio.
        environment: Environment::Sky {
            sun_direction: sun,
            sun_radiance: Vec3::new(1.5, 1.4, 1.2),
            sky_radiance: Vec3::new(0.45, 0.6, 0.9),
            ground_radiance: Vec3::new(0.2, 0.18, 0.15),
        },
        environment_rotation: glam::Quat::IDENTITY,
        camera: Camera {
            position: Vec3::new(-13.0, 1.7, 0.0),
            target: Vec3::new(10.0, 4.5, 0.0),
            up: Vec3::Y,
            yfov: 60f32.to_radians(),
            znear: 0.05,
            zfar: 200.0,
        },
        warnings: Vec::new(),
        animation: None,
    }
}

/// One side of the court: an arcade along `along`, its centre line at `across · line`.
#[derive(Clone, Copy)]
struct Side {
    along: Vec3,
    across: Vec3,
    /// Signed position of the centre line along `across` (the court is on the side of smaller |d|).
    line: f32,
    /// Half length of the arcade: the centre line of the perpendicular arcades.
    half_length: f32,
    bays: u32,
}

fn sides() -> [Side; 4] {
    let x_side = |line| Side { along: Vec3::X, across: Vec3::Z, line, half_length: COURT.x, bays: 10 };
    let z_side = |line| Side { along: Vec3::Z, across: Vec3::X, line, half_length: COURT.y, bays: 4 };
    [x_side(-COURT.y), x_side(COURT.y), z_side(-COURT.x), z_side(COURT.x)]
}

impl Side {
    fn point(&self, s: f32, y: f32, d: f32) -> Vec3 {
        self.along * s + Vec3::Y * y + self.across * d
    }

    /// Unit vector from the arcade towards the court.
    fn towards_court(&self) -> Vec3 {
        -self.across * self.line.signum()
    }

    /// d of the court-side face and of the gallery-side face.
    fn faces(&self) -> (f32, f32) {
        (self.line - WALL * self.line.signum(), self.line + WALL * self.line.signum())
    }

    /// s of support `k` (0..=bays); the two ends are corner piers shared with the perpendicular sides.
    fn support_s(&self, k: u32) -> f32 {
        -self.half_length + BAY * k as f32
    }

    /// Round columns between the corners of this side. The four square corner piers are emitted by the
    /// two long sides (both ends of each), so every corner is built exactly once.
    fn supports(&self, b: &mut MeshBuilder, floor: f32, spring: f32, detail: &Detail) {
        for k in 1..self.bays {
            column(b, self.point(self.support_s(k), floor, self.line), spring - floor, detail);
        }
        if self.along == Vec3::X {
            for s in [-self.half_length, self.half_length] {
                let centre = self.point(s, floor, self.line);
                b.aabb(
                    centre - Vec3::new(ABACUS, 0.0, ABACUS),
                    centre + Vec3::new(ABACUS, spring - floor, ABACUS),
                    1.0,
                );
            }
        }
    }

    /// The arcade wall of one storey above the springing: per bay, the court face and the gallery face
    /// around the arch opening, and the arch's intrados.
    fn arches(&self, b: &mut MeshBuilder, levels: &[f32; 4], detail: &Detail) {
        let [_, spring, ceiling, top] = *levels;
        let (d_court, d_gallery) = self.faces();
        // Where the faces end at the corners: at the perpendicular arcade's faces.
        let court_end = self.half_length - WALL;
        let gallery_end = self.half_length + WALL;
        let to_court = self.towards_court();
        for k in 0..self.bays {
            let (sa, sb) = (self.support_s(k), self.support_s(k + 1));
            let centre = (sa + sb) * 0.5;
            let arch = Arch { centre, radius: ARCH_RADIUS, spring, segments: detail.arch_segments };
            let clamp = |s: f32, end: f32| s.clamp(-end, end);
            arch_face(b, self, &arch, [clamp(sa, court_end), clamp(sb, court_end)], top, d_court, to_court);
            arch_face(
                b,
                self,
                &arch,
                [clamp(sa, gallery_end), clamp(sb, gallery_end)],
                ceiling,
                d_gallery,
                -to_court,
            );
            intrados(b, self, &arch, d_court, d_gallery);
        }
    }

    /// A 1 m parapet between the upper columns, flush with the arcade's court face.
    fn balustrade(&self, b: &mut MeshBuilder, floor: f32) {
        let (d_court, _) = self.faces();
        let d_back = self.line;
        for k in 0..self.bays {
            let (sa, sb) = (self.support_s(k) + 0.36, self.support_s(k + 1) - 0.36);
            let sa = if k == 0 { self.support_s(0) + ABACUS } else { sa };
            let sb = if k + 1 == self.bays { self.support_s(self.bays) - ABACUS } else { sb };
            let p = self.point(sa, floor, d_court.min(d_back));
            let q = self.point(sb, floor + BALUSTRADE_HEIGHT, d_court.max(d_back));
            b.aabb(p.min(q), p.max(q), 1.0);
        }
    }

    /// Banners hanging from the balustrade over the ground arcade, on the long sides, bays 1–8, cycling
    /// red, green, blue. Each is a subdivided sheet pushed out from the wall by a deterministic wave: folds
    /// across, a ripple down, growing towards the free bottom edge, and a slight waist, so it reads as
    /// draped cloth; the wave never brings it closer than 2 cm to the wall.
    fn cloths(&self, out: &mut [MeshBuilder; 3], hang_y: f32, detail: &Detail) {
        if self.along != Vec3::X {
            return;
        }
        let (d_court, _) = self.faces();
        let to_court = self.towards_court();
        // `along × −Y` must point to the court for the sheet's front to face it.
        let dir = if self.along.cross(Vec3::NEG_Y).dot(to_court) > 0.0 { 1.0 } else { -1.0 };
        let (width, length) = (1.6, 2.5);
        let (nu, nv) = detail.cloth;
        let side_id = (self.line > 0.0) as u32;
        for k in 1..self.bays - 1 {
            let centre = (self.support_s(k) + self.support_s(k + 1)) * 0.5;
            let phase = TAU * hash_unit(&[side_id, k]);
            let folds = 2.0 + (3.0 * hash_unit(&[side_id, k, 7])).floor();
            let position = |i: u32, j: u32| {
                let (u, t) = (i as f32 / nu as f32, j as f32 / nv as f32);
                let waist = 1.0 - 0.06 * (PI * t).sin();
                let s = centre + dir * (u - 0.5) * width * waist;
                let out = 0.02
                    + t * (0.06 + 0.05 * (TAU * folds * u + phase).sin())
                    + t * 0.012 * (TAU * (3.0 * t + 1.5 * u) + phase).sin();
                self.point(s, hang_y - length * t, d_court) + to_court * out
            };
            let uv = |i: u32, j: u32| Vec2::new(width * i as f32 / nu as f32, length * j as f32 / nv as f32);
            out[(k as usize - 1) % 3].surface(nu, nv, false, position, uv);
        }
    }
}

/// A semicircular arch: centre (s) and radius of the opening, springing height, segments.
struct Arch {
    centre: f32,
    radius: f32,
    spring: f32,
    segments: u32,
}

impl Arch {
    /// (s, y) of point `i` of the intrados, from the left springing (i = 0) over the crown to the right.
    fn point(&self, i: u32) -> Vec2 {
        let a = PI * i as f32 / self.segments as f32;
        Vec2::new(self.centre - self.radius * a.cos(), self.spring + self.radius * a.sin())
    }
}

/// The flat face of one bay's wall around its arch, in the plane `d`: the region between the rectangle
/// `[s0, s1] × [spring, top]` and the semicircle, as a strip of quads joining intrados point i to point i
/// of the rectangle's left, top and right edges (a quarter, a half and a quarter of the segments). Side
/// points are computed from an integer level counted from the springing on both sides, so neighbouring
/// bays produce bit-identical vertices along their shared edge.
fn arch_face(
    b: &mut MeshBuilder,
    side: &Side,
    arch: &Arch,
    [s0, s1]: [f32; 2],
    top: f32,
    d: f32,
    facing: Vec3,
) {
    let n = arch.segments;
    let q = n / 4;
    let height = top - arch.spring;
    let level = |k: u32| arch.spring + height * k as f32 / q as f32;
    let boundary = |i: u32| match i {
        i if i <= q => Vec2::new(s0, level(i)),
        i if i >= 3 * q => Vec2::new(s1, level(n - i)),
        i => Vec2::new(s0 + (s1 - s0) * (i - q) as f32 / (2 * q) as f32, top),
    };
    let base = b.positions.len() as u32;
    for i in 0..=n {
        for p in [arch.point(i), boundary(i)] {
            b.vertex(side.point(p.x, p.y, d), facing, Vec2::new(p.x, top - p.y));
        }
    }
    for i in 0..n {
        let [c0, o0, c1, o1] = [0, 1, 2, 3].map(|k| base + 2 * i + k);
        oriented_quad(b, [c0, c1, o1, o0], facing);
    }
}

/// The underside of an arch through the wall, from the court face to the gallery face; its normals point
/// at the arch's axis.
fn intrados(b: &mut MeshBuilder, side: &Side, arch: &Arch, d0: f32, d1: f32) {
    let base = b.positions.len() as u32;
    for i in 0..=arch.segments {
        let p = arch.point(i);
        let a = PI * i as f32 / arch.segments as f32;
        let normal = side.along * a.cos() - Vec3::Y * a.sin();
        let u = arch.radius * a;
        b.vertex(side.point(p.x, p.y, d0), normal, Vec2::new(u, 0.0));
        b.vertex(side.point(p.x, p.y, d1), normal, Vec2::new(u, (d1 - d0).abs()));
    }
    for i in 0..arch.segments {
        let [a0, a1, b0, b1] = [0, 1, 2, 3].map(|k| base + 2 * i + k);
        let mid = (b.normals[a0 as usize] + b.normals[b0 as usize]).normalize();
        oriented_quad(b, [a0, b0, b1, a1], mid);
    }
}

/// Adds quad `[a, b, c, d]` (a convex loop in either winding) as two triangles facing `facing`.
fn oriented_quad(b: &mut MeshBuilder, [p0, p1, p2, p3]: [u32; 4], facing: Vec3) {
    let pos = |i: u32| b.positions[i as usize];
    let n = (pos(p1) - pos(p0)).cross(pos(p2) - pos(p0)) + (pos(p2) - pos(p0)).cross(pos(p3) - pos(p0));
    if n.dot(facing) >= 0.0 {
        b.triangle(p0, p1, p2);
        b.triangle(p0, p2, p3);
    } else {
        b.triangle(p0, p2, p1);
        b.triangle(p0, p3, p2);
    }
}

/// A column section's radius as a function of height fraction t and angle θ.
type Profile<'a> = &'a dyn Fn(f32, f32) -> f32;

/// A column standing at `base`, `height` up to the top of its abacus: square plinth, a half-round base
/// moulding, a shaft with entasis (and 16 flutes from detail 2), a flaring capital and a square abacus.
fn column(b: &mut MeshBuilder, base: Vec3, height: f32, detail: &Detail) {
    const PLINTH: f32 = 0.2;
    const PLINTH_HALF: f32 = 0.36;
    const MOULDING: f32 = 0.18;
    const CAPITAL: f32 = 0.3;
    const ABACUS_HEIGHT: f32 = 0.2;
    const SHAFT_RADIUS: f32 = 0.26;
    b.aabb(
        base - Vec3::new(PLINTH_HALF, 0.0, PLINTH_HALF),
        base + Vec3::new(PLINTH_HALF, PLINTH, PLINTH_HALF),
        1.0,
    );
    let abacus_y = height - ABACUS_HEIGHT;
    b.aabb(base + Vec3::new(-ABACUS, abacus_y, -ABACUS), base + Vec3::new(ABACUS, height, ABACUS), 1.0);

    let segments = detail.column_segments;
    let shaft = (PLINTH + MOULDING, abacus_y - CAPITAL);
    // Entasis: the shaft narrows by 12 % towards the top along a gentle curve.
    let shaft_radius = |t: f32| SHAFT_RADIUS * (1.0 - 0.12 * t * t);
    let flute = |theta: f32, t: f32| {
        if !detail.fluted {
            return 1.0;
        }
        // Concave semicircular grooves with sharp arrises, fading out just before both ends.
        let phase = (theta * FLUTES as f32 / TAU).fract();
        let groove = (1.0 - (2.0 * phase - 1.0).powi(2)).max(0.0).sqrt();
        let fade = (t.min(1.0 - t) / 0.05).clamp(0.0, 1.0);
        1.0 - 0.05 * groove * fade
    };
    let sections: [(f32, f32, u32, Profile); 3] = [
        // A half-round torus on the plinth.
        (PLINTH, PLINTH + MOULDING, detail.base_rings, &|t, _| SHAFT_RADIUS + 0.01 + 0.07 * (PI * t).sin()),
        (shaft.0, shaft.1, detail.shaft_rings, &|t, theta| shaft_radius(t) * flute(theta, t)),
        // The echinus flares from the shaft's top radius out under the abacus.
        (shaft.1, abacus_y, detail.capital_rings, &|t, _| {
            shaft_radius(1.0) + (ABACUS - 0.02 - shaft_radius(1.0)) * (FRAC_PI_2 * t).sin()
        }),
    ];
    let circumference = TAU * SHAFT_RADIUS;
    for (y0, y1, rings, radius) in sections {
        b.surface(
            segments,
            rings,
            true,
            |i, j| {
                let theta = TAU * (i % segments) as f32 / segments as f32;
                let t = j as f32 / rings as f32;
                let r = radius(t, theta);
                base + Vec3::new(r * theta.cos(), y0 + (y1 - y0) * t, -r * theta.sin())
            },
            |i, j| {
                let t = j as f32 / rings as f32;
                Vec2::new(circumference * i as f32 / segments as f32, height - (y0 + (y1 - y0) * t))
            },
        );
    }
}

/// Ground floors (court paving, gallery floors), gallery ceilings and the roof over the galleries.
/// Rings are cut from one lattice per level, so they have no T-junctions.
fn floors_and_ceilings(cell: f32) -> ((MeshBuilder, MeshBuilder), MeshBuilder, MeshBuilder) {
    let lattice = |inner: Vec2, outer: Vec2| {
        let xs = subdivide(&[-outer.x, -inner.x, inner.x, outer.x], cell);
        let zs = subdivide(&[-outer.y, -inner.y, inner.y, outer.y], cell);
        (xs, zs)
    };
    let outside = |inner: Vec2| move |p: Vec2| p.x.abs() > inner.x || p.y.abs() > inner.y;
    let inside = |inner: Vec2| move |p: Vec2| p.x.abs() < inner.x && p.y.abs() < inner.y;

    let (mut court, mut gallery, mut ceilings, mut roof) =
        (MeshBuilder::new(), MeshBuilder::new(), MeshBuilder::new(), MeshBuilder::new());
    let (xs, zs) = lattice(COURT, OUTER);
    court.horizontal_lattice(0.0, &xs, &zs, true, 0.5, inside(COURT));
    gallery.horizontal_lattice(0.0, &xs, &zs, true, 0.5, outside(COURT));
    // Floors above and the roof reach the arcade's court face (the roof also covers the outer walls);
    // ceilings stop at its gallery face.
    let court_face = COURT - Vec2::splat(WALL);
    let gallery_face = COURT + Vec2::splat(WALL);
    let (xs, zs) = lattice(court_face, OUTER);
    gallery.horizontal_lattice(STOREYS[1][0], &xs, &zs, true, 0.5, outside(court_face));
    let (xs, zs) = lattice(court_face, EXTERIOR);
    roof.horizontal_lattice(STOREYS[1][3], &xs, &zs, true, 0.5, outside(court_face));
    let (xs, zs) = lattice(gallery_face, OUTER);
    for storey in STOREYS {
        ceilings.horizontal_lattice(storey[2], &xs, &zs, false, 0.5, outside(gallery_face));
    }
    ((court, gallery), ceilings, roof)
}
