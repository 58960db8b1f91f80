//! Side-by-side comparison images: several HDR images tone-mapped (as a `.png` render is) and laid out in
//! one row, each under its label, on a dark background. For READMEs, reports and the demo: one PNG
//! showing a technique next to the reference, labelled with what was rendered.
//!
//! Labels are drawn with the public-domain 8×8 bitmap font of the `font8x8` crate (ASCII and Latin-1;
//! other characters show as '?'), at twice its size on panels at least 512 pixels wide, wrapped at spaces
//! to the panel's width.

use font8x8::UnicodeFonts;

use crate::image::{HdrImage, ToneMap};

/// Pixels between panels and around the label text.
pub const GAP: u32 = 8;
const BACKGROUND: [u8; 3] = [24, 24, 24];
const INK: [u8; 3] = [235, 235, 235];

/// An 8-bit sRGB image, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Rgb8Image {
    pub width: u32,
    pub height: u32,
    /// width × height × 3 bytes.
    pub rgb: Vec<u8>,
}

impl Rgb8Image {
    fn filled(width: u32, height: u32, colour: [u8; 3]) -> Self {
        Rgb8Image { width, height, rgb: colour.repeat(width as usize * height as usize) }
    }

    fn set(&mut self, x: u32, y: u32, colour: [u8; 3]) {
        if x < self.width && y < self.height {
            let i = (y as usize * self.width as usize + x as usize) * 3;
            self.rgb[i..i + 3].copy_from_slice(&colour);
        }
    }

    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let i = (y as usize * self.width as usize + x as usize) * 3;
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }
}

/// The glyph of `c`: 8 rows, bit k of a row is column k (left to right).
fn glyph(c: char) -> [u8; 8] {
    font8x8::BASIC_FONTS
        .get(c)
        .or_else(|| font8x8::LATIN_FONTS.get(c))
        .or_else(|| font8x8::BASIC_FONTS.get('?'))
        .unwrap_or([0; 8])
}

/// Font scale for a panel `width` pixels wide.
fn scale_for(width: u32) -> u32 {
    if width >= 512 { 2 } else { 1 }
}

/// `text` in lines of at most `columns` characters, broken at spaces (a word longer than a line is cut).
pub fn wrap(text: &str, columns: usize) -> Vec<String> {
    let columns = columns.max(1);
    let mut lines = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        let mut word: Vec<char> = word.chars().collect();
        while word.len() > columns {
            if !line.is_empty() {
                lines.push(std::mem::take(&mut line));
            }
            lines.push(word.drain(..columns).collect());
        }
        let word: String = word.into_iter().collect();
        let needed = line.chars().count() + usize::from(!line.is_empty()) + word.chars().count();
        if needed > columns && !line.is_empty() {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(&word);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

/// Draws `line` with its top-left corner at (x, y), each font pixel `scale`² image pixels.
fn draw_line(image: &mut Rgb8Image, line: &str, x: u32, y: u32, scale: u32) {
    for (k, c) in line.chars().enumerate() {
        let rows = glyph(c);
        for (row, bits) in rows.iter().enumerate() {
            for column in 0..8u32 {
                if bits & (1 << column) == 0 {
                    continue;
                }
                for dy in 0..scale {
                    for dx in 0..scale {
                        let px = x + (k as u32 * 8 + column) * scale + dx;
                        image.set(px, y + row as u32 * scale + dy, INK);
                    }
                }
            }
        }
    }
}

/// One row of `panels` (image, label), each tone-mapped with `tone_map`, its label above it.
pub fn montage(panels: &[(&HdrImage, &str)], tone_map: &ToneMap) -> Rgb8Image {
    let layouts: Vec<(u32, Vec<String>)> = panels
        .iter()
        .map(|(image, label)| {
            let scale = scale_for(image.width);
            let columns = (image.width / (8 * scale)) as usize;
            (scale, wrap(label, columns))
        })
        .collect();
    let strip = layouts
        .iter()
        .map(|(scale, lines)| if lines.is_empty() { 0 } else { lines.len() as u32 * 9 * scale + GAP })
        .max()
        .unwrap_or(0);
    let width = panels.iter().map(|(image, _)| image.width).sum::<u32>() + GAP * (panels.len() as u32 + 1);
    let height = strip + panels.iter().map(|(image, _)| image.height).max().unwrap_or(0) + 2 * GAP;
    let mut out = Rgb8Image::filled(width, height, BACKGROUND);
    let mut x = GAP;
    for ((image, _), (scale, lines)) in panels.iter().zip(&layouts) {
        for (k, line) in lines.iter().enumerate() {
            draw_line(&mut out, line, x, GAP + k as u32 * 9 * scale, *scale);
        }
        let pixels = image.to_rgb8(tone_map);
        for y in 0..image.height {
            for px in 0..image.width {
                let i = (y as usize * image.width as usize + px as usize) * 3;
                out.set(x + px, GAP + strip + y, [pixels[i], pixels[i + 1], pixels[i + 2]]);
            }
        }
        x += image.width + GAP;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_wrap_at_spaces_and_cut_long_words() {
        assert_eq!(wrap("path tracer 256 spp", 11), ["path tracer", "256 spp"]);
        assert_eq!(wrap("abcdefghij", 4), ["abcd", "efgh", "ij"]);
        assert_eq!(wrap("  ", 4), Vec::<String>::new());
    }

    /// Two images of different heights: the layout's size, each image's pixels exactly as the PNG tone map
    /// gives them, and the label's first glyph drawn bit for bit from the font.
    #[test]
    fn panels_hold_their_images_and_labels() {
        let mut a = HdrImage::new(40, 30);
        a.rgb.iter_mut().enumerate().for_each(|(i, v)| *v = (i % 97) as f32 / 40.0);
        let b = HdrImage { width: 24, height: 16, rgb: vec![0.5; 24 * 16 * 3] };
        let tone = ToneMap { exposure_ev: 0.0 };
        let m = montage(&[(&a, "A b"), (&b, "")], &tone);
        let strip = 9 + GAP;
        assert_eq!((m.width, m.height), (40 + 24 + 3 * GAP, strip + 30 + 2 * GAP));
        let pa = a.to_rgb8(&tone);
        for y in 0..30 {
            for x in 0..40 {
                let i = (y * 40 + x) as usize * 3;
                assert_eq!(m.pixel(GAP + x, GAP + strip + y), [pa[i], pa[i + 1], pa[i + 2]], "({x}, {y})");
            }
        }
        let pb = b.to_rgb8(&tone);
        assert_eq!(m.pixel(2 * GAP + 40, GAP + strip), [pb[0], pb[1], pb[2]]);
        // Below the shorter image: background.
        assert_eq!(m.pixel(2 * GAP + 40, GAP + strip + 20), BACKGROUND);
        let g = glyph('A');
        for (row, bits) in g.iter().enumerate() {
            for column in 0..8 {
                let ink = bits & (1 << column) != 0;
                let got = m.pixel(GAP + column, GAP + row as u32);
                assert_eq!(got, if ink { INK } else { BACKGROUND }, "glyph A at ({column}, {row})");
            }
        }
        assert!(g.iter().any(|&r| r != 0), "the font has no 'A'");
    }
}
