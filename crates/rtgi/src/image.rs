//! Linear HDR images and their files: EXR (as is) and PNG (exposure, tone map, sRGB).

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
}
