//! Image sequences: `frame_%04d.exr` patterns, finding their frames on disk, comparing two sequences
//! frame by frame, and temporal stability (how much a sequence changes between consecutive frames).
//!
//! A pattern holds one printf-style frame number in its file name: `%0Nd` (zero-padded to at least N
//! digits, as printf writes it) or `%d`. A sequence is the contiguous run of indices starting at the
//! smallest one present; a gap is an error naming the missing file. Two sequences are paired by frame
//! index, so both must hold the same indices.
//!
//! Temporal stability is the mean FLIP (and relative MSE) of each frame against the one before it. On
//! its own it mixes flicker with real motion; compared with the same figure of the reference sequence
//! (whose change is only the motion) it measures the flicker a technique adds.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::{Metrics, MetricsError};
use crate::image::{HdrImage, ImageError};

/// Errors of sequence patterns, discovery and comparison; every message names a pattern or a file.
#[derive(Debug, thiserror::Error)]
pub enum SequenceError {
    #[error("'{pattern}': {message}")]
    Pattern { pattern: String, message: String },
    #[error("{}: cannot list the folder of '{pattern}': {message}", dir.display())]
    List { dir: PathBuf, pattern: String, message: String },
    #[error("no file matches the sequence '{pattern}'")]
    NoFrames { pattern: String },
    /// A frame one sequence lacks: inside its own run (a gap) or present in the other sequence.
    #[error("{}: missing: {reason}", path.display())]
    Missing { path: PathBuf, reason: String },
    #[error("the sequence '{pattern}' has a single frame (index {index}); temporal stability needs two")]
    TooShort { pattern: String, index: u32 },
    #[error(transparent)]
    Image(#[from] ImageError),
    /// A frame holding NaN or ±inf; the message names its file.
    #[error(transparent)]
    NonFinite(MetricsError),
    /// `what` names the frame file(s) the metric failed on.
    #[error("{what}: {source}")]
    Metrics { what: String, source: MetricsError },
}

/// A file pattern with one frame number, e.g. `out/frame_%04d.exr`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FramePattern {
    text: String,
    dir: PathBuf,
    prefix: String,
    digits: usize,
    suffix: String,
}

impl FramePattern {
    /// `Ok(None)` when the path holds no `%` (a single image); an error when it holds a `%` that is not
    /// one `%0Nd` / `%d` in the file name.
    pub fn parse(path: &Path) -> Result<Option<FramePattern>, SequenceError> {
        let text = path.to_string_lossy().into_owned();
        if !text.contains('%') {
            return Ok(None);
        }
        let err = |message: &str| SequenceError::Pattern { pattern: text.clone(), message: message.into() };
        let name = path.file_name().and_then(|n| n.to_str()).ok_or_else(|| err("no UTF-8 file name"))?;
        if !name.contains('%') {
            return Err(err("the frame number (%0Nd) must be in the file name, not in a folder"));
        }
        if name.matches('%').count() > 1 {
            return Err(err("more than one '%': a pattern holds exactly one frame number %0Nd"));
        }
        let (prefix, rest) = name.split_once('%').ok_or_else(|| err("no '%'"))?;
        let spec_len = rest.find('d').ok_or_else(|| err("expected %0Nd or %d after the prefix"))?;
        let spec = &rest[..spec_len];
        let digits = match spec {
            "" => 1,
            _ if spec.starts_with('0') && spec.len() > 1 && spec.bytes().all(|b| b.is_ascii_digit()) => {
                spec[1..].parse::<usize>().map_err(|_| err("bad width in %0Nd"))?
            }
            _ => return Err(err(&format!("'%{spec}d' is not %0Nd (zero-padded) or %d"))),
        };
        if !(1..=10).contains(&digits) {
            return Err(err("the width N of %0Nd must be 1 to 10"));
        }
        Ok(Some(FramePattern {
            dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
            prefix: prefix.into(),
            digits,
            suffix: rest[spec_len + 1..].into(),
            text,
        }))
    }

    /// The pattern as the user wrote it.
    pub fn as_str(&self) -> &str {
        &self.text
    }

    /// The file of frame `index`.
    pub fn path(&self, index: u32) -> PathBuf {
        self.dir.join(self.file_name(index))
    }

    fn file_name(&self, index: u32) -> String {
        format!("{}{index:0width$}{}", self.prefix, self.suffix, width = self.digits)
    }

    /// The index of the file `name`, if the pattern writes exactly that name (padding included, so that
    /// `a_4.exr` is not frame 4 of `a_%04d.exr`).
    fn index_of(&self, name: &str) -> Option<u32> {
        let number = name.strip_prefix(&self.prefix)?.strip_suffix(&self.suffix)?;
        if number.is_empty() || !number.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        let index = number.parse::<u32>().ok()?;
        (self.file_name(index) == name).then_some(index)
    }

    /// The indices of the files in the pattern's folder that match it, sorted.
    fn indices_on_disk(&self) -> Result<Vec<u32>, SequenceError> {
        let dir = if self.dir.as_os_str().is_empty() { Path::new(".") } else { &self.dir };
        let list_err = |e: std::io::Error| SequenceError::List {
            dir: dir.to_path_buf(),
            pattern: self.text.clone(),
            message: e.to_string(),
        };
        let mut indices = Vec::new();
        for entry in std::fs::read_dir(dir).map_err(list_err)? {
            let entry = entry.map_err(list_err)?;
            if let Some(index) = entry.file_name().to_str().and_then(|n| self.index_of(n)) {
                indices.push(index);
            }
        }
        indices.sort_unstable();
        Ok(indices)
    }
}

/// The frames of a pattern found on disk: indices `first .. first + len` without gaps.
#[derive(Clone, Debug)]
pub struct Sequence {
    pub pattern: FramePattern,
    pub first: u32,
    pub len: u32,
}

impl Sequence {
    /// Finds the frames of `pattern`: the run from the smallest index present to the largest, which
    /// must hold every index in between.
    pub fn discover(pattern: FramePattern) -> Result<Sequence, SequenceError> {
        let indices = pattern.indices_on_disk()?;
        let (Some(&first), Some(&last)) = (indices.first(), indices.last()) else {
            return Err(SequenceError::NoFrames { pattern: pattern.text });
        };
        // Sorted and distinct: the first position whose index is not first + position is a gap.
        if let Some(k) = (0..indices.len()).find(|&k| indices[k] != first + k as u32) {
            let missing = first + k as u32;
            return Err(SequenceError::Missing {
                path: pattern.path(missing),
                reason: format!(
                    "frame {missing} of the sequence '{}', which has frames {first} to {last} otherwise",
                    pattern.text
                ),
            });
        }
        Ok(Sequence { pattern, first, len: indices.len() as u32 })
    }

    pub fn indices(&self) -> std::ops::Range<u32> {
        self.first..self.first + self.len
    }

    /// Reads frame `index`, refusing NaN and infinite pixels with a message naming the file.
    fn read(&self, index: u32) -> Result<(PathBuf, HdrImage), SequenceError> {
        let path = self.pattern.path(index);
        let image = HdrImage::read(&path)?;
        super::check_finite(&image, &path.display().to_string()).map_err(SequenceError::NonFinite)?;
        Ok((path, image))
    }

    fn describe(&self) -> String {
        match self.len {
            1 => format!("frame {}", self.first),
            _ => format!("frames {} to {}", self.first, self.first + self.len - 1),
        }
    }
}

/// The metrics of one frame of a sequence comparison.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FrameMetrics {
    pub index: u32,
    pub flip: f64,
    pub rel_mse: f64,
    pub rmse: f64,
}

/// Mean FLIP and relative MSE of each frame against the previous one, over `pairs` consecutive pairs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TemporalStability {
    pub pairs: u32,
    pub flip: f64,
    pub rel_mse: f64,
}

/// Temporal stability of a sequence fed one frame at a time (only the previous frame is kept).
#[derive(Debug, Default)]
pub struct TemporalAccumulator {
    previous: Option<HdrImage>,
    flip: f64,
    rel_mse: f64,
    pairs: u32,
}

impl TemporalAccumulator {
    /// Adds the next frame; the previous one serves as the reference of relative MSE.
    pub fn push(&mut self, frame: HdrImage) -> Result<(), MetricsError> {
        if let Some(previous) = &self.previous {
            self.flip += super::flip(previous, &frame)?;
            self.rel_mse += super::rel_mse(previous, &frame)?;
            self.pairs += 1;
        }
        self.previous = Some(frame);
        Ok(())
    }

    /// The means, or `None` before the second frame.
    pub fn finish(&self) -> Option<TemporalStability> {
        (self.pairs > 0).then(|| {
            let n = f64::from(self.pairs);
            TemporalStability { pairs: self.pairs, flip: self.flip / n, rel_mse: self.rel_mse / n }
        })
    }
}

/// Temporal stability of frames in memory; `None` for fewer than two.
pub fn temporal_stability(frames: &[HdrImage]) -> Result<Option<TemporalStability>, MetricsError> {
    let mut acc = TemporalAccumulator::default();
    for frame in frames {
        acc.push(frame.clone())?;
    }
    Ok(acc.finish())
}

/// Temporal stability of both sides of a comparison (`None` for a single-frame sequence).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TemporalComparison {
    pub reference: Option<TemporalStability>,
    pub test: Option<TemporalStability>,
}

/// Frame-by-frame metrics of two sequences, their means and both sides' temporal stability.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SequenceComparison {
    pub frames: Vec<FrameMetrics>,
    pub mean: Metrics,
    pub temporal: TemporalComparison,
}

/// Compares `test` with `reference` frame by frame (paired by index; both must hold the same indices,
/// otherwise the error names the first file one of them lacks). Frames are read one pair at a time.
pub fn compare_sequences(reference: &Sequence, test: &Sequence) -> Result<SequenceComparison, SequenceError> {
    check_same_frames(reference, test)?;
    let (mut temporal_r, mut temporal_t) = (TemporalAccumulator::default(), TemporalAccumulator::default());
    let mut frames = Vec::with_capacity(reference.len as usize);
    for index in reference.indices() {
        let (rp, r) = reference.read(index)?;
        let (tp, t) = test.read(index)?;
        let m = super::compare(&r, &t).map_err(|source| SequenceError::Metrics {
            what: format!("frame {index} ({} against {})", tp.display(), rp.display()),
            source,
        })?;
        frames.push(FrameMetrics { index, flip: m.flip, rel_mse: m.rel_mse, rmse: m.rmse });
        for (acc, path, image) in [(&mut temporal_r, &rp, r), (&mut temporal_t, &tp, t)] {
            acc.push(image)
                .map_err(|source| SequenceError::Metrics { what: against_previous_frame(path), source })?;
        }
    }
    let n = frames.len() as f64;
    let mean = Metrics {
        rmse: frames.iter().map(|f| f.rmse).sum::<f64>() / n,
        rel_mse: frames.iter().map(|f| f.rel_mse).sum::<f64>() / n,
        flip: frames.iter().map(|f| f.flip).sum::<f64>() / n,
    };
    let temporal = TemporalComparison { reference: temporal_r.finish(), test: temporal_t.finish() };
    Ok(SequenceComparison { frames, mean, temporal })
}

/// Temporal stability of one sequence on disk (at least two frames).
pub fn sequence_temporal_stability(sequence: &Sequence) -> Result<TemporalStability, SequenceError> {
    let mut acc = TemporalAccumulator::default();
    for index in sequence.indices() {
        let (path, frame) = sequence.read(index)?;
        acc.push(frame)
            .map_err(|source| SequenceError::Metrics { what: against_previous_frame(&path), source })?;
    }
    acc.finish().ok_or_else(|| SequenceError::TooShort {
        pattern: sequence.pattern.text.clone(),
        index: sequence.first,
    })
}

fn against_previous_frame(path: &Path) -> String {
    format!("{} against the frame before it", path.display())
}

fn check_same_frames(reference: &Sequence, test: &Sequence) -> Result<(), SequenceError> {
    let (a, b) = (reference.indices(), test.indices());
    let start = a.start.min(b.start);
    let end = a.end.max(b.end);
    for index in start..end {
        let (missing, other) = match (a.contains(&index), b.contains(&index)) {
            (true, false) => (test, reference),
            (false, true) => (reference, test),
            _ => continue,
        };
        return Err(SequenceError::Missing {
            path: missing.pattern.path(index),
            reason: format!(
                "'{}' has frame {index} ({}), '{}' has {}",
                other.pattern.text,
                other.describe(),
                missing.pattern.text,
                missing.describe()
            ),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pattern(p: &Path) -> FramePattern {
        FramePattern::parse(p).unwrap().expect("a pattern")
    }

    fn frame(value: f32, noise: f32, seed: u32) -> HdrImage {
        let (w, h) = (32u32, 32u32);
        let rgb = (0..w * h * 3)
            .map(|i| {
                let n = ((i ^ seed.wrapping_mul(0x9e37_79b9)).wrapping_mul(2_654_435_761) >> 8) as f32
                    / 16_777_216.0
                    - 0.5;
                (value + 0.3 * ((i % 29) as f32 / 29.0) + noise * n).max(0.0)
            })
            .collect();
        HdrImage { width: w, height: h, rgb }
    }

    fn write(dir: &Path, name: &str, image: &HdrImage) {
        image.write_exr(dir.join(name)).expect("write exr");
    }

    #[test]
    fn patterns_parse_and_format() {
        assert_eq!(FramePattern::parse(Path::new("a.exr")).unwrap(), None);
        let p = pattern(Path::new("out/a_%04d.exr"));
        assert_eq!(p.path(7), Path::new("out/a_0007.exr"));
        assert_eq!(p.path(123_456), Path::new("out/a_123456.exr"));
        assert_eq!(p.index_of("a_0007.exr"), Some(7));
        assert_eq!(p.index_of("a_007.exr"), None, "padding must match");
        assert_eq!(p.index_of("a_12345.exr"), Some(12345));
        assert_eq!(p.index_of("a_00x7.exr"), None);
        assert_eq!(pattern(Path::new("f%d.exr")).index_of("f12.exr"), Some(12));
        for bad in ["a_%4d.exr", "a_%04x.exr", "a_%04d_%04d.exr", "dir%04d/a.exr", "a_%0d.exr"] {
            let e = FramePattern::parse(Path::new(bad)).unwrap_err().to_string();
            assert!(e.contains(bad), "{e}");
        }
    }

    #[test]
    fn discovery_finds_the_contiguous_run_and_names_gaps() {
        let dir = tempfile::tempdir().expect("temp dir");
        let image = frame(0.5, 0.0, 0);
        for i in [3, 4, 5] {
            write(dir.path(), &format!("a_{i:04}.exr"), &image);
        }
        write(dir.path(), "a_004.exr", &image); // wrong padding: not a frame
        write(dir.path(), "b_0004.exr", &image); // another sequence
        let s = Sequence::discover(pattern(&dir.path().join("a_%04d.exr"))).unwrap();
        assert_eq!((s.first, s.len), (3, 3));

        write(dir.path(), "a_0007.exr", &image);
        let e = Sequence::discover(pattern(&dir.path().join("a_%04d.exr"))).unwrap_err().to_string();
        assert!(e.contains("a_0006.exr: missing") && e.contains("frames 3 to 7"), "{e}");

        let e = Sequence::discover(pattern(&dir.path().join("c_%04d.exr"))).unwrap_err().to_string();
        assert!(e.contains("no file matches") && e.contains("c_%04d.exr"), "{e}");
    }

    #[test]
    fn mismatched_sequences_name_the_missing_file() {
        let dir = tempfile::tempdir().expect("temp dir");
        let image = frame(0.5, 0.0, 0);
        for i in 0..4 {
            write(dir.path(), &format!("r_{i:02}.exr"), &image);
        }
        for i in 0..3 {
            write(dir.path(), &format!("t_{i:02}.exr"), &image);
        }
        let r = Sequence::discover(pattern(&dir.path().join("r_%02d.exr"))).unwrap();
        let t = Sequence::discover(pattern(&dir.path().join("t_%02d.exr"))).unwrap();
        let e = compare_sequences(&r, &t).unwrap_err().to_string();
        assert!(e.contains("t_03.exr: missing") && e.contains("frames 0 to 3"), "{e}");
        let e = compare_sequences(&t, &r).unwrap_err().to_string();
        assert!(e.contains("t_03.exr: missing"), "{e}");
    }

    #[test]
    fn sequences_compare_frame_by_frame() {
        let dir = tempfile::tempdir().expect("temp dir");
        for i in 0..3u32 {
            write(dir.path(), &format!("r_{i}.exr"), &frame(0.5, 0.0, 0));
            write(dir.path(), &format!("t_{i}.exr"), &frame(0.5, 0.1 * i as f32, i));
        }
        let r = Sequence::discover(pattern(&dir.path().join("r_%d.exr"))).unwrap();
        let t = Sequence::discover(pattern(&dir.path().join("t_%d.exr"))).unwrap();
        let c = compare_sequences(&r, &t).unwrap();
        assert_eq!(c.frames.iter().map(|f| f.index).collect::<Vec<_>>(), vec![0, 1, 2]);
        assert_eq!(c.frames[0].flip, 0.0);
        assert!(c.frames[2].flip > c.frames[1].flip && c.frames[1].flip > 0.0, "{c:?}");
        let mean_flip = c.frames.iter().map(|f| f.flip).sum::<f64>() / 3.0;
        assert!((c.mean.flip - mean_flip).abs() < 1e-12);
        assert_eq!(c.temporal.reference.map(|s| (s.pairs, s.flip)), Some((2, 0.0)));
        assert!(c.temporal.test.is_some_and(|s| s.flip > 0.0));
    }

    #[test]
    fn temporal_stability_is_zero_for_identical_frames_and_grows_with_noise() {
        let still = vec![frame(0.4, 0.0, 0); 4];
        let s = temporal_stability(&still).unwrap().expect("three pairs");
        assert_eq!((s.pairs, s.flip, s.rel_mse), (3, 0.0, 0.0));
        let mut last = 0.0;
        for noise in [0.02f32, 0.1, 0.4] {
            let frames: Vec<HdrImage> = (0..4).map(|i| frame(0.4, noise, i)).collect();
            let s = temporal_stability(&frames).unwrap().expect("three pairs");
            assert!(s.flip > last && s.rel_mse > 0.0, "noise {noise}: {s:?}, previous FLIP {last}");
            last = s.flip;
        }
        assert_eq!(temporal_stability(&still[..1]).unwrap(), None);
    }

    #[test]
    fn non_finite_frames_are_named() {
        let dir = tempfile::tempdir().expect("temp dir");
        write(dir.path(), "a_0.exr", &frame(0.5, 0.0, 0));
        let mut bad = frame(0.5, 0.0, 0);
        bad.rgb[0] = f32::NAN;
        write(dir.path(), "a_1.exr", &bad);
        let s = Sequence::discover(pattern(&dir.path().join("a_%d.exr"))).unwrap();
        let e = sequence_temporal_stability(&s).unwrap_err().to_string();
        assert!(e.contains("a_1.exr holds 1 non-finite pixel(s)"), "{e}");
    }
}
