//! The image-test harness: a technique's render against the cached path-traced reference.
//!
//! A test declares the scene, technique, parameters, size and thresholds; [`ImageTest::run`] renders,
//! fetches (or renders once and caches) the reference, compares, and on failure writes the test image,
//! the reference and the FLIP error map to `<out_dir>/<name>/` so they can be looked at.
//!
//! [`animated_gltf`] writes a small hand-made animated glTF file for animation tests.

mod animated_gltf;

pub use animated_gltf::animated_gltf;

use std::path::{Path, PathBuf};

use crate::gpu::GpuContext;
use crate::image::{HdrImage, ToneMap};
use crate::metrics::{self, Metrics};
use crate::reference::{ReferenceRequest, reference};
use crate::render::{RenderSettings, render};

/// One image comparison.
#[derive(Clone, Debug)]
pub struct ImageTest<'a> {
    pub name: &'a str,
    /// A built-in scene name.
    pub scene: &'a str,
    pub scene_settings: &'a [(&'a str, &'a str)],
    pub technique: &'a str,
    pub settings: &'a [(&'a str, &'a str)],
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    /// Samples per pixel of the reference and its `path` parameters (e.g. `max_bounces=1`). Its seed is
    /// [`crate::reference::REFERENCE_SEED`] unless set here, so its noise is independent of the
    /// technique's own random streams (seed 0 by default).
    pub reference_spp: u32,
    pub reference_settings: &'a [(&'a str, &'a str)],
    /// Largest acceptable mean FLIP and relative MSE (derive them from measurement, with the measured
    /// value in a comment next to them).
    pub max_flip: f64,
    pub max_rel_mse: f64,
}

/// What a run measured, and where the images went when it failed.
#[derive(Debug)]
pub struct ImageTestResult {
    pub metrics: Metrics,
    pub passed: bool,
    pub artefacts: Option<PathBuf>,
}

fn owned(pairs: &[(&str, &str)]) -> Vec<(String, String)> {
    pairs.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect()
}

impl ImageTest<'_> {
    /// Renders and compares; `Err` only for errors of the render itself.
    pub fn run(&self, ctx: &GpuContext, out_dir: &Path) -> Result<ImageTestResult, String> {
        let scene = crate::scene::builtin::build(self.scene, &owned(self.scene_settings))
            .map_err(|e| e.to_string())?;
        let settings = RenderSettings {
            technique: self.technique.into(),
            technique_settings: owned(self.settings),
            width: self.width,
            height: self.height,
            frames: self.frames,
        };
        let test = render(ctx, &scene, &settings, &mut |_, _| {}).map_err(|e| e.to_string())?.image;
        let request = ReferenceRequest {
            width: self.width,
            height: self.height,
            spp: self.reference_spp,
            settings: owned(self.reference_settings),
        };
        let reference = reference(ctx, &scene, &request, &mut |_, _| {}).map_err(|e| e.to_string())?;
        let metrics = metrics::compare(&reference.image, &test).map_err(|e| e.to_string())?;
        let passed = metrics.flip <= self.max_flip && metrics.rel_mse <= self.max_rel_mse;
        let artefacts = if passed {
            None
        } else {
            let dir = out_dir.join(self.name);
            self.write_artefacts(&dir, &reference.image, &test)
                .map_err(|e| format!("{}: {e}", dir.display()))?;
            Some(dir)
        };
        Ok(ImageTestResult { metrics, passed, artefacts })
    }

    fn write_artefacts(&self, dir: &Path, reference: &HdrImage, test: &HdrImage) -> Result<(), String> {
        std::fs::create_dir_all(dir).map_err(|e| e.to_string())?;
        let tone = ToneMap { exposure_ev: 0.0 };
        for (name, img) in [("reference", reference), ("test", test)] {
            img.write_exr(dir.join(format!("{name}.exr"))).map_err(|e| e.to_string())?;
            img.write_png(dir.join(format!("{name}.png")), &tone).map_err(|e| e.to_string())?;
        }
        let (map, _) = metrics::flip_map(reference, test).map_err(|e| e.to_string())?;
        crate::image::write_rgb8_png(
            dir.join("flip.png"),
            reference.width,
            reference.height,
            &metrics::error_map_rgb8(&map, reference.width, reference.height),
        )
        .map_err(|e| e.to_string())
    }

    /// Runs and panics with the measured figures and the artefact folder when the thresholds are
    /// exceeded (for `#[test]`s).
    pub fn assert_passes(&self, ctx: &GpuContext, out_dir: &Path) -> Metrics {
        let r = self.run(ctx, out_dir).unwrap_or_else(|e| panic!("image test {}: {e}", self.name));
        eprintln!(
            "image test {}: flip {:.4} (max {}), rel_mse {:.5} (max {}), rmse {:.5}",
            self.name, r.metrics.flip, self.max_flip, r.metrics.rel_mse, self.max_rel_mse, r.metrics.rmse
        );
        assert!(
            r.passed,
            "image test {} failed: flip {:.4} > {} or rel_mse {:.5} > {}; images in {}",
            self.name,
            r.metrics.flip,
            self.max_flip,
            r.metrics.rel_mse,
            self.max_rel_mse,
            r.artefacts.map(|p| p.display().to_string()).unwrap_or_default()
        );
        r.metrics
    }
}
