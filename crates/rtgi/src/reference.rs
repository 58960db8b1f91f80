//! Cached path-traced references.
//!
//! A reference is keyed by everything that affects its pixels: the scene's content (geometry,
//! materials, textures, lights, environment, camera), the image size, the sample count, the path
//! tracer's parameters and the renderer version (the crate version plus a hash of the composed path
//! tracer shader, so any change to the shared WGSL library invalidates old references). Tests and
//! benchmarks ask for a reference and get the cached EXR when one exists.

use std::path::{Path, PathBuf};

use crate::gpu::GpuContext;
use crate::image::HdrImage;
use crate::render::{ProgressFn, RenderError, RenderSettings, render};
use crate::scene::{Environment, Light, Scene};

/// 64-bit FNV-1a: a stable hash (unlike `DefaultHasher`, which may change between Rust releases).
#[derive(Clone, Copy, Debug)]
pub struct StableHasher(u64);

impl Default for StableHasher {
    fn default() -> Self {
        StableHasher(0xcbf2_9ce4_8422_2325)
    }
}

impl StableHasher {
    pub fn bytes(&mut self, data: &[u8]) -> &mut Self {
        for b in data {
            self.0 ^= u64::from(*b);
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
        self
    }

    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.bytes(&v.to_le_bytes())
    }

    pub fn f32s(&mut self, v: &[f32]) -> &mut Self {
        for x in v {
            self.u32(x.to_bits());
        }
        self
    }

    pub fn str(&mut self, s: &str) -> &mut Self {
        self.u32(s.len() as u32).bytes(s.as_bytes())
    }

    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// A hash of everything in `scene` that can change a rendered pixel (names and warnings excluded).
pub fn scene_content_hash(scene: &Scene) -> u64 {
    let mut h = StableHasher::default();
    for m in &scene.meshes {
        h.u32(m.material).u32(m.positions.len() as u32);
        for p in &m.positions {
            h.f32s(&p.to_array());
        }
        for n in &m.normals {
            h.f32s(&n.to_array());
        }
        for t in &m.tangents {
            h.f32s(&t.to_array());
        }
        for uv in &m.uvs {
            h.f32s(&uv.to_array());
        }
        for i in &m.indices {
            h.u32(*i);
        }
    }
    for m in &scene.materials {
        h.f32s(&m.base_color.to_array()).f32s(&[m.metallic, m.roughness, m.normal_scale, m.specular]);
        h.f32s(&m.emissive.to_array()).u32(u32::from(m.double_sided));
        for t in [m.base_color_texture, m.metallic_roughness_texture, m.emissive_texture, m.normal_texture] {
            h.u32(t.map_or(u32::MAX, |t| t.texture));
        }
        match m.alpha_mode {
            crate::scene::AlphaMode::Opaque => h.u32(0),
            crate::scene::AlphaMode::Mask { cutoff } => h.u32(1).f32s(&[cutoff]),
            crate::scene::AlphaMode::Blend => h.u32(2),
        };
    }
    for t in &scene.textures {
        h.u32(t.width).u32(t.height).u32(u32::from(t.srgb)).bytes(&t.rgba8);
    }
    for l in &scene.lights {
        match *l {
            Light::Point { position, intensity } => {
                h.u32(0).f32s(&position.to_array()).f32s(&intensity.to_array())
            }
            Light::Spot { position, direction, intensity, inner_angle, outer_angle } => h
                .u32(1)
                .f32s(&position.to_array())
                .f32s(&direction.to_array())
                .f32s(&intensity.to_array())
                .f32s(&[inner_angle, outer_angle]),
            Light::Directional { direction, irradiance } => {
                h.u32(2).f32s(&direction.to_array()).f32s(&irradiance.to_array())
            }
        };
    }
    match &scene.environment {
        Environment::None => h.u32(0),
        Environment::Uniform(c) => h.u32(1).f32s(&c.to_array()),
        Environment::Sky { sun_direction, sun_radiance, sky_radiance, ground_radiance } => h
            .u32(2)
            .f32s(&sun_direction.to_array())
            .f32s(&sun_radiance.to_array())
            .f32s(&sky_radiance.to_array())
            .f32s(&ground_radiance.to_array()),
        Environment::Map(m) => h.u32(3).u32(m.width).u32(m.height).f32s(&[m.intensity]).f32s(&m.rgb),
    };
    let c = &scene.camera;
    h.f32s(&c.position.to_array())
        .f32s(&c.target.to_array())
        .f32s(&c.up.to_array())
        .f32s(&[c.yfov, c.znear, c.zfar]);
    h.finish()
}

/// The renderer version that references depend on: the crate version and the composed path tracer.
pub fn renderer_version() -> String {
    let shader = crate::techniques::path::composed_source_for_hash();
    let mut h = StableHasher::default();
    h.str(&shader);
    format!("{}-{:016x}", env!("CARGO_PKG_VERSION"), h.finish())
}

/// Where references are cached: `$RTGI_CACHE_DIR`, else `$XDG_CACHE_HOME/rtgi/references`, else
/// `~/.cache/rtgi/references`, else `./.rtgi-cache`.
pub fn cache_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("RTGI_CACHE_DIR") {
        return PathBuf::from(d);
    }
    if let Some(d) = std::env::var_os("XDG_CACHE_HOME") {
        return PathBuf::from(d).join("rtgi").join("references");
    }
    if let Some(home) = std::env::var_os("HOME") {
        return PathBuf::from(home).join(".cache").join("rtgi").join("references");
    }
    PathBuf::from(".rtgi-cache")
}

/// Samples per pixel traced in one frame: the largest power of two ≤ 64 that divides `spp`, so that a
/// reference of N samples is exactly N samples.
pub fn samples_per_frame(spp: u32) -> u32 {
    let mut per = 64;
    while per > 1 && !spp.is_multiple_of(per) {
        per /= 2;
    }
    per
}

/// A request for a reference image.
#[derive(Clone, Debug)]
pub struct ReferenceRequest {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// Further `path` parameters (e.g. `max_bounces=1`); `spp` is set from the field above.
    pub settings: Vec<(String, String)>,
}

/// A reference image and where it lives.
pub struct Reference {
    pub image: HdrImage,
    pub path: PathBuf,
    /// True when it came from the cache.
    pub cached: bool,
    pub key: String,
}

/// The cache key of `request` for `scene`.
pub fn cache_key(scene: &Scene, request: &ReferenceRequest) -> Result<String, RenderError> {
    let mut settings = request.settings.clone();
    settings.retain(|(k, _)| k != "spp");
    let (_, params) = crate::techniques::resolve("path", &settings).map_err(RenderError::InvalidSettings)?;
    let mut h = StableHasher::default();
    h.str(&renderer_version()).bytes(&scene_content_hash(scene).to_le_bytes());
    h.u32(request.width).u32(request.height).u32(request.spp);
    for (k, v) in params.to_map() {
        if k != "spp" {
            h.str(&k).str(&v);
        }
    }
    Ok(format!("{:016x}", h.finish()))
}

/// Returns the cached reference for (`scene`, `request`) or renders and caches it.
pub fn reference(
    ctx: &GpuContext,
    scene: &Scene,
    request: &ReferenceRequest,
    progress: &mut ProgressFn<'_>,
) -> Result<Reference, RenderError> {
    if request.spp == 0 {
        return Err(RenderError::InvalidSettings("a reference needs at least 1 sample per pixel".into()));
    }
    let key = cache_key(scene, request)?;
    let dir = cache_dir();
    let path = dir.join(format!(
        "{}-{}x{}-{}spp-{key}.exr",
        sanitize(&scene.name),
        request.width,
        request.height,
        request.spp
    ));
    if let Ok(image) = HdrImage::read(&path)
        && image.width == request.width
        && image.height == request.height
    {
        return Ok(Reference { image, path, cached: true, key });
    }
    let per_frame = samples_per_frame(request.spp);
    let mut technique_settings: Vec<(String, String)> =
        request.settings.iter().filter(|(k, _)| k != "spp").cloned().collect();
    technique_settings.push(("spp".into(), per_frame.to_string()));
    let settings = RenderSettings {
        technique: "path".into(),
        technique_settings,
        width: request.width,
        height: request.height,
        frames: request.spp / per_frame,
    };
    let out = render(ctx, scene, &settings, progress)?;
    std::fs::create_dir_all(&dir).map_err(|e| {
        RenderError::InvalidSettings(format!("{}: cannot create the cache: {e}", dir.display()))
    })?;
    // Write to a temporary name first so a concurrent reader never sees a half-written file.
    let tmp = path.with_extension(format!("tmp{}.exr", std::process::id()));
    out.image.write_exr(&tmp).map_err(|e| RenderError::InvalidSettings(e.to_string()))?;
    std::fs::rename(&tmp, &path)
        .map_err(|e| RenderError::InvalidSettings(format!("{}: cannot store: {e}", path.display())))?;
    Ok(Reference { image: out.image, path, cached: false, key })
}

fn sanitize(name: &str) -> String {
    let s: String =
        name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect();
    if s.is_empty() { "scene".into() } else { s }
}

/// Copies `reference` to `out` (any extension `HdrImage::write` supports).
pub fn export(reference: &Reference, out: &Path) -> Result<(), RenderError> {
    reference
        .image
        .write(out, &crate::image::ToneMap { exposure_ev: 0.0 })
        .map_err(|e| RenderError::InvalidSettings(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_change_with_what_affects_pixels() {
        let a = crate::scene::builtin::build("cornell", &[]).unwrap();
        let req = ReferenceRequest { width: 64, height: 64, spp: 256, settings: vec![] };
        let k = cache_key(&a, &req).unwrap();
        assert_eq!(k, cache_key(&a, &req).unwrap(), "stable");
        let mut b = a.clone();
        b.name = "renamed".into();
        assert_eq!(k, cache_key(&b, &req).unwrap(), "names do not matter");
        b.materials[0].base_color.x += 0.01;
        assert_ne!(k, cache_key(&b, &req).unwrap(), "materials matter");
        let mut c = a.clone();
        c.camera.yfov *= 1.01;
        assert_ne!(k, cache_key(&c, &req).unwrap(), "camera matters");
        for other in [
            ReferenceRequest { spp: 512, ..req.clone() },
            ReferenceRequest { width: 32, ..req.clone() },
            ReferenceRequest { settings: vec![("max_bounces".into(), "1".into())], ..req.clone() },
        ] {
            assert_ne!(k, cache_key(&a, &other).unwrap());
        }
        // Setting a parameter to its default is the same reference.
        let same = ReferenceRequest { settings: vec![("max_bounces".into(), "-1".into())], ..req.clone() };
        assert_eq!(k, cache_key(&a, &same).unwrap());
        assert!(
            cache_key(&a, &ReferenceRequest { settings: vec![("bogus".into(), "1".into())], ..req }).is_err()
        );
    }

    #[test]
    fn samples_per_frame_divides_the_count() {
        for spp in [1, 3, 16, 100, 1000, 16384, 16385] {
            let per = samples_per_frame(spp);
            assert!(spp.is_multiple_of(per) && per <= 64, "{spp}: {per}");
        }
        assert_eq!(samples_per_frame(16384), 64);
    }
}
