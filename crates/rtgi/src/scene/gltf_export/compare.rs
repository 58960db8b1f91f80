//! Semantic comparison of two scenes, for round-trip tests (export then load must give back the same
//! scene up to float rounding).
//!
//! "The same" means what rendering depends on: the names of generated textures, the scene name,
//! warnings, and meshes without triangles (which the exporter leaves out) are not compared, and the
//! camera's `up` is compared after orthogonalisation against the view direction (only that part
//! affects the view matrix, and it is all that a glTF camera node can carry).

use glam::{Vec2, Vec3, Vec4};

use crate::scene::{Camera, Environment, Light, Material, Mesh, Scene, TextureRef};

/// Position, direction and radiometric tolerance (relative for magnitudes above 1).
const TOL: f32 = 1e-5;
/// Material factor tolerance (relative for magnitudes above 1, e.g. emissive radiance).
const FACTOR_TOL: f32 = 1e-6;

/// Every way in which `b` differs from `a` beyond float rounding, as readable lines (empty if the
/// scenes are equivalent).
pub fn scene_differences(a: &Scene, b: &Scene) -> Vec<String> {
    let mut d = Diffs::default();
    compare_meshes(&mut d, a, b);
    let (ba, bb) = (a.bounds(), b.bounds());
    if !ba.is_empty() || !bb.is_empty() {
        d.vec3("bounds.min", ba.min, bb.min, TOL);
        d.vec3("bounds.max", ba.max, bb.max, TOL);
    }
    compare_materials(&mut d, a, b);
    compare_lights(&mut d, a, b);
    compare_camera(&mut d, &a.camera, &b.camera);
    compare_environment(&mut d, &a.environment, &b.environment);
    // Matrices, not quaternions: q and −q are the same turn.
    d.floats(
        "environment rotation",
        &glam::Mat3::from_quat(a.environment_rotation).to_cols_array(),
        &glam::Mat3::from_quat(b.environment_rotation).to_cols_array(),
        FACTOR_TOL,
    );
    d.0
}

/// Panics with the list of differences if the scenes are not equivalent (see [`scene_differences`]).
#[track_caller]
pub fn assert_scenes_equivalent(a: &Scene, b: &Scene) {
    let diffs = scene_differences(a, b);
    assert!(diffs.is_empty(), "scenes differ ({} differences):\n  {}", diffs.len(), diffs.join("\n  "));
}

#[derive(Default)]
struct Diffs(Vec<String>);

fn close(x: f32, y: f32, tol: f32) -> bool {
    (x - y).abs() <= tol * 1f32.max(x.abs()).max(y.abs()) || (x.is_nan() && y.is_nan())
}

impl Diffs {
    fn push(&mut self, s: String) {
        self.0.push(s);
    }

    fn f32(&mut self, what: &str, x: f32, y: f32, tol: f32) {
        if !close(x, y, tol) {
            self.push(format!("{what}: {x} vs {y}"));
        }
    }

    fn floats(&mut self, what: &str, x: &[f32], y: &[f32], tol: f32) -> bool {
        let same = x.len() == y.len() && x.iter().zip(y).all(|(p, q)| close(*p, *q, tol));
        if !same {
            self.push(format!("{what}: {x:?} vs {y:?}"));
        }
        same
    }

    fn vec3(&mut self, what: &str, x: Vec3, y: Vec3, tol: f32) {
        self.floats(what, &x.to_array(), &y.to_array(), tol);
    }

    fn eq<T: PartialEq + std::fmt::Debug>(&mut self, what: &str, x: T, y: T) -> bool {
        let same = x == y;
        if !same {
            self.push(format!("{what}: {x:?} vs {y:?}"));
        }
        same
    }

    /// Compares per-vertex arrays, reporting only the first mismatch (a mesh can have millions).
    fn per_vertex<T: Copy>(&mut self, what: &str, x: &[T], y: &[T], tol: f32, f: impl Fn(T) -> Vec<f32>) {
        if !self.eq(&format!("{what} count"), x.len(), y.len()) {
            return;
        }
        let bad = x.iter().zip(y).enumerate().find(|(_, (p, q))| {
            let (p, q) = (f(**p), f(**q));
            !p.iter().zip(&q).all(|(u, v)| close(*u, *v, tol))
        });
        if let Some((i, (p, q))) = bad {
            self.push(format!("{what}[{i}]: {:?} vs {:?}", f(*p), f(*q)));
        }
    }
}

fn drawn(scene: &Scene) -> Vec<&Mesh> {
    scene.meshes.iter().filter(|m| m.indices.len() >= 3).collect()
}

fn compare_meshes(d: &mut Diffs, a: &Scene, b: &Scene) {
    let (ma, mb) = (drawn(a), drawn(b));
    if !d.eq("mesh count (meshes with triangles)", ma.len(), mb.len()) {
        return;
    }
    d.eq("triangle count", a.triangle_count(), b.triangle_count());
    for (i, (x, y)) in ma.iter().zip(&mb).enumerate() {
        let label = format!("mesh {i} '{}'", x.name);
        if !x.name.is_empty() {
            d.eq(&format!("{label} name"), &x.name, &y.name);
        }
        d.eq(&format!("{label} material index"), x.material, y.material);
        d.per_vertex(&format!("{label} positions"), &x.positions, &y.positions, TOL, |v: Vec3| {
            v.to_array().to_vec()
        });
        d.per_vertex(&format!("{label} normals"), &x.normals, &y.normals, TOL, |v: Vec3| {
            v.to_array().to_vec()
        });
        d.per_vertex(&format!("{label} tangents"), &x.tangents, &y.tangents, TOL, |v: Vec4| {
            v.to_array().to_vec()
        });
        d.per_vertex(&format!("{label} uvs"), &x.uvs, &y.uvs, FACTOR_TOL, |v: Vec2| v.to_array().to_vec());
        if x.indices != y.indices {
            let first = x.indices.iter().zip(&y.indices).position(|(p, q)| p != q);
            d.push(format!(
                "{label} indices differ ({} vs {} indices, first difference at {first:?})",
                x.indices.len(),
                y.indices.len()
            ));
        }
    }
}

fn compare_materials(d: &mut Diffs, a: &Scene, b: &Scene) {
    if !d.eq("material count", a.materials.len(), b.materials.len()) {
        return;
    }
    for (i, (x, y)) in a.materials.iter().zip(&b.materials).enumerate() {
        compare_material(d, &format!("material {i} '{}'", x.name), a, x, b, y);
    }
}

fn compare_material(d: &mut Diffs, label: &str, a: &Scene, x: &Material, b: &Scene, y: &Material) {
    if !x.name.is_empty() {
        d.eq(&format!("{label} name"), &x.name, &y.name);
    }
    d.floats(&format!("{label} base_color"), &x.base_color.to_array(), &y.base_color.to_array(), FACTOR_TOL);
    d.f32(&format!("{label} metallic"), x.metallic, y.metallic, FACTOR_TOL);
    d.f32(&format!("{label} roughness"), x.roughness, y.roughness, FACTOR_TOL);
    d.vec3(&format!("{label} emissive"), x.emissive, y.emissive, FACTOR_TOL);
    d.f32(&format!("{label} normal_scale"), x.normal_scale, y.normal_scale, FACTOR_TOL);
    d.f32(&format!("{label} specular"), x.specular, y.specular, FACTOR_TOL);
    match (x.alpha_mode, y.alpha_mode) {
        (crate::scene::AlphaMode::Mask { cutoff: p }, crate::scene::AlphaMode::Mask { cutoff: q }) => {
            d.f32(&format!("{label} alpha cutoff"), p, q, FACTOR_TOL)
        }
        (p, q) => {
            d.eq(&format!("{label} alpha_mode"), p, q);
        }
    }
    d.eq(&format!("{label} double_sided"), x.double_sided, y.double_sided);
    match (x.subsurface, y.subsurface) {
        (Some(p), Some(q)) => {
            d.vec3(&format!("{label} subsurface absorption"), p.absorption, q.absorption, FACTOR_TOL);
            d.vec3(
                &format!("{label} subsurface reduced scattering"),
                p.reduced_scattering,
                q.reduced_scattering,
                FACTOR_TOL,
            );
            d.f32(&format!("{label} subsurface eta"), p.eta, q.eta, FACTOR_TOL);
        }
        (p, q) => {
            d.eq(&format!("{label} subsurface"), p.is_some(), q.is_some());
        }
    }
    let slots = [
        ("base_color_texture", x.base_color_texture, y.base_color_texture),
        ("metallic_roughness_texture", x.metallic_roughness_texture, y.metallic_roughness_texture),
        ("emissive_texture", x.emissive_texture, y.emissive_texture),
        ("normal_texture", x.normal_texture, y.normal_texture),
    ];
    for (slot, p, q) in slots {
        compare_texture_ref(d, &format!("{label} {slot}"), a, p, b, q);
    }
}

/// Textures are compared by content: their indices may legitimately differ after a round trip.
fn compare_texture_ref(
    d: &mut Diffs,
    label: &str,
    a: &Scene,
    p: Option<TextureRef>,
    b: &Scene,
    q: Option<TextureRef>,
) {
    let (p, q) = match (p, q) {
        (None, None) => return,
        (Some(p), Some(q)) => (p, q),
        (p, q) => {
            d.push(format!("{label}: {p:?} vs {q:?}"));
            return;
        }
    };
    d.eq(&format!("{label} tex_coord"), p.tex_coord, q.tex_coord);
    let (Some(s), Some(t)) = (a.textures.get(p.texture as usize), b.textures.get(q.texture as usize)) else {
        d.push(format!("{label}: texture index out of range"));
        return;
    };
    d.eq(&format!("{label} size"), (s.width, s.height), (t.width, t.height));
    d.eq(&format!("{label} srgb"), s.srgb, t.srgb);
    if s.rgba8 != t.rgba8 {
        let first = s.rgba8.iter().zip(&t.rgba8).position(|(u, v)| u != v);
        d.push(format!("{label}: pixel data differ (first differing byte {first:?})"));
    }
}

fn compare_lights(d: &mut Diffs, a: &Scene, b: &Scene) {
    if !d.eq("light count", a.lights.len(), b.lights.len()) {
        return;
    }
    for (i, (x, y)) in a.lights.iter().zip(&b.lights).enumerate() {
        let label = format!("light {i}");
        match (*x, *y) {
            (Light::Point { position: p0, intensity: i0 }, Light::Point { position: p1, intensity: i1 }) => {
                d.vec3(&format!("{label} position"), p0, p1, TOL);
                d.vec3(&format!("{label} intensity"), i0, i1, TOL);
            }
            (
                Light::Spot { position: p0, direction: d0, intensity: i0, inner_angle: a0, outer_angle: o0 },
                Light::Spot { position: p1, direction: d1, intensity: i1, inner_angle: a1, outer_angle: o1 },
            ) => {
                d.vec3(&format!("{label} position"), p0, p1, TOL);
                d.vec3(&format!("{label} direction"), d0.normalize_or_zero(), d1.normalize_or_zero(), TOL);
                d.vec3(&format!("{label} intensity"), i0, i1, TOL);
                d.f32(&format!("{label} inner_angle"), a0, a1, TOL);
                d.f32(&format!("{label} outer_angle"), o0, o1, TOL);
            }
            (
                Light::Directional { direction: d0, irradiance: i0 },
                Light::Directional { direction: d1, irradiance: i1 },
            ) => {
                d.vec3(&format!("{label} direction"), d0.normalize_or_zero(), d1.normalize_or_zero(), TOL);
                d.vec3(&format!("{label} irradiance"), i0, i1, TOL);
            }
            (x, y) => d.push(format!("{label}: {} light vs {} light", x.kind_name(), y.kind_name())),
        }
    }
}

fn compare_camera(d: &mut Diffs, x: &Camera, y: &Camera) {
    d.vec3("camera position", x.position, y.position, TOL);
    d.vec3("camera target", x.target, y.target, TOL);
    let view_up = |c: &Camera| {
        let f = (c.target - c.position).normalize_or_zero();
        (c.up - f * c.up.dot(f)).normalize_or_zero()
    };
    d.vec3("camera up (orthogonalised)", view_up(x), view_up(y), TOL);
    d.f32("camera yfov", x.yfov, y.yfov, TOL);
    d.f32("camera znear", x.znear, y.znear, TOL);
    d.f32("camera zfar", x.zfar, y.zfar, TOL);
}

fn compare_environment(d: &mut Diffs, x: &Environment, y: &Environment) {
    match (x, y) {
        (Environment::None, Environment::None) => {}
        (Environment::Uniform(p), Environment::Uniform(q)) => {
            d.vec3("environment radiance", *p, *q, FACTOR_TOL)
        }
        (
            Environment::Sky { sun_direction: s0, sun_radiance: r0, sky_radiance: k0, ground_radiance: g0 },
            Environment::Sky { sun_direction: s1, sun_radiance: r1, sky_radiance: k1, ground_radiance: g1 },
        ) => {
            d.vec3("environment sun_direction", *s0, *s1, FACTOR_TOL);
            d.vec3("environment sun_radiance", *r0, *r1, FACTOR_TOL);
            d.vec3("environment sky_radiance", *k0, *k1, FACTOR_TOL);
            d.vec3("environment ground_radiance", *g0, *g1, FACTOR_TOL);
        }
        (Environment::Map(p), Environment::Map(q)) => {
            d.eq("environment map path", &p.path, &q.path);
            d.f32("environment map intensity", p.intensity, q.intensity, FACTOR_TOL);
            if d.eq("environment map size", (p.width, p.height), (q.width, q.height)) {
                let bad = p.rgb.iter().zip(&q.rgb).position(|(u, v)| !close(*u, *v, FACTOR_TOL));
                if let Some(i) = bad.or((p.rgb.len() != q.rgb.len()).then_some(0)) {
                    d.push(format!("environment map data differ (first at float {i})"));
                }
            }
        }
        (x, y) => d.push(format!("environment: {} vs {}", env_kind(x), env_kind(y))),
    }
}

fn env_kind(e: &Environment) -> &'static str {
    match e {
        Environment::None => "none",
        Environment::Uniform(_) => "uniform",
        Environment::Sky { .. } => "sky",
        Environment::Map(_) => "map",
    }
}
