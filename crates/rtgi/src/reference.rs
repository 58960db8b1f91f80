//! Cached path-traced references.
//!
//! A reference is keyed by everything that affects its pixels: the scene's content (geometry,
//! materials, textures, lights, environment, camera), the image size, the sample count, the path
//! tracer's parameters and the renderer version (the crate version plus a hash of the library sources
//! that shape a reference — path tracer, BVH build, sampling tables, shared WGSL, renderer; see
//! [`sources`] — so a change to any of them renders references anew). Tests and
//! benchmarks ask for a reference and get the cached EXR when one exists.

pub mod sources;

use std::path::{Path, PathBuf};

use crate::gpu::GpuContext;
use crate::image::HdrImage;
use crate::render::{ProgressFn, RenderError, RenderSettings, render};
use crate::scene::{Environment, Light, Scene};

pub use crate::stable_hash::StableHasher;

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
    h.f32s(&scene.environment_rotation.to_array());
    let c = &scene.camera;
    h.f32s(&c.position.to_array())
        .f32s(&c.target.to_array())
        .f32s(&c.up.to_array())
        .f32s(&[c.yfov, c.znear, c.zfar]);
    h.finish()
}

/// The renderer version that references depend on: the crate version and a hash of every library
/// source that can change a reference's pixels (computed by `build.rs`; which files, and why, in
/// [`sources::is_reference_source`]).
pub fn renderer_version() -> String {
    format!("{}-{}", env!("CARGO_PKG_VERSION"), env!("RTGI_REFERENCE_SOURCES_HASH"))
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

/// The `path` seed of a reference unless its request sets one ("REFS" in ASCII). Techniques default to
/// seed 0, and `path` draws its random numbers from (pixel, frame, sample, seed) alone: with the same
/// seed, a 16-spp `path` image under test would be the first 16 samples of its own reference, and the
/// errors of other techniques' default streams would be correlated with the reference's noise too.
pub const REFERENCE_SEED: u32 = 0x5245_4653;

/// The request's `path` parameters without `spp` (set per frame by [`reference`]), with the seed
/// defaulting to [`REFERENCE_SEED`].
fn path_settings(request: &ReferenceRequest) -> Vec<(String, String)> {
    let mut settings: Vec<(String, String)> =
        request.settings.iter().filter(|(k, _)| k != "spp").cloned().collect();
    if !settings.iter().any(|(k, _)| k == "seed") {
        settings.insert(0, ("seed".into(), REFERENCE_SEED.to_string()));
    }
    settings
}

/// The cache key of `request` for `scene`.
pub fn cache_key(scene: &Scene, request: &ReferenceRequest) -> Result<String, RenderError> {
    let settings = path_settings(request);
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
    let mut technique_settings = path_settings(request);
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
            cache_key(&a, &ReferenceRequest { settings: vec![("bogus".into(), "1".into())], ..req.clone() })
                .is_err()
        );
        // The seed defaults to REFERENCE_SEED, not to `path`'s own default.
        let seed = |s: String| ReferenceRequest { settings: vec![("seed".into(), s)], ..req.clone() };
        assert_eq!(k, cache_key(&a, &seed(REFERENCE_SEED.to_string())).unwrap());
        for technique in crate::techniques::registry() {
            if let Some(spec) = technique.params.iter().find(|p| p.name == "seed") {
                assert_ne!(spec.default, REFERENCE_SEED.to_string(), "{}'s default seed", technique.name);
            }
        }
        assert_ne!(k, cache_key(&a, &seed("0".into())).unwrap());
    }

    /// The renderer version hashes the sources that shape a reference, with the same rule and hash at
    /// build time (`build.rs`) as here, and one changed byte in any of them gives another key.
    #[test]
    fn renderer_version_covers_the_sources_that_shape_a_reference() {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
        let files = sources::collect_reference_sources(&src, &mut Vec::new()).expect("read src");
        let hash = sources::hash_sources(&files);
        assert_eq!(
            format!("{hash:016x}"),
            env!("RTGI_REFERENCE_SOURCES_HASH"),
            "build.rs hashed other sources than the ones under {} now",
            src.display()
        );
        assert!(renderer_version().ends_with(&format!("{hash:016x}")));
        let names: Vec<&str> = files.iter().map(|(p, _)| p.as_str()).collect();
        let covered = [
            "gpu/bvh/build.rs",          // the BVH build
            "gpu/bvh/instances.rs",      // the two-level BVH
            "gpu/scene.rs",              // scene upload, emitter and environment sampling tables
            "techniques/path/mod.rs",    // the path tracer's host code
            "techniques/path/path.wgsl", // and its shader
            "techniques/compute.rs",     // its pipeline and dispatch helpers
            "shaders/common/light_sampling.wgsl",
            "shaders/mod.rs", // WGSL composition
            "frame/mod.rs",   // camera uniforms
            "renderer.rs",
            "render.rs",
            "reference.rs",
            "reference/sources.rs",
            "image.rs", // the EXR the reference is stored as
        ];
        for name in covered {
            assert!(names.contains(&name), "{name} is not hashed into reference keys: {names:?}");
        }
        let not_covered = [
            "techniques/igi/mod.rs",
            "techniques/rsm/gather.wgsl",
            "gpu/bvh/tests.rs",
            "gpu/bvh/test_geometry.rs",
            "scene/gltf_load/animation_tests.rs",
            "testing.rs",
            "testing/animated_gltf.rs",
            "metrics/mod.rs",
            "bench/mod.rs",
            "bench/report.rs",
            "scene/builtin/cornell.rs",
        ];
        for name in not_covered {
            assert!(!names.contains(&name), "{name} should not invalidate references");
        }
        // One byte of any file, its name, or one more file: another hash.
        for name in ["gpu/bvh/build.rs", "gpu/scene.rs", "techniques/path/mod.rs", "shaders/common/bvh.wgsl"]
        {
            let i = names.iter().position(|n| *n == name).expect("listed");
            let mut edited = files.clone();
            let last = edited[i].1.len() - 1;
            edited[i].1[last] ^= 1;
            assert_ne!(sources::hash_sources(&edited), hash, "{name} edited");
        }
        let mut renamed = files.clone();
        renamed[0].0.push('x');
        assert_ne!(sources::hash_sources(&renamed), hash, "renamed");
        let mut added = files.clone();
        added.push(("gpu/new.rs".into(), Vec::new()));
        assert_ne!(sources::hash_sources(&added), hash, "added");
        // The order files are listed in does not matter (directory order differs between systems).
        let mut reversed = files.clone();
        reversed.reverse();
        assert_eq!(sources::hash_sources(&reversed), hash);
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
