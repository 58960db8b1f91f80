//! Linear HDR images and their files.
//!
//! The file format follows the extension (case-insensitive):
//! - `.exr` (read and write): linear f32 RGB, written as is — negative and non-finite values included —
//!   with lossless compression, so a write followed by a read is bit-exact. Reading accepts half or
//!   float RGB in the first layer and ignores alpha.
//! - `.hdr` (read only): Radiance RGBE, linear.
//! - `.png` (read and write): written through the tone map below. Read back by decoding sRGB to linear,
//!   which is a convenience: an 8-bit PNG holds a display image, not the radiance that was rendered.
//!
//! # The PNG tone map
//!
//! Per channel of linear radiance `c`, with [`ToneMap::exposure_ev`] = `ev`:
//! 1. exposure: `x = c · 2^ev`;
//! 2. the ACES filmic fit of Narkowicz (2015): `y = x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)`, clamped to
//!    `[0, 1]` (negative `x` counts as 0; the curve reaches 1 near `x = 7.24`);
//! 3. the exact sRGB OETF: `s = 12.92·y` for `y ≤ 0.0031308`, else `1.055·y^(1/2.4) − 0.055`;
//! 4. 8 bits: `round(255·s)`.
//!
//! Non-finite radiance: NaN becomes 0 (black), +∞ becomes 1 (white), −∞ becomes 0. [`tone_map_pixel`]
//! implements steps 1–3 so that image comparisons can measure exactly what the PNG shows.

use std::io::Cursor;
use std::path::{Path, PathBuf};

/// A linear HDR RGB image, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct HdrImage {
    pub width: u32,
    pub height: u32,
    /// width × height × 3 linear radiance values.
    pub rgb: Vec<f32>,
}

impl HdrImage {
    pub fn new(width: u32, height: u32) -> Self {
        HdrImage { width, height, rgb: vec![0.0; width as usize * height as usize * 3] }
    }

    pub fn pixel(&self, x: u32, y: u32) -> [f32; 3] {
        let i = (y as usize * self.width as usize + x as usize) * 3;
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }

    /// Reads an `.exr`, `.hdr` or `.png` file (see the module documentation).
    pub fn read(path: impl AsRef<Path>) -> Result<HdrImage, ImageError> {
        let path = path.as_ref();
        let format = FileFormat::for_reading(path)?;
        let bytes = std::fs::read(path)
            .map_err(|e| ImageError::Read { path: path.into(), message: e.to_string() })?;
        match format {
            FileFormat::Exr => read_exr(path, bytes),
            FileFormat::Hdr => {
                let decoded = decode(path, &bytes, ::image::ImageFormat::Hdr, "Radiance HDR")?;
                Ok(HdrImage { width: decoded.width(), height: decoded.height(), rgb: decoded.into_raw() })
            }
            FileFormat::Png => {
                let decoded = decode(path, &bytes, ::image::ImageFormat::Png, "PNG")?;
                let (width, height) = (decoded.width(), decoded.height());
                let rgb = decoded.into_raw().into_iter().map(srgb_decode).collect();
                Ok(HdrImage { width, height, rgb })
            }
        }
    }

    /// Writes `.exr` (linear, as is) or `.png` (through `tone_map`), chosen by the extension of `path`.
    pub fn write(&self, path: impl AsRef<Path>, tone_map: &ToneMap) -> Result<(), ImageError> {
        let path = path.as_ref();
        match FileFormat::for_writing(path)? {
            FileFormat::Exr => self.write_exr(path),
            FileFormat::Png => self.write_png(path, tone_map),
            // `for_writing` never chooses a read-only format.
            FileFormat::Hdr => Err(unsupported(path, FileFormat::WRITABLE)),
        }
    }

    /// Writes linear f32 RGB to an OpenEXR file, values as they are.
    pub fn write_exr(&self, path: impl AsRef<Path>) -> Result<(), ImageError> {
        use exr::prelude::{Image, SpecificChannels, Vec2, WritableImage};

        let path = path.as_ref();
        self.check_size(path)?;
        let width = self.width as usize;
        let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
            let i = (y * width + x) * 3;
            (self.rgb[i], self.rgb[i + 1], self.rgb[i + 2])
        });
        // Encode in memory first so that a failed encode never leaves a partial file behind.
        let mut bytes = Cursor::new(Vec::new());
        Image::from_channels((width, self.height as usize), channels)
            .write()
            .to_buffered(&mut bytes)
            .map_err(|e| ImageError::Encode { path: path.into(), message: format!("OpenEXR: {e}") })?;
        write_file(path, bytes.get_ref())
    }

    /// Writes an 8-bit sRGB PNG through `tone_map` (see the module documentation).
    pub fn write_png(&self, path: impl AsRef<Path>, tone_map: &ToneMap) -> Result<(), ImageError> {
        let path = path.as_ref();
        self.check_size(path)?;
        write_rgb8_png(path, self.width, self.height, &self.to_rgb8(tone_map))
    }

    /// The 8-bit sRGB pixels a PNG written with `tone_map` holds (width × height × 3 bytes).
    pub fn to_rgb8(&self, tone_map: &ToneMap) -> Vec<u8> {
        self.rgb
            .chunks_exact(3)
            .flat_map(|p| tone_map_pixel([p[0], p[1], p[2]], tone_map).map(unorm8))
            .collect()
    }

    /// `path` only names the file in the error.
    fn check_size(&self, path: &Path) -> Result<(), ImageError> {
        let expected = self.width as usize * self.height as usize * 3;
        if self.width == 0 || self.height == 0 || self.rgb.len() != expected {
            return Err(ImageError::SizeMismatch {
                path: path.into(),
                width: self.width,
                height: self.height,
                expected,
                actual: self.rgb.len(),
            });
        }
        Ok(())
    }
}

/// Errors of image files. Every message names the file.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    #[error("{}: cannot read: {message}", path.display())]
    Read { path: PathBuf, message: String },
    #[error("{}: cannot write: {message}", path.display())]
    Write { path: PathBuf, message: String },
    /// `extension` is quoted (`'.jpg'`) or says `no extension`.
    #[error("{}: unsupported image file ({extension}); {supported}", path.display())]
    UnsupportedExtension { path: PathBuf, extension: String, supported: &'static str },
    #[error(
        "{}: a {width}x{height} image needs {expected} values but holds {actual}",
        path.display()
    )]
    SizeMismatch { path: PathBuf, width: u32, height: u32, expected: usize, actual: usize },
    /// The file exists but its content cannot be decoded.
    #[error("{}: {message}", path.display())]
    Decode { path: PathBuf, message: String },
    #[error("{}: cannot encode: {message}", path.display())]
    Encode { path: PathBuf, message: String },
}

/// The image file formats rtgi knows, by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileFormat {
    Exr,
    Hdr,
    Png,
}

impl FileFormat {
    const READABLE: &'static str = "rtgi reads .exr, .hdr and .png";
    const WRITABLE: &'static str = "rtgi writes .exr (linear HDR) and .png (tone-mapped)";

    /// The format `path`'s extension names, if any.
    pub fn from_path(path: &Path) -> Option<FileFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "exr" => Some(FileFormat::Exr),
            "hdr" => Some(FileFormat::Hdr),
            "png" => Some(FileFormat::Png),
            _ => None,
        }
    }

    /// The format [`HdrImage::read`] would use for `path`.
    pub fn for_reading(path: &Path) -> Result<FileFormat, ImageError> {
        FileFormat::from_path(path).ok_or_else(|| unsupported(path, Self::READABLE))
    }

    /// The format [`HdrImage::write`] would use for `path`; lets callers reject a bad output path before
    /// doing the work that produces the image.
    pub fn for_writing(path: &Path) -> Result<FileFormat, ImageError> {
        match FileFormat::from_path(path) {
            Some(f @ (FileFormat::Exr | FileFormat::Png)) => Ok(f),
            _ => Err(unsupported(path, Self::WRITABLE)),
        }
    }
}

/// Exposure applied before the PNG tone map.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ToneMap {
    /// Stops: radiance is multiplied by 2^exposure_ev.
    pub exposure_ev: f32,
}

/// Steps 1–3 of the documented tone map: linear radiance to display-encoded sRGB in `[0, 1]`, before
/// quantisation (which [`unorm8`] does).
pub fn tone_map_pixel(rgb: [f32; 3], tone_map: &ToneMap) -> [f32; 3] {
    let scale = tone_map.exposure_ev.exp2();
    rgb.map(|c| {
        // Decided before scaling: a very negative exposure would turn +inf into inf·0 = NaN.
        if c.is_nan() {
            return 0.0;
        }
        if c == f32::INFINITY {
            return 1.0;
        }
        srgb_encode(aces_filmic(c * scale).clamp(0.0, 1.0))
    })
}

/// The ACES filmic fit of Narkowicz (2015). Negative input counts as 0; not clamped above (it tends to
/// 2.51/2.43 ≈ 1.03).
pub fn aces_filmic(x: f32) -> f32 {
    // Past ~7.24 the curve is above 1 and only grows, so capping the input changes no clamped result
    // while keeping x² finite for huge radiance.
    let x = x.clamp(0.0, 1.0e4);
    (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)
}

/// The exact sRGB OETF (IEC 61966-2-1) of a linear value in `[0, 1]`.
pub fn srgb_encode(linear: f32) -> f32 {
    if linear <= 0.0031308 { 12.92 * linear } else { 1.055 * linear.powf(1.0 / 2.4) - 0.055 }
}

/// The inverse of [`srgb_encode`]: sRGB-encoded `[0, 1]` to linear.
pub fn srgb_decode(encoded: f32) -> f32 {
    if encoded <= 0.04045 { encoded / 12.92 } else { ((encoded + 0.055) / 1.055).powf(2.4) }
}

/// Rounds a `[0, 1]` value to 8 bits (values outside are clamped).
pub fn unorm8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

fn unsupported(path: &Path, supported: &'static str) -> ImageError {
    let extension = match path.extension() {
        Some(e) => format!("'.{}'", e.to_string_lossy()),
        None => "no extension".to_string(),
    };
    ImageError::UnsupportedExtension { path: path.into(), extension, supported }
}

/// Writes 8-bit RGB pixels (already display-encoded, e.g. an error map) as a PNG.
pub fn write_rgb8_png(
    path: impl AsRef<Path>,
    width: u32,
    height: u32,
    rgb8: &[u8],
) -> Result<(), ImageError> {
    use ::image::ImageEncoder;

    let path = path.as_ref();
    let mut bytes = Vec::new();
    ::image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(rgb8, width, height, ::image::ExtendedColorType::Rgb8)
        .map_err(|e| ImageError::Encode { path: path.into(), message: format!("PNG: {e}") })?;
    write_file(path, &bytes)
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<(), ImageError> {
    std::fs::write(path, bytes).map_err(|e| ImageError::Write { path: path.into(), message: e.to_string() })
}

/// Decodes a PNG or HDR file to f32 RGB (normalised to [0, 1] for integer formats, alpha dropped).
fn decode(
    path: &Path,
    bytes: &[u8],
    format: ::image::ImageFormat,
    name: &str,
) -> Result<::image::Rgb32FImage, ImageError> {
    ::image::load_from_memory_with_format(bytes, format).map(|img| img.to_rgb32f()).map_err(|e| {
        ImageError::Decode { path: path.into(), message: format!("not a readable {name} file: {e}") }
    })
}

fn read_exr(path: &Path, bytes: Vec<u8>) -> Result<HdrImage, ImageError> {
    use exr::prelude::{ReadChannels, ReadLayers, Vec2, read};

    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |size: Vec2<usize>, _| HdrImage::new(size.width() as u32, size.height() as u32),
            |image: &mut HdrImage, Vec2(x, y): Vec2<usize>, (r, g, b, _a): (f32, f32, f32, f32)| {
                let i = (y * image.width as usize + x) * 3;
                image.rgb[i..i + 3].copy_from_slice(&[r, g, b]);
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| ImageError::Decode {
            path: path.into(),
            message: format!("not a readable OpenEXR RGB image: {e}"),
        })?;
    Ok(image.layer_data.channel_data.pixels)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tone_map_u8(c: f32, exposure_ev: f32) -> u8 {
        unorm8(tone_map_pixel([c, c, c], &ToneMap { exposure_ev })[0])
    }

    #[test]
    fn exr_round_trip_is_bit_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        let special = [
            0.0,
            -0.0,
            1.0,
            -3.25,
            f32::MIN_POSITIVE / 8.0,
            f32::MAX,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            0.1,
        ];
        // 5x3 with distinct values everywhere, so a transposed or flipped read cannot pass.
        let mut image = HdrImage::new(5, 3);
        for (i, v) in image.rgb.iter_mut().enumerate() {
            *v = if i < special.len() { special[i] } else { (i as f32).sqrt() * 1.37e3 - 7.0 };
        }
        image.write_exr(&path).unwrap();
        let back = HdrImage::read(&path).unwrap();
        assert_eq!((back.width, back.height), (5, 3));
        let bits = |im: &HdrImage| im.rgb.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back), bits(&image));
    }

    #[test]
    fn tone_map_known_values() {
        assert_eq!(tone_map_u8(0.0, 0.0), 0);
        // By hand: ACES(0.18) = 0.086724 / 0.324932 = 0.266899; sRGB: 1.055·0.266899^(1/2.4) − 0.055
        // = 0.553458; ·255 = 141.13.
        assert_eq!(tone_map_u8(0.18, 0.0), 141);
        // ACES(1) = 2.54 / 3.16 = 0.803797 → sRGB 0.908230 → 231.6.
        assert_eq!(tone_map_u8(1.0, 0.0), 232);
        // One stop up doubles the radiance before the curve.
        assert_eq!(tone_map_u8(0.09, 1.0), 141);
        assert_eq!(tone_map_u8(8.0, 0.0), 255);
        assert_eq!(tone_map_u8(1.0e30, 0.0), 255);
        assert_eq!(tone_map_u8(-5.0, 0.0), 0);
        assert_eq!(tone_map_u8(-1.0e30, 0.0), 0);
    }

    #[test]
    fn tone_map_non_finite() {
        assert_eq!(tone_map_u8(f32::NAN, 0.0), 0);
        assert_eq!(tone_map_u8(f32::INFINITY, 0.0), 255);
        assert_eq!(tone_map_u8(f32::INFINITY, -200.0), 255);
        assert_eq!(tone_map_u8(f32::NEG_INFINITY, 0.0), 0);
    }

    #[test]
    fn srgb_encode_of_half_is_188() {
        // 0.5 linear → 0.735357 → 187.516 → 188.
        assert_eq!(unorm8(srgb_encode(0.5)), 188);
        for v in [0.0, 0.002, 0.01, 0.2, 0.5, 1.0] {
            assert!((srgb_decode(srgb_encode(v)) - v).abs() < 1e-6, "{v}");
        }
    }

    #[test]
    fn png_write_applies_tone_map_and_reads_back_linear() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.PNG");
        let mut image = HdrImage::new(2, 1);
        image.rgb = vec![0.0, 0.18, 1.0, f32::NAN, f32::INFINITY, 100.0];
        image.write(&path, &ToneMap::default()).unwrap();
        let decoded = ::image::open(&path).unwrap().to_rgb8();
        assert_eq!(decoded.into_raw(), vec![0, 141, 232, 0, 255, 255]);
        let back = HdrImage::read(&path).unwrap();
        assert_eq!((back.width, back.height), (2, 1));
        assert!((back.rgb[1] - srgb_decode(141.0 / 255.0)).abs() < 1e-6);
        assert_eq!(back.rgb[4], 1.0);
    }

    #[test]
    fn reads_radiance_hdr() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.hdr");
        // Powers of two survive RGBE's shared exponent exactly.
        let pixels = [::image::Rgb([0.5f32, 1.0, 2.0]), ::image::Rgb([4.0, 0.25, 0.0])];
        let mut bytes = Vec::new();
        ::image::codecs::hdr::HdrEncoder::new(&mut bytes).encode(&pixels, 2, 1).unwrap();
        std::fs::write(&path, bytes).unwrap();
        let image = HdrImage::read(&path).unwrap();
        assert_eq!(image.rgb, vec![0.5, 1.0, 2.0, 4.0, 0.25, 0.0]);
    }

    #[test]
    fn errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("missing.exr");
        let e = HdrImage::read(&missing).unwrap_err().to_string();
        assert!(e.contains("missing.exr") && e.contains("cannot read"), "{e}");

        let garbage = dir.path().join("garbage.exr");
        std::fs::write(&garbage, b"not an exr").unwrap();
        let e = HdrImage::read(&garbage).unwrap_err().to_string();
        assert!(e.contains("garbage.exr") && e.contains("OpenEXR"), "{e}");

        let image = HdrImage::new(2, 2);
        let e = image.write(dir.path().join("out.jpg"), &ToneMap::default()).unwrap_err().to_string();
        assert!(e.contains("out.jpg") && e.contains("'.jpg'") && e.contains(".png"), "{e}");
        let e = image.write(dir.path().join("out"), &ToneMap::default()).unwrap_err().to_string();
        assert!(e.contains("no extension"), "{e}");
        let e = image.write(dir.path().join("x.hdr"), &ToneMap::default()).unwrap_err().to_string();
        assert!(e.contains("x.hdr"), "{e}");

        let bad = HdrImage { width: 2, height: 2, rgb: vec![0.0; 5] };
        let e = bad.write_exr(dir.path().join("bad.exr")).unwrap_err().to_string();
        assert!(e.contains("bad.exr") && e.contains("2x2") && e.contains("12") && e.contains('5'), "{e}");
        assert!(!dir.path().join("bad.exr").exists());

        let e = image.write_png(dir.path().join("no/such/dir/a.png"), &ToneMap::default()).unwrap_err();
        assert!(e.to_string().contains("a.png") && e.to_string().contains("cannot write"), "{e}");
    }
}
