//! Bench suites: a matrix of scenes × techniques × parameter sweeps × sizes declared in TOML, expanded
//! into numbered cells. The format is documented in `docs/bench.md`; `benches/*.toml` are examples.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::params::parse_size;
use crate::reference::StableHasher;
use crate::scene::SceneSpec;

/// The suite file as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SuiteFile {
    name: String,
    #[serde(default)]
    description: String,
    sizes: Vec<String>,
    #[serde(default = "default_frames")]
    frames: u32,
    error_frames: Option<u32>,
    /// `frame` (default) or `passes`, as `rtgi render --timing`.
    timing: Option<String>,
    reference: ReferenceFile,
    scenes: Vec<SceneFile>,
    techniques: Vec<TechniqueFile>,
}

fn default_frames() -> u32 {
    8
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ReferenceFile {
    spp: u32,
    #[serde(default)]
    set: BTreeMap<String, toml::Value>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    scene: String,
    spp: Option<u32>,
    /// The scene's reference `path` parameters, instead of `[reference]`'s `set`.
    set: Option<BTreeMap<String, toml::Value>>,
    /// The scene's sizes, instead of the suite's.
    sizes: Option<Vec<String>>,
    #[serde(default)]
    times: Vec<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TechniqueFile {
    technique: String,
    label: Option<String>,
    #[serde(default)]
    set: BTreeMap<String, toml::Value>,
    #[serde(default)]
    sweep: BTreeMap<String, Vec<toml::Value>>,
    scenes: Option<Vec<String>>,
    warmup: Option<u32>,
}

/// A parsed, validated suite.
#[derive(Clone, Debug)]
pub struct Suite {
    pub name: String,
    pub description: String,
    pub path: PathBuf,
    /// Hash of the suite file's text: shards merge only with shards of the same suite.
    pub digest: String,
    /// Frames measured per cell, after one warm-up frame (which compiles pipelines lazily on some
    /// drivers and is excluded from every figure).
    pub frames: u32,
    /// How many of the measured frames are read back and compared with the reference.
    pub error_frames: u32,
    /// How the cells' passes are submitted and timed: `passes` gives each pass a wall time (for
    /// comparisons of passes whose GPU timestamps a driver gets wrong).
    pub timing: crate::gpu::TimingMode,
    pub reference_spp: u32,
    pub scenes: Vec<SuiteScene>,
    pub cells: Vec<CellSpec>,
}

#[derive(Clone, Debug)]
pub struct SuiteScene {
    /// As written in the suite (`NAME:key=value` or a file path relative to the suite).
    pub text: String,
    pub spec: SceneSpec,
    pub reference_spp: u32,
    /// `path` parameters of the scene's references: its own `set`, else the suite's.
    pub reference_settings: Vec<(String, String)>,
    /// The sizes it is rendered at: its own `sizes`, else the suite's.
    pub sizes: Vec<(u32, u32)>,
    /// Scene times of the measured frames, cycled; empty for a still scene (time 0).
    pub times: Vec<f32>,
}

/// One cell of the matrix: a technique with fixed parameters on one scene at one size.
#[derive(Clone, Debug)]
pub struct CellSpec {
    pub index: usize,
    pub scene: usize,
    pub technique: String,
    /// The curve the cell belongs to in plots: its technique entry's label.
    pub series: String,
    /// All parameters: the entry's `set` followed by this cell's sweep values.
    pub settings: Vec<(String, String)>,
    /// The swept parameters alone.
    pub sweep: Vec<(String, String)>,
    pub width: u32,
    pub height: u32,
    /// Frames rendered before the measured ones (at least 1: the first compiles pipelines lazily on
    /// some drivers). Temporal techniques keep world-space history (DDGI's probes) across the cut
    /// before every frame, so more warm-up frames let it converge.
    pub warmup: u32,
}

/// A deterministic slice of the matrix: cells whose index is `index` modulo `count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: u32,
    pub count: u32,
}

impl Shard {
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Parses `I/N` with I < N.
    pub fn parse(text: &str) -> Result<Shard, String> {
        let parsed = text
            .split_once('/')
            .and_then(|(i, n)| Some((i.trim().parse::<u32>().ok()?, n.trim().parse::<u32>().ok()?)));
        match parsed {
            Some((index, count)) if count > 0 && index < count => Ok(Shard { index, count }),
            _ => Err(format!("'{text}' is not a shard; expected I/N with 0 ≤ I < N, e.g. 0/4")),
        }
    }

    pub fn contains(&self, cell: usize) -> bool {
        cell % self.count as usize == self.index as usize
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// A TOML scalar as the `key=value` text the parameter parser reads.
fn setting_text(key: &str, value: &toml::Value) -> Result<String, String> {
    match value {
        toml::Value::String(s) => Ok(s.clone()),
        toml::Value::Integer(i) => Ok(i.to_string()),
        toml::Value::Float(f) => Ok(f.to_string()),
        toml::Value::Boolean(b) => Ok(b.to_string()),
        other => Err(format!("'{key}': a {} is not a string, number or boolean", other.type_str())),
    }
}

fn settings(map: &BTreeMap<String, toml::Value>) -> Result<Vec<(String, String)>, String> {
    map.iter().map(|(k, v)| Ok((k.clone(), setting_text(k, v)?))).collect()
}

/// Every combination of the sweep's values, keys in name order, values in the order written.
fn combinations(sweep: &BTreeMap<String, Vec<toml::Value>>) -> Result<Vec<Vec<(String, String)>>, String> {
    let mut out = vec![Vec::new()];
    for (key, values) in sweep {
        if values.is_empty() {
            return Err(format!("sweep '{key}' has no values"));
        }
        let texts = values.iter().map(|v| setting_text(key, v)).collect::<Result<Vec<_>, _>>()?;
        out = out
            .into_iter()
            .flat_map(|prefix| {
                texts.iter().map(move |t| {
                    let mut c = prefix.clone();
                    c.push((key.clone(), t.clone()));
                    c
                })
            })
            .collect();
    }
    Ok(out)
}

impl Suite {
    /// Reads and validates a suite: scene names and parameters, technique names and every cell's
    /// parameters are checked here, before any GPU work. Errors name the file.
    pub fn load(path: &Path) -> Result<Suite, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        Suite::parse(&text, path).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Parses suite `text`; `path` locates scene files given relative to the suite.
    pub fn parse(text: &str, path: &Path) -> Result<Suite, String> {
        let file: SuiteFile = toml::from_str(text).map_err(|e| e.to_string().trim_end().to_string())?;
        if file.sizes.is_empty() || file.scenes.is_empty() || file.techniques.is_empty() {
            return Err("a suite needs at least one entry in sizes, scenes and techniques".into());
        }
        if file.frames < 1 {
            return Err("frames must be at least 1".into());
        }
        let error_frames = file.error_frames.unwrap_or(file.frames.min(4));
        if error_frames < 1 || error_frames > file.frames {
            return Err(format!("error_frames must be between 1 and frames ({})", file.frames));
        }
        if file.reference.spp == 0 {
            return Err("reference.spp must be at least 1".into());
        }
        let reference_settings = settings(&file.reference.set).map_err(|e| format!("reference: {e}"))?;
        crate::techniques::resolve("path", &reference_settings).map_err(|e| format!("reference: {e}"))?;
        let parse_sizes = |sizes: &[String]| {
            sizes
                .iter()
                .map(|s| parse_size(s).map_err(|e| format!("sizes: {e}")))
                .collect::<Result<Vec<_>, _>>()
        };
        let suite_sizes = parse_sizes(&file.sizes)?;
        let base = path.parent().unwrap_or(Path::new("."));
        let mut scenes = Vec::new();
        for s in &file.scenes {
            let mut spec = SceneSpec::parse(&s.scene).map_err(|e| format!("scene {e}"))?;
            if let SceneSpec::File(p) = &mut spec
                && p.is_relative()
            {
                *p = base.join(&*p);
            }
            spec.validate().map_err(|e| format!("scene '{}': {e}", s.scene))?;
            if s.spp == Some(0) {
                return Err(format!("scene '{}': spp must be at least 1", s.scene));
            }
            if s.times.iter().any(|t| !t.is_finite()) {
                return Err(format!("scene '{}': times must be finite", s.scene));
            }
            let reference_settings = match &s.set {
                None => reference_settings.clone(),
                Some(set) => {
                    let own = settings(set).map_err(|e| format!("scene '{}': set: {e}", s.scene))?;
                    crate::techniques::resolve("path", &own)
                        .map_err(|e| format!("scene '{}': set (its reference): {e}", s.scene))?;
                    own
                }
            };
            let sizes = match &s.sizes {
                None => suite_sizes.clone(),
                Some(own) if own.is_empty() => {
                    return Err(format!("scene '{}': sizes needs at least one size", s.scene));
                }
                Some(own) => parse_sizes(own).map_err(|e| format!("scene '{}': {e}", s.scene))?,
            };
            scenes.push(SuiteScene {
                text: s.scene.clone(),
                spec,
                reference_spp: s.spp.unwrap_or(file.reference.spp),
                reference_settings,
                sizes,
                times: s.times.clone(),
            });
        }
        let mut entries = Vec::new();
        for t in &file.techniques {
            let set = settings(&t.set).map_err(|e| format!("technique '{}': {e}", t.technique))?;
            let sweeps = combinations(&t.sweep).map_err(|e| format!("technique '{}': {e}", t.technique))?;
            let on: Vec<usize> = match &t.scenes {
                None => (0..scenes.len()).collect(),
                Some(names) => names
                    .iter()
                    .map(|n| {
                        scenes.iter().position(|s| &s.text == n).ok_or_else(|| {
                            format!("technique '{}': scene '{n}' is not in the suite's scenes", t.technique)
                        })
                    })
                    .collect::<Result<_, _>>()?,
            };
            let series = t.label.clone().unwrap_or_else(|| {
                let mut label = t.technique.clone();
                for (k, v) in &set {
                    label.push_str(&format!(" {k}={v}"));
                }
                label
            });
            for sweep in &sweeps {
                let mut all = set.clone();
                all.extend(sweep.iter().cloned());
                crate::techniques::resolve(&t.technique, &all)
                    .map_err(|e| format!("technique '{}' ({series}): {e}", t.technique))?;
            }
            let warmup = t.warmup.unwrap_or(1);
            if warmup == 0 {
                return Err(format!("technique '{}' ({series}): warmup must be at least 1", t.technique));
            }
            entries.push((t.technique.clone(), series, set, sweeps, on, warmup));
        }
        let mut series_names: Vec<&str> = entries.iter().map(|e| e.1.as_str()).collect();
        series_names.sort_unstable();
        if let Some(w) = series_names.windows(2).find(|w| w[0] == w[1]) {
            return Err(format!("two technique entries are labelled '{}'; give one a `label`", w[0]));
        }
        // The suite's sizes, then the sizes only some scenes have, in the order written.
        let mut sizes = suite_sizes;
        for s in &scenes {
            for size in &s.sizes {
                if !sizes.contains(size) {
                    sizes.push(*size);
                }
            }
        }
        let mut cells = Vec::new();
        for &(width, height) in &sizes {
            for (scene, suite_scene) in scenes.iter().enumerate() {
                if !suite_scene.sizes.contains(&(width, height)) {
                    continue;
                }
                for (technique, series, set, sweeps, on, warmup) in &entries {
                    if !on.contains(&scene) {
                        continue;
                    }
                    for sweep in sweeps {
                        let mut all = set.clone();
                        all.extend(sweep.iter().cloned());
                        cells.push(CellSpec {
                            index: cells.len(),
                            scene,
                            technique: technique.clone(),
                            series: series.clone(),
                            settings: all,
                            sweep: sweep.clone(),
                            width,
                            height,
                            warmup: *warmup,
                        });
                    }
                }
            }
        }
        let timing = match &file.timing {
            Some(t) => t.parse().map_err(|e: String| format!("timing: {e}"))?,
            None => crate::gpu::TimingMode::Frame,
        };
        let mut h = StableHasher::default();
        h.str(text);
        Ok(Suite {
            name: file.name,
            description: file.description,
            path: path.to_path_buf(),
            digest: format!("{:016x}", h.finish()),
            frames: file.frames,
            error_frames,
            timing,
            reference_spp: file.reference.spp,
            scenes,
            cells,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SUITE: &str = r#"
name = "t"
sizes = ["32x32", "16x8"]
frames = 3
[reference]
spp = 64
set = { max_bounces = 1 }
[[scenes]]
scene = "cornell"
[[scenes]]
scene = "cornell-spot:animate=spot"
times = [0.0, 0.5]
[[techniques]]
technique = "path"
sweep = { spp = [1, 2, 4] }
[[techniques]]
technique = "igi"
label = "igi raster"
set = { direct = "raster" }
sweep = { vpls = [64, 256], interleave = ["1x1", "4x4"] }
scenes = ["cornell"]
warmup = 5
"#;

    #[test]
    fn the_matrix_is_sizes_by_scenes_by_sweeps_in_a_fixed_order() {
        let s = Suite::parse(SUITE, Path::new("benches/t.toml")).expect("suite");
        // Per size: cornell 3 path + 4 igi cells, cornell-spot 3 path cells.
        assert_eq!(s.cells.len(), 2 * (3 + 4 + 3));
        assert_eq!(s.error_frames, 3);
        let one_bounce = vec![("max_bounces".to_string(), "1".to_string())];
        assert!(s.scenes.iter().all(|scene| scene.reference_settings == one_bounce));
        assert!(s.scenes.iter().all(|scene| scene.sizes == vec![(32, 32), (16, 8)]));
        let c = &s.cells[4];
        assert_eq!((c.scene, c.technique.as_str(), c.series.as_str()), (0, "igi", "igi raster"));
        // Sweep keys in name order (interleave before vpls), values as written.
        assert_eq!(
            c.sweep,
            vec![("interleave".to_string(), "1x1".to_string()), ("vpls".to_string(), "256".to_string())]
        );
        assert_eq!(c.settings[0], ("direct".to_string(), "raster".to_string()));
        assert_eq!((s.cells[0].warmup, c.warmup), (1, 5));
        assert_eq!((s.cells[10].width, s.cells[10].height), (16, 8));
        assert!(s.cells.iter().enumerate().all(|(i, c)| c.index == i));
        assert_eq!(s.scenes[1].times, vec![0.0, 0.5]);
    }

    /// A scene's own `sizes` and reference `set` replace the suite's for that scene alone; sizes no
    /// other scene has come after the suite's in the matrix.
    #[test]
    fn scenes_may_have_their_own_sizes_and_reference_settings() {
        let text = SUITE.replace(
            "times = [0.0, 0.5]\n",
            "times = [0.0, 0.5]\nsizes = [\"8x8\", \"16x8\"]\nset = { max_bounces = 2, seed = 7 }\n",
        );
        assert_ne!(text, SUITE);
        let s = Suite::parse(&text, Path::new("t.toml")).expect("suite");
        assert_eq!(s.scenes[0].sizes, vec![(32, 32), (16, 8)]);
        assert_eq!(s.scenes[1].sizes, vec![(8, 8), (16, 8)]);
        assert_eq!(s.scenes[0].reference_settings, vec![("max_bounces".to_string(), "1".to_string())]);
        assert_eq!(
            s.scenes[1].reference_settings,
            vec![("max_bounces".to_string(), "2".to_string()), ("seed".to_string(), "7".to_string())]
        );
        // 32x32: cornell (3 path + 4 igi); 16x8: cornell and cornell-spot (3 path); 8x8: cornell-spot.
        let shape: Vec<(u32, usize, usize)> = [(32, 0), (16, 0), (16, 1), (8, 1)]
            .iter()
            .map(|&(w, scene)| {
                let n = s.cells.iter().filter(|c| c.width == w && c.scene == scene).count();
                (w, scene, n)
            })
            .collect();
        assert_eq!(shape, vec![(32, 0, 7), (16, 0, 7), (16, 1, 3), (8, 1, 3)]);
        assert_eq!(s.cells.len(), 20);
        let order: Vec<(u32, usize)> = s.cells.iter().map(|c| (c.width, c.scene)).collect();
        let mut sorted = order.clone();
        sorted.sort_by_key(|&(w, scene)| ([32, 16, 8].iter().position(|&x| x == w), scene));
        assert_eq!(order, sorted, "size (suite's first) → scene → entry");
        // An empty `set` is a full-GI reference for that scene.
        let full = SUITE.replace("times = [0.0, 0.5]\n", "times = [0.0, 0.5]\nset = {}\n");
        let s = Suite::parse(&full, Path::new("t.toml")).expect("suite");
        assert!(s.scenes[1].reference_settings.is_empty());
    }

    /// The suites the repository ships (benches/*.toml) are valid: the bench's own and those the
    /// measurement scripts run.
    #[test]
    fn the_committed_suites_parse() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../benches");
        let mut names = Vec::new();
        for entry in std::fs::read_dir(&dir).expect("benches/") {
            let path = entry.expect("entry").path();
            if path.extension().is_some_and(|e| e == "toml") {
                let suite = Suite::load(&path).unwrap_or_else(|e| panic!("{e}"));
                assert!(!suite.cells.is_empty(), "{}", path.display());
                names.push(path.file_name().expect("name").to_string_lossy().into_owned());
            }
        }
        names.sort();
        assert_eq!(
            names,
            [
                "ddgi-formats.toml",
                "ddgi-gpu.toml",
                "ddgi-lavapipe.toml",
                "ddgi.toml",
                "env-harmonics.toml",
                "gpu.toml",
                "igi-cost.toml",
                "igi.toml",
                "lpv.toml",
                "photon-irradiance-cache.toml",
                "primary.toml",
                "prt-hard-shadows.toml",
                "prt-moving.toml",
                "prt-texels.toml",
                "prt-turning.toml",
                "prt.toml",
                "quick.toml",
                "radiance-cache-glossy.toml",
                "radiance-cache.toml",
                "rsm-timing.toml",
                "rsm.toml",
                "splat.toml",
                "traversal.toml",
                "vpl-equal-time-quick.toml",
                "vpl-equal-time.toml",
                "vxgi-voxelization.toml",
                "vxgi.toml"
            ]
        );
        // The scripts' suites use the per-scene overrides: bumpy-glossy at its own size, with the same
        // full-GI reference in both (one cached file), while rsm's other references are one-bounce.
        let load = |name: &str| Suite::load(&dir.join(name)).unwrap_or_else(|e| panic!("{e}"));
        // DDGI's cells converge their probes first; the other techniques of its suite do not need to.
        let ddgi = load("ddgi.toml");
        // The G-buffer comparison times every pass alone: wall times, beside the timestamps.
        assert_eq!(load("primary.toml").timing, crate::gpu::TimingMode::Passes);
        assert_eq!(ddgi.timing, crate::gpu::TimingMode::Frame);
        assert!(ddgi.cells.iter().all(|c| (c.warmup == 100) == (c.technique == "ddgi")));
        let (igi, rsm) = (load("igi.toml"), load("rsm.toml"));
        let bumpy =
            |s: &Suite| s.scenes.iter().find(|x| x.text == "bumpy-glossy").cloned().expect("bumpy-glossy");
        let (a, b) = (bumpy(&igi), bumpy(&rsm));
        assert_eq!(
            (a.sizes, a.reference_spp, a.reference_settings),
            (b.sizes, b.reference_spp, b.reference_settings)
        );
        assert_eq!(rsm.scenes[0].reference_settings, vec![("max_bounces".to_string(), "1".to_string())]);
        assert!(igi.cells.iter().all(|c| (c.width == 128) == (igi.scenes[c.scene].text == "bumpy-glossy")));
    }

    #[test]
    fn shards_partition_the_matrix() {
        let s = Suite::parse(SUITE, Path::new("t.toml")).expect("suite");
        let shards: Vec<Shard> = (0..3).map(|i| Shard { index: i, count: 3 }).collect();
        for cell in 0..s.cells.len() {
            assert_eq!(shards.iter().filter(|sh| sh.contains(cell)).count(), 1);
        }
        assert_eq!(Shard::parse("2/3"), Ok(shards[2]));
        for bad in ["3/3", "1", "a/2", "0/0"] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn mistakes_are_reported_before_any_gpu_work() {
        for (edit, needle) in [
            (("technique = \"path\"", "technique = \"nope\""), "nope"),
            (("spp = [1, 2, 4]", "spp = [0]"), "spp"),
            (("scene = \"cornell\"\n", "scene = \"cornel\"\n"), "cornel"),
            (("scenes = [\"cornell\"]", "scenes = [\"atrium\"]"), "atrium"),
            (("frames = 3", "frames = 3\nerror_frames = 9"), "error_frames"),
            (("label = \"igi raster\"", "label = \"path\""), "labelled"),
            (("sizes = [", "colour = 1\nsizes = ["), "colour"),
            (("vpls = [64, 256]", "vpls = []"), "no values"),
            (("warmup = 5", "warmup = 0"), "warmup"),
            (("times = [0.0, 0.5]", "times = [0.0, 0.5]\nsizes = []"), "'cornell-spot:animate=spot': sizes"),
            (
                ("times = [0.0, 0.5]", "times = [0.0, 0.5]\nsizes = [\"8x\"]"),
                "'cornell-spot:animate=spot': sizes",
            ),
            (
                ("times = [0.0, 0.5]", "times = [0.0, 0.5]\nset = { bounces = 1 }"),
                "'cornell-spot:animate=spot': set",
            ),
            (
                ("times = [0.0, 0.5]", "times = [0.0, 0.5]\nset = { max_bounces = [1] }"),
                "'cornell-spot:animate=spot': set",
            ),
        ] {
            let text = SUITE.replacen(edit.0, edit.1, 1);
            assert_ne!(text, SUITE, "{edit:?} did not apply");
            let e = Suite::parse(&text, Path::new("t.toml")).expect_err("an error");
            assert!(e.contains(needle), "{edit:?}: {e}");
        }
    }
}
