//! Image comparison against a reference: RMSE, relative MSE and mean ꟻLIP.
//!
//! RMSE and relMSE work on linear radiance. FLIP (Andersson et al. 2020, NVIDIA's LDR-ꟻLIP through the
//! `nv-flip` crate) works on what a person sees: both images go through the one documented PNG tone map
//! ([`crate::image`], exposure 0: ACES filmic fit, sRGB, 8 bits) before comparison, at the reference
//! FLIP default of 67 pixels per degree (a 0.7 m wide, 3840-pixel monitor seen from 0.7 m).
//!
//! Images holding NaN or ±∞ are refused ([`MetricsError::NonFinite`]): a mean over them is NaN (or ∞)
//! and hides how many pixels are broken, while the count is what a person debugging a technique needs.
//!
//! [`sequence`] compares image sequences frame by frame and measures temporal stability.

pub mod sequence;

use serde::Serialize;

use crate::image::{HdrImage, ToneMap};

/// The ε of relative MSE: (t − r)² / (r² + ε) keeps dark pixels from dominating.
pub const REL_MSE_EPSILON: f64 = 0.01;

#[derive(Debug, thiserror::Error)]
pub enum MetricsError {
    #[error("images differ in size: reference {rw}x{rh}, test {tw}x{th}")]
    SizeMismatch { rw: u32, rh: u32, tw: u32, th: u32 },
    #[error("images are empty")]
    Empty,
    #[error("region {w}x{h} at ({x}, {y}) is empty or leaves the {width}x{height} image")]
    Region { x: u32, y: u32, w: u32, h: u32, width: u32, height: u32 },
    /// One clause per image holding NaN or ±∞ ([`check_all_finite`]), naming it.
    #[error("{}; the metrics are undefined on them", .0.join("; "))]
    NonFinite(Vec<String>),
}

/// Pixels of `image` with a NaN or infinite channel: their count and the first (x, y), rows from the top.
pub fn non_finite_pixels(image: &HdrImage) -> (usize, Option<(u32, u32)>) {
    let mut count = 0;
    let mut first = None;
    for (i, px) in image.rgb.chunks_exact(3).enumerate() {
        if px.iter().any(|v| !v.is_finite()) {
            count += 1;
            if first.is_none() && image.width > 0 {
                let i = i as u32;
                first = Some((i % image.width, i / image.width));
            }
        }
    }
    (count, first)
}

/// Fails with [`MetricsError::NonFinite`], naming the image `name`, if any pixel is NaN or infinite.
pub fn check_finite(image: &HdrImage, name: &str) -> Result<(), MetricsError> {
    check_all_finite(&[(image, name)])
}

/// Like [`check_finite`] for several (image, name) pairs at once, so an error counts the non-finite
/// pixels of every image that holds some, not only of the first.
pub fn check_all_finite(images: &[(&HdrImage, &str)]) -> Result<(), MetricsError> {
    let clauses: Vec<String> = images
        .iter()
        .filter_map(|(image, name)| match non_finite_pixels(image) {
            (0, _) => None,
            (count, first) => {
                let (x, y) = first.unwrap_or_default();
                let total = image.rgb.len() / 3;
                Some(format!(
                    "{name} holds {count} non-finite pixel(s) (NaN or ±inf) of {total}, the first at ({x}, {y})"
                ))
            }
        })
        .collect();
    if clauses.is_empty() { Ok(()) } else { Err(MetricsError::NonFinite(clauses)) }
}

/// The three error figures of a comparison.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Metrics {
    pub rmse: f64,
    pub rel_mse: f64,
    pub flip: f64,
}

fn check(reference: &HdrImage, test: &HdrImage) -> Result<(), MetricsError> {
    if reference.width != test.width || reference.height != test.height {
        return Err(MetricsError::SizeMismatch {
            rw: reference.width,
            rh: reference.height,
            tw: test.width,
            th: test.height,
        });
    }
    if reference.rgb.is_empty() {
        return Err(MetricsError::Empty);
    }
    check_all_finite(&[(reference, "reference"), (test, "test")])
}

/// Luminance (Rec. 709 weights) of linear RGB.
pub fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Mean linear radiance (RGB) of the pixels in the rectangle at (x, y) of size w×h.
pub fn region_mean(image: &HdrImage, x: u32, y: u32, w: u32, h: u32) -> Result<[f64; 3], MetricsError> {
    if w == 0 || h == 0 || x.saturating_add(w) > image.width || y.saturating_add(h) > image.height {
        return Err(MetricsError::Region { x, y, w, h, width: image.width, height: image.height });
    }
    let mut sum = [0.0f64; 3];
    for py in y..y + h {
        for px in x..x + w {
            let i = 3 * (py * image.width + px) as usize;
            for (c, s) in sum.iter_mut().enumerate() {
                *s += f64::from(image.rgb[i + c]);
            }
        }
    }
    let n = f64::from(w) * f64::from(h);
    Ok(sum.map(|s| s / n))
}

/// Root-mean-square error over all channels and pixels.
pub fn rmse(reference: &HdrImage, test: &HdrImage) -> Result<f64, MetricsError> {
    check(reference, test)?;
    let sum: f64 =
        reference.rgb.iter().zip(&test.rgb).map(|(r, t)| (f64::from(*t) - f64::from(*r)).powi(2)).sum();
    Ok((sum / reference.rgb.len() as f64).sqrt())
}

/// Relative MSE: the mean over channels and pixels of (t − r)² / (r² + 0.01).
pub fn rel_mse(reference: &HdrImage, test: &HdrImage) -> Result<f64, MetricsError> {
    check(reference, test)?;
    let sum: f64 = reference
        .rgb
        .iter()
        .zip(&test.rgb)
        .map(|(r, t)| {
            let (r, t) = (f64::from(*r), f64::from(*t));
            (t - r).powi(2) / (r * r + REL_MSE_EPSILON)
        })
        .sum();
    Ok(sum / reference.rgb.len() as f64)
}

/// The FLIP error map (one value in [0, 1] per pixel, rows top to bottom) and its mean.
pub fn flip_map(reference: &HdrImage, test: &HdrImage) -> Result<(Vec<f32>, f64), MetricsError> {
    check(reference, test)?;
    let tone = ToneMap { exposure_ev: 0.0 };
    let r = nv_flip::FlipImageRgb8::with_data(reference.width, reference.height, &reference.to_rgb8(&tone));
    let t = nv_flip::FlipImageRgb8::with_data(test.width, test.height, &test.to_rgb8(&tone));
    let map = nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE).to_vec();
    let mean = map.iter().map(|v| f64::from(*v)).sum::<f64>() / map.len() as f64;
    Ok((map, mean))
}

/// Mean FLIP of `test` against `reference`.
pub fn flip(reference: &HdrImage, test: &HdrImage) -> Result<f64, MetricsError> {
    flip_map(reference, test).map(|(_, mean)| mean)
}

/// All three metrics.
pub fn compare(reference: &HdrImage, test: &HdrImage) -> Result<Metrics, MetricsError> {
    Ok(Metrics {
        rmse: rmse(reference, test)?,
        rel_mse: rel_mse(reference, test)?,
        flip: flip(reference, test)?,
    })
}

/// An error map as 8-bit RGB with the magma colour map (black = no error, yellow = largest).
pub fn error_map_rgb8(map: &[f32], width: u32, height: u32) -> Vec<u8> {
    let img = nv_flip::FlipImageFloat::with_data(width, height, map);
    img.apply_color_lut(&nv_flip::magma_lut()).to_vec()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(w: u32, h: u32, rgb: Vec<f32>) -> HdrImage {
        HdrImage { width: w, height: h, rgb }
    }

    #[test]
    fn rmse_and_rel_mse_by_hand() {
        // Two pixels: reference (0, 0.5, 1), (2, 0, 0.1); test adds known offsets.
        let r = img(2, 1, vec![0.0, 0.5, 1.0, 2.0, 0.0, 0.1]);
        let t = img(2, 1, vec![0.1, 0.5, 0.8, 2.0, 0.3, 0.1]);
        let sq = [0.01, 0.0, 0.04, 0.0, 0.09, 0.0];
        let want_rmse = (sq.iter().sum::<f64>() / 6.0).sqrt();
        assert!((rmse(&r, &t).unwrap() - want_rmse).abs() < 1e-7);
        let refs = [0.0, 0.5, 1.0, 2.0, 0.0, 0.1];
        let want_rel = sq.iter().zip(refs).map(|(s, r)| s / (r * r + 0.01)).sum::<f64>() / 6.0;
        assert!(
            (rel_mse(&r, &t).unwrap() - want_rel).abs() < 1e-6,
            "{} vs {want_rel}",
            rel_mse(&r, &t).unwrap()
        );
        assert_eq!(rmse(&r, &r).unwrap(), 0.0);
    }

    #[test]
    fn flip_is_zero_for_identical_images_and_grows_with_noise() {
        let (w, h) = (64u32, 64u32);
        let base: Vec<f32> = (0..w * h * 3).map(|i| 0.2 + 0.6 * ((i % 97) as f32 / 97.0)).collect();
        let r = img(w, h, base.clone());
        assert_eq!(flip(&r, &r).unwrap(), 0.0);
        let mut last = 0.0;
        for amplitude in [0.02f32, 0.1, 0.4] {
            let noisy: Vec<f32> = base
                .iter()
                .enumerate()
                .map(|(i, v)| {
                    let n = ((i as u32).wrapping_mul(2654435761) >> 8) as f32 / 16777216.0 - 0.5;
                    (v + amplitude * n).max(0.0)
                })
                .collect();
            let f = flip(&r, &img(w, h, noisy)).unwrap();
            assert!(f > last, "FLIP {f} at noise {amplitude} not above {last}");
            last = f;
        }
    }

    #[test]
    fn non_finite_pixels_are_counted_and_refused() {
        let r = img(3, 2, vec![0.5; 18]);
        let mut t = r.clone();
        t.rgb[3 * 4 + 1] = f32::NAN; // pixel (1, 1)
        t.rgb[3 * 5] = f32::INFINITY; // pixel (2, 1)
        assert_eq!(non_finite_pixels(&t), (2, Some((1, 1))));
        let e = compare(&r, &t).unwrap_err().to_string();
        assert!(
            e.starts_with("test holds 2 non-finite pixel(s)") && e.contains("of 6, the first at (1, 1)"),
            "{e}"
        );
        let e = rel_mse(&t, &r).unwrap_err().to_string();
        assert!(e.starts_with("reference holds 2"), "{e}");
    }

    #[test]
    fn size_mismatch_is_an_error() {
        let e = compare(&img(2, 1, vec![0.0; 6]), &img(1, 2, vec![0.0; 6])).unwrap_err();
        assert!(e.to_string().contains("2x1") && e.to_string().contains("1x2"), "{e}");
    }
}
