//! The scene model: plain CPU data, no GPU types.
//!
//! Built-in procedural scenes and the glTF loader both produce a [`Scene`]. Geometry is stored in world
//! space (node transforms are baked in at load time) because the BVH and every technique want
//! world-space triangles. Animated scenes store their rest pose that way and add a
//! [`SceneAnimation`] (see [`animation`]) that poses it at any time: [`Scene::pose_at`] gives per-mesh
//! transforms, lights and camera, [`Scene::posed`] a static world-space copy.
//!
//! Units: metres for lengths. Radiometric quantities are linear RGB:
//! - emissive materials: emitted radiance (W·sr⁻¹·m⁻²), `KHR_materials_emissive_strength` folded in;
//! - point and spot lights: radiant intensity (W·sr⁻¹), glTF's `intensity × color` taken as is;
//! - directional lights: irradiance on a surface facing the light (W·m⁻²);
//! - environment: radiance arriving from each direction.
//!
//! rtgi does no photometric conversion (no division by 683 lm/W): a glTF light of intensity 10 is
//! 10 W·sr⁻¹ here. This keeps analytic tests exact and scenes portable between techniques.

pub mod animation;
pub mod builtin;
pub mod gltf_export;
pub mod gltf_load;
pub mod spec;
pub mod subsurface;

pub use spec::SceneSpec;
pub use subsurface::Subsurface;

use glam::{IVec3, Mat3, Mat4, Quat, Vec2, Vec3, Vec4};

pub use animation::{Pose, SceneAnimation};

/// A renderable scene.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    pub name: String,
    pub meshes: Vec<Mesh>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Vec<Light>,
    pub environment: Environment,
    /// How the environment is turned in the world: radiance arriving from world direction d is the
    /// unturned environment's radiance from R⁻¹ d (for a map, u = 0 at R·(−Z)). Identity by default.
    /// Every technique sees the same turn: the GPU scene applies it where the environment is read and
    /// sampled, and SH techniques rotate their projection instead of projecting again.
    pub environment_rotation: Quat,
    pub camera: Camera,
    /// Features of the source file that rtgi read but does not render (e.g. a glTF extension that is
    /// optional). Loaders report them here instead of dropping them silently; the CLI prints them.
    pub warnings: Vec<String>,
    /// Keyframed motion of the meshes, lights, camera and sky sun; `None` for a static scene. The
    /// fields above hold the rest pose.
    pub animation: Option<SceneAnimation>,
}

/// A triangle mesh in world space. All attribute arrays have one entry per vertex.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    /// Unit shading normals.
    pub normals: Vec<Vec3>,
    /// xyz: unit tangent along +u, w: handedness (±1); bitangent = w · cross(normal, tangent), which
    /// points along −v (up the image, the direction of a glTF normal map's green channel).
    pub tangents: Vec<Vec4>,
    pub uvs: Vec<Vec2>,
    /// Three indices per triangle, counter-clockwise seen from the front.
    pub indices: Vec<u32>,
    /// Index into [`Scene::materials`].
    pub material: u32,
}

/// glTF metallic-roughness material. Colours are linear.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Linear RGBA; alpha is coverage (used by [`AlphaMode::Mask`]).
    pub base_color: Vec4,
    pub base_color_texture: Option<TextureRef>,
    pub metallic: f32,
    /// Perceptual roughness in [0, 1]; GGX α = roughness².
    pub roughness: f32,
    /// glTF packing: roughness in G, metallic in B (multiplied with the factors above).
    pub metallic_roughness_texture: Option<TextureRef>,
    /// Emitted radiance, linear RGB, emissive strength included.
    pub emissive: Vec3,
    pub emissive_texture: Option<TextureRef>,
    /// Tangent-space normal map (glTF convention: +Y up, OpenGL style).
    pub normal_texture: Option<TextureRef>,
    pub normal_scale: f32,
    /// Strength of the dielectric specular layer (KHR_materials_specular's `specularFactor`): 1 is the
    /// glTF default (4 % Fresnel reflectance at normal incidence), 0 makes a dielectric exactly
    /// Lambertian, as analytic and energy tests need.
    pub specular: f32,
    pub alpha_mode: AlphaMode,
    pub double_sided: bool,
    /// A translucent medium under the surface, which the `subsurface` technique shades with the dipole;
    /// every other technique (and the path tracer) sees the Lambertian `base_color`, which
    /// [`Material::translucent`] sets to the medium's total diffuse reflectance. glTF has no
    /// extension for it: rtgi's exporter writes it in the material's `extras` (`rtgi_subsurface`:
    /// `absorption`, `reduced_scattering` per metre, `eta`) and the loader reads it back.
    pub subsurface: Option<Subsurface>,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: String::new(),
            base_color: Vec4::ONE,
            base_color_texture: None,
            metallic: 0.0,
            roughness: 1.0,
            metallic_roughness_texture: None,
            emissive: Vec3::ZERO,
            emissive_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            specular: 1.0,
            alpha_mode: AlphaMode::Opaque,
            double_sided: false,
            subsurface: None,
        }
    }
}

impl Material {
    /// An exactly Lambertian material of the given linear albedo (no specular layer).
    pub fn diffuse(name: &str, albedo: Vec3) -> Self {
        Material { name: name.into(), base_color: albedo.extend(1.0), specular: 0.0, ..Default::default() }
    }

    /// A translucent dielectric over `medium`: a smooth-ish specular layer of the boundary's Fresnel
    /// reflectance at normal incidence ((η−1)/(η+1)², as a fraction of glTF's 4 %) and, for techniques
    /// without subsurface transport, a Lambertian albedo equal to the medium's total diffuse
    /// reflectance, so that far from light and shadow edges every technique sees the same brightness.
    pub fn translucent(name: &str, medium: Subsurface) -> Self {
        let f0 = ((medium.eta - 1.0) / (medium.eta + 1.0)).powi(2);
        Material {
            name: name.into(),
            base_color: medium.total_diffuse_reflectance().extend(1.0),
            roughness: 0.4,
            specular: f0 / 0.04,
            subsurface: Some(medium),
            ..Default::default()
        }
    }

    /// A black surface that emits `radiance`.
    pub fn emitter(name: &str, radiance: Vec3) -> Self {
        Material {
            name: name.into(),
            base_color: Vec4::new(0.0, 0.0, 0.0, 1.0),
            emissive: radiance,
            ..Default::default()
        }
    }

    pub fn is_emissive(&self) -> bool {
        self.emissive.max_element() > 0.0
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    Opaque,
    /// Fragments with alpha below the cutoff are discarded.
    Mask {
        cutoff: f32,
    },
    /// Read but rendered as opaque (rtgi has no transparency); loaders add a warning.
    Blend,
}

/// A reference from a material to a texture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TextureRef {
    /// Index into [`Scene::textures`].
    pub texture: u32,
    /// Which UV set; rtgi meshes carry one, so loaders reject other sets with a warning.
    pub tex_coord: u32,
}

impl TextureRef {
    pub fn new(texture: u32) -> Self {
        TextureRef { texture, tex_coord: 0 }
    }
}

/// An 8-bit RGBA image. `srgb` says how the shader must decode it (base colour and emissive are sRGB;
/// normal and metallic-roughness maps are linear).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// width × height × 4 bytes, rows top to bottom.
    pub rgba8: Vec<u8>,
    pub srgb: bool,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// Radiant intensity `intensity` (W/sr, linear RGB) in all directions.
    Point { position: Vec3, intensity: Vec3 },
    /// Like a point light inside a cone around `direction`: full intensity within `inner_angle`,
    /// smooth falloff to zero at `outer_angle` (half-angles in radians, glTF's smoothstep-free linear
    /// falloff in cos space as in KHR_lights_punctual).
    Spot { position: Vec3, direction: Vec3, intensity: Vec3, inner_angle: f32, outer_angle: f32 },
    /// Light travelling along `direction` (unit vector, from the light towards the scene) giving
    /// irradiance `irradiance` (W/m², linear RGB) on a surface facing it.
    Directional { direction: Vec3, irradiance: Vec3 },
}

impl Light {
    pub fn kind_name(&self) -> &'static str {
        match self {
            Light::Point { .. } => "point",
            Light::Spot { .. } => "spot",
            Light::Directional { .. } => "directional",
        }
    }
}

/// Light arriving from infinitely far away.
#[derive(Clone, Debug, PartialEq, Default)]
pub enum Environment {
    /// Black.
    #[default]
    None,
    /// The same radiance from every direction.
    Uniform(Vec3),
    /// A procedural clear sky (see `shaders/common/environment.wgsl` for the model): a zenith-to-horizon
    /// gradient and a sun disc. `sun_direction` points from the scene towards the sun.
    Sky { sun_direction: Vec3, sun_radiance: Vec3, sky_radiance: Vec3, ground_radiance: Vec3 },
    /// An equirectangular (latitude–longitude) radiance map, +Y up; u = 0 at −Z, growing towards +X.
    Map(EnvironmentMap),
}

#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentMap {
    pub path: String,
    pub width: u32,
    pub height: u32,
    /// width × height linear RGB radiance values, rows top (zenith) to bottom.
    pub rgb: Vec<f32>,
    pub intensity: f32,
}

impl EnvironmentMap {
    /// The unit direction at equirectangular coordinates (u, v) ∈ [0, 1]²: +Y up, u = 0 at −Z growing
    /// towards +X, v = 0 at the zenith (common/math.wgsl equirect_direction).
    pub fn direction(u: f32, v: f32) -> Vec3 {
        let (phi, theta) = (u * std::f32::consts::TAU, v * std::f32::consts::PI);
        Vec3::new(theta.sin() * phi.sin(), theta.cos(), -theta.sin() * phi.cos())
    }

    /// Reads an equirectangular radiance map (.hdr or .exr, linear) scaled by `intensity`.
    pub fn load(path: &std::path::Path, intensity: f32) -> Result<EnvironmentMap, crate::SceneError> {
        if !intensity.is_finite() || intensity < 0.0 {
            return Err(crate::SceneError::file(
                path,
                format!("environment intensity {intensity} must be ≥ 0"),
            ));
        }
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        if ext != "hdr" && ext != "exr" {
            return Err(crate::SceneError::file(
                path,
                "an environment map must be an equirectangular .hdr or .exr file",
            ));
        }
        let img = crate::image::HdrImage::read(path).map_err(|e| {
            // The image error already names the file; keep one mention of it.
            let text = e.to_string();
            let prefix = format!("{}: ", path.display());
            crate::SceneError::file(path, text.strip_prefix(&prefix).unwrap_or(&text).to_string())
        })?;
        if img.width != 2 * img.height {
            return Err(crate::SceneError::file(
                path,
                format!("{}x{} is not an equirectangular (2:1) map", img.width, img.height),
            ));
        }
        Ok(EnvironmentMap {
            path: path.display().to_string(),
            width: img.width,
            height: img.height,
            rgb: img.rgb,
            intensity,
        })
    }
}

/// A perspective camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Vertical field of view in radians.
    pub yfov: f32,
    pub znear: f32,
    pub zfar: f32,
}

impl Default for Camera {
    fn default() -> Self {
        Camera {
            position: Vec3::new(0.0, 1.0, 3.0),
            target: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Y,
            yfov: 45f32.to_radians(),
            znear: 0.01,
            zfar: 1000.0,
        }
    }
}

impl Camera {
    pub fn view(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.position, self.target, self.up)
    }

    /// Right-handed perspective with depth in [0, 1] and NDC y up (the wgpu convention, glam's `directx`).
    pub fn projection(&self, aspect: f32) -> Mat4 {
        glam::camera::rh::proj::directx::perspective(self.yfov, aspect, self.znear, self.zfar)
    }

    pub fn view_projection(&self, aspect: f32) -> Mat4 {
        self.projection(aspect) * self.view()
    }

    /// Parses a placement `X,Y,Z,TX,TY,TZ,FOV`: position, target and vertical field of view in degrees
    /// (what [`Self::placement`] writes); up and clip distances come from `base`.
    pub fn parse_placement(text: &str, base: &Camera) -> Result<Camera, String> {
        let values = text
            .split(',')
            .map(|v| v.trim().parse::<f32>().ok().filter(|v| v.is_finite()))
            .collect::<Option<Vec<f32>>>()
            .filter(|v| v.len() == 7)
            .ok_or_else(|| {
                format!(
                    "'{text}': expected seven finite numbers X,Y,Z,TX,TY,TZ,FOV (position, target, degrees)"
                )
            })?;
        let position = Vec3::new(values[0], values[1], values[2]);
        let target = Vec3::new(values[3], values[4], values[5]);
        if (target - position).length() <= 1e-6 * position.length().max(1.0) {
            return Err(format!("'{text}': the target is the position; the camera needs a direction"));
        }
        if (target - position).normalize().cross(base.up.normalize()).length() < 1e-4 {
            return Err(format!("'{text}': the camera looks along its up axis ({})", base.up));
        }
        if !(values[6] > 0.0 && values[6] < 180.0) {
            return Err(format!("'{text}': field of view {} degrees is outside (0, 180)", values[6]));
        }
        Ok(Camera { position, target, yfov: values[6].to_radians(), ..*base })
    }

    /// This camera as `X,Y,Z,TX,TY,TZ,FOV` for [`Self::parse_placement`] (shortest round-trip decimals).
    pub fn placement(&self) -> String {
        let p = self.position;
        let t = self.target;
        format!("{},{},{},{},{},{},{}", p.x, p.y, p.z, t.x, t.y, t.z, self.yfov.to_degrees())
    }
}

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x
    }

    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    /// The sphere through the box's corners: radius half the diagonal, at least 1e-3 (a point or a flat
    /// box still frames a view and a light's disc).
    pub fn bounding_radius(&self) -> f32 {
        (self.extent().length() * 0.5).max(1e-3)
    }

    /// A cube of `cells`³ cubic cells centred on the box, holding it with a cell of margin on every
    /// side (the volumes of LPV's coarsest cascade and of VXGI): its minimum corner and cell edge.
    pub fn enclosing_cube(&self, cells: u32) -> (Vec3, f32) {
        let n = cells as f32;
        let cell = self.extent().max_element().max(1e-3) / (n - 2.0).max(1.0);
        (self.center() - Vec3::splat(0.5 * n * cell), cell)
    }

    /// `count` nested cubes of `cells`³ cells, finest first (LPV's cascades, VXGI's clipmap levels): the
    /// coarsest is the `enclosing_cube`, each finer one halves the cell and is centred on `focus`, its
    /// corner snapped to whole multiples of `snap_cells` of its cells from the coarsest cube's corner, so
    /// that a focus moving by less than that leaves it where it was, and every cube's cells (and the
    /// coarser cells `snap_cells` of them make up, mips) lie inside cells of the next coarser cube.
    pub fn nested_cubes(&self, focus: Vec3, cells: u32, count: usize, snap_cells: u32) -> Vec<NestedCube> {
        let (origin, coarsest) = self.enclosing_cube(cells);
        (0..count)
            .map(|k| {
                let cell = coarsest / (1u32 << (count - 1 - k)) as f32;
                let offset = if k + 1 == count {
                    IVec3::ZERO
                } else {
                    let snap = cell * snap_cells as f32;
                    let half = (cells / 2 / snap_cells) as i32;
                    (((focus - origin) / snap).floor().as_ivec3() - IVec3::splat(half)) * snap_cells as i32
                };
                NestedCube { corner: origin + offset.as_vec3() * cell, cell, offset }
            })
            .collect()
    }
}

/// One cube of [`Aabb::nested_cubes`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NestedCube {
    /// Minimum corner.
    pub corner: Vec3,
    /// Cell edge.
    pub cell: f32,
    /// The corner in whole cells of this cube from the coarsest cube's corner (zero for the coarsest):
    /// cell c of the cube is cell `offset + c` of a lattice that stays where it is while the cube moves.
    pub offset: IVec3,
}

impl Scene {
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.indices.len() / 3).sum()
    }

    pub fn vertex_count(&self) -> usize {
        self.meshes.iter().map(|m| m.positions.len()).sum()
    }

    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for m in &self.meshes {
            for p in &m.positions {
                b.grow(*p);
            }
        }
        b
    }

    /// Checks the internal consistency that GPU upload relies on. Loaders and generators call it; a
    /// failure is a bug in them (or a malformed file) and is reported, never uploaded.
    pub fn validate(&self) -> Result<(), String> {
        for (i, m) in self.meshes.iter().enumerate() {
            let n = m.positions.len();
            if m.normals.len() != n || m.tangents.len() != n || m.uvs.len() != n {
                return Err(format!(
                    "mesh {i} '{}': attribute counts differ (positions {n}, normals {}, tangents {}, uvs {})",
                    m.name,
                    m.normals.len(),
                    m.tangents.len(),
                    m.uvs.len()
                ));
            }
            if m.indices.len() % 3 != 0 {
                return Err(format!(
                    "mesh {i} '{}': index count {} is not a multiple of 3",
                    m.name,
                    m.indices.len()
                ));
            }
            if let Some(bad) = m.indices.iter().find(|&&ix| ix as usize >= n) {
                return Err(format!("mesh {i} '{}': index {bad} out of range ({n} vertices)", m.name));
            }
            if m.material as usize >= self.materials.len() {
                return Err(format!(
                    "mesh {i} '{}': material {} out of range ({} materials)",
                    m.name,
                    m.material,
                    self.materials.len()
                ));
            }
            if m.positions.iter().any(|p| !p.is_finite()) {
                return Err(format!("mesh {i} '{}': non-finite vertex position", m.name));
            }
        }
        for (i, mat) in self.materials.iter().enumerate() {
            for t in [
                mat.base_color_texture,
                mat.metallic_roughness_texture,
                mat.emissive_texture,
                mat.normal_texture,
            ]
            .into_iter()
            .flatten()
            {
                if t.texture as usize >= self.textures.len() {
                    return Err(format!("material {i} '{}': texture {} out of range", mat.name, t.texture));
                }
            }
        }
        for (i, t) in self.textures.iter().enumerate() {
            if t.rgba8.len() != (t.width as usize) * (t.height as usize) * 4 || t.width == 0 || t.height == 0
            {
                return Err(format!(
                    "texture {i} '{}': {}×{} does not match its data",
                    t.name, t.width, t.height
                ));
            }
        }
        if let Some(anim) = &self.animation {
            anim.validate(self.meshes.len(), self.lights.len()).map_err(|e| format!("animation: {e}"))?;
        }
        Ok(())
    }
}

/// Applies the affine transform `m` to vertex data in place: positions by `m`, normals by its inverse
/// transpose (computed as the cofactor matrix times sign(det), which stays finite for degenerate,
/// zero-scale transforms; not renormalised), tangents by its linear part with their handedness
/// flipped when `m` mirrors. A mirroring transform also turns counter-clockwise triangles clockwise,
/// so their winding is swapped back.
pub(crate) fn transform_vertices(
    m: Mat4,
    positions: &mut [Vec3],
    normals: &mut [Vec3],
    tangents: &mut [Vec4],
    indices: &mut [u32],
) {
    if m == Mat4::IDENTITY {
        return;
    }
    let m3 = Mat3::from_mat4(m);
    let det = m3.determinant();
    for p in positions {
        *p = m.transform_point3(*p);
    }
    let cofactor =
        Mat3::from_cols(m3.y_axis.cross(m3.z_axis), m3.z_axis.cross(m3.x_axis), m3.x_axis.cross(m3.y_axis));
    let normal_matrix = if det < 0.0 { -cofactor } else { cofactor };
    for n in normals {
        *n = normal_matrix * *n;
    }
    for t in tangents {
        let w = if det < 0.0 { -t.w } else { t.w };
        *t = (m3 * t.truncate()).extend(w);
    }
    if det < 0.0 {
        for tri in indices.chunks_exact_mut(3) {
            tri.swap(1, 2);
        }
    }
}

impl Mesh {
    /// Builds a mesh from positions, normals, uvs and indices, computing tangents from the UV layout
    /// (per-triangle tangents accumulated per vertex, then Gram–Schmidt orthogonalised).
    pub fn with_generated_tangents(
        name: &str,
        positions: Vec<Vec3>,
        normals: Vec<Vec3>,
        uvs: Vec<Vec2>,
        indices: Vec<u32>,
        material: u32,
    ) -> Mesh {
        let tangents = generate_tangents(&positions, &normals, &uvs, &indices);
        Mesh { name: name.into(), positions, normals, tangents, uvs, indices, material }
    }
}

/// Per-vertex tangents from UVs. Degenerate UV layouts fall back to any vector perpendicular to the
/// normal, so the result is always a unit tangent.
pub fn generate_tangents(positions: &[Vec3], normals: &[Vec3], uvs: &[Vec2], indices: &[u32]) -> Vec<Vec4> {
    let n = positions.len();
    let mut tan = vec![Vec3::ZERO; n];
    let mut bit = vec![Vec3::ZERO; n];
    for tri in indices.chunks_exact(3) {
        let [a, b, c] = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
        let (e1, e2) = (positions[b] - positions[a], positions[c] - positions[a]);
        let (d1, d2) = (uvs[b] - uvs[a], uvs[c] - uvs[a]);
        let det = d1.x * d2.y - d2.x * d1.y;
        if det.abs() < 1e-20 {
            continue;
        }
        let r = 1.0 / det;
        let t = (e1 * d2.y - e2 * d1.y) * r;
        let bt = (e2 * d1.x - e1 * d2.x) * r;
        for &v in &[a, b, c] {
            tan[v] += t;
            bit[v] += bt;
        }
    }
    (0..n)
        .map(|i| {
            let nrm = normals[i];
            let mut t = tan[i] - nrm * nrm.dot(tan[i]);
            if t.length_squared() < 1e-20 {
                t = nrm.any_orthonormal_vector();
            }
            let t = t.normalize();
            // glTF's v axis points down the image while a normal map's green channel points up it, so
            // the bitangent must follow −∂P/∂v (as the Khronos sample viewer and MikkTSpace on glTF do).
            let w = if nrm.cross(t).dot(bit[i]) < 0.0 { 1.0 } else { -1.0 };
            t.extend(w)
        })
        .collect()
}

#[cfg(test)]
mod camera_tests {
    use super::*;

    #[test]
    fn placement_round_trips_and_rejects_bad_input() {
        let base = Camera { znear: 0.05, zfar: 40.0, ..Camera::default() };
        let camera =
            Camera { position: Vec3::new(0.1, 1.25, -3.7), target: Vec3::new(2.0, 0.3, 1.0 / 3.0), ..base };
        let parsed = Camera::parse_placement(&camera.placement(), &base).expect("round trip");
        assert_eq!(parsed.position, camera.position);
        assert_eq!(parsed.target, camera.target);
        assert!(
            (parsed.yfov - camera.yfov).abs() <= 1e-6 * camera.yfov,
            "{} vs {}",
            parsed.yfov,
            camera.yfov
        );
        assert_eq!((parsed.znear, parsed.zfar, parsed.up), (0.05, 40.0, Vec3::Y));
        for bad in [
            "1,2,3",
            "1,2,3,4,5,6,x",
            "0,0,0,0,0,0,45",
            "0,0,0,0,5,0,45",
            "0,0,0,0,0,-1,180",
            "nan,0,0,1,0,0,45",
        ] {
            assert!(Camera::parse_placement(bad, &base).is_err(), "{bad} accepted");
        }
    }
}
