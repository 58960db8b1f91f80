//! The normal histograms of a normal-mapped material, summed over texel rectangles in O(1): the
//! "histogram SAT" of Gamboa, Guertin & Nowrouzezahrai 2018 (seed 003, article 2, step 1).
//!
//! Every texel holds, per bin, how many of the micronormals in the rectangle from the map's origin to
//! that texel fall in the bin; four lookups per bin then give the histogram of any axis-aligned box of
//! texels, by inclusion–exclusion. Where rtgi departs from the thesis:
//! - **Micronormals of the surface the GPU shades.** The path tracer reads normal maps bilinearly, so
//!   each texel contributes [`SUBSAMPLES`]² normals of the bilinear field (at its sub-texel centres)
//!   rather than its own value alone; the histogram describes the normals the reference integrates.
//! - **Bins on the projected disc.** A K × K grid over the normals' (x, y) on the disc of radius
//!   `radius` (the largest tilt in the map) instead of the thesis's 9 × 32 (θ, φ) bins, whose cells
//!   shrink at the pole and widen at the rim: the cells here are nearly the same solid angle where
//!   normals are, and a flat-ish map spends no bins on tilts it never has.
//! - **32-bit counts**, twice the thesis's 2 bytes per bin: exact for every footprint, maps tiled any
//!   number of times included (wrap-around arithmetic, see [`NormalHistogram::box_counts`]).
//! - **Row counts**: after the K² bins each texel stores the K row sums, so a footprint asks 2K rows'
//!   worth of lookups before the bins of its occupied rows, not K² (K more counts per texel).

use glam::{Vec2, Vec3};

/// Sub-texel normals per texel along each axis.
pub const SUBSAMPLES: u32 = 2;

/// Normals tilted this little from the macro-surface are replaced by it (`perturb_normal` in
/// common/scene.wgsl does the same, so the histogram and the path tracer agree).
const MIN_COSINE: f32 = 0.01;

/// The cumulative normal histogram of one normal map at one normal scale.
#[derive(Clone, Debug)]
pub struct NormalHistogram {
    pub width: u32,
    pub height: u32,
    /// Bins along each axis of the projected disc (K; K² bins in all).
    pub bins: u32,
    /// Radius of the binned part of the projected disc: no normal tilts further.
    pub radius: f32,
    /// `sat[((y − 1) · width + (x − 1)) · K² + b]`: normals of bin b over texels [0, x) × [0, y), for
    /// x in 1..=width, y in 1..=height (zero on the first row and column, which are not stored).
    pub sat: Vec<u32>,
    /// Per bin, the mean of the map's micronormals in it (the cell's centre where it has none): what
    /// a bin's normals are shaded with. Closer to them than the centre, for maps with few distinct
    /// normals (flakes) much closer.
    pub bin_normals: Vec<Vec3>,
}

/// The tangent-space normal of an RGBA8 normal map (glTF convention) at texel-space point `p` (texel
/// centres at half-integers), read as the GPU's bilinear, repeating sampler reads it, with the normal
/// scale applied: `perturb_normal`'s tangent-space normal.
pub fn bilinear_normal(rgba8: &[u8], size: u32, p: Vec2, normal_scale: f32) -> Vec3 {
    let q = p - 0.5;
    let (x0, y0) = (q.x.floor(), q.y.floor());
    let (fx, fy) = (q.x - x0, q.y - y0);
    let texel = |x: f32, y: f32| {
        let (x, y) = ((x as i64).rem_euclid(size as i64), (y as i64).rem_euclid(size as i64));
        let i = ((y * size as i64 + x) * 4) as usize;
        Vec3::new(rgba8[i] as f32, rgba8[i + 1] as f32, rgba8[i + 2] as f32) / 255.0
    };
    let v = texel(x0, y0) * (1.0 - fx) * (1.0 - fy)
        + texel(x0 + 1.0, y0) * fx * (1.0 - fy)
        + texel(x0, y0 + 1.0) * (1.0 - fx) * fy
        + texel(x0 + 1.0, y0 + 1.0) * fx * fy;
    let t = v * 2.0 - 1.0;
    let n = Vec3::new(t.x * normal_scale, t.y * normal_scale, t.z).normalize_or_zero();
    if n.z > MIN_COSINE { n } else { Vec3::Z }
}

impl NormalHistogram {
    /// Builds the histogram of a square RGBA8 normal map of side `size` with `bins` × `bins` bins.
    pub fn build(rgba8: &[u8], size: u32, normal_scale: f32, bins: u32) -> Self {
        let s = SUBSAMPLES;
        let n = size as usize;
        let mut normals = Vec::with_capacity(n * n * (s * s) as usize);
        for y in 0..size {
            for x in 0..size {
                for j in 0..s {
                    for i in 0..s {
                        let p = Vec2::new(
                            x as f32 + (i as f32 + 0.5) / s as f32,
                            y as f32 + (j as f32 + 0.5) / s as f32,
                        );
                        normals.push(bilinear_normal(rgba8, size, p, normal_scale));
                    }
                }
            }
        }
        let tilt = normals.iter().map(|v| v.truncate().length()).fold(0.0f32, f32::max);
        // A little margin so the most tilted normal is inside the last cell, at least one cell wide.
        let radius = ((tilt * 1.001 * 64.0).ceil() / 64.0).clamp(1.0 / 64.0, 1.0);
        let bin_count = (bins * bins) as usize;
        let stored = stored_bins(bins) as usize;
        let mut sat = vec![0u32; n * n * stored];
        let per_texel = (s * s) as usize;
        for y in 0..n {
            for x in 0..n {
                let cell = (y * n + x) * stored;
                for v in &normals[(y * n + x) * per_texel..(y * n + x + 1) * per_texel] {
                    let bin = bin_of(*v, radius, bins) as usize;
                    sat[cell + bin] += 1;
                    sat[cell + bin_count + bin / bins as usize] += 1;
                }
                // Summed over the rectangle: add the texels above and to the left, minus their overlap.
                for b in 0..stored {
                    let mut c = sat[cell + b];
                    if x > 0 {
                        c = c.wrapping_add(sat[cell - stored + b]);
                    }
                    if y > 0 {
                        c = c.wrapping_add(sat[cell - n * stored + b]);
                    }
                    if x > 0 && y > 0 {
                        c = c.wrapping_sub(sat[cell - (n + 1) * stored + b]);
                    }
                    sat[cell + b] = c;
                }
            }
        }
        let mut sums = vec![Vec3::ZERO; bin_count];
        for v in &normals {
            sums[bin_of(*v, radius, bins) as usize] += *v;
        }
        let bin_normals = sums
            .iter()
            .enumerate()
            .map(|(b, sum)| sum.try_normalize().unwrap_or_else(|| bin_centre(b as u32, radius, bins)))
            .collect();
        NormalHistogram { width: size, height: size, bins, radius, sat, bin_normals }
    }

    /// The bins of normals (K²); [`stored_bins`] also counts the rows.
    pub fn bin_count(&self) -> u32 {
        self.bins * self.bins
    }

    pub fn bytes(&self) -> u64 {
        self.sat.len() as u64 * 4
    }

    /// Normals per texel.
    pub fn weight_per_texel(&self) -> u32 {
        SUBSAMPLES * SUBSAMPLES
    }

    fn stored(&self, x: u32, y: u32, bin: u32) -> u32 {
        if x == 0 || y == 0 {
            return 0;
        }
        self.sat[(((y - 1) * self.width + (x - 1)) * stored_bins(self.bins) + bin) as usize]
    }

    /// Normals in `bin` over texels [0, x) × [0, y) of the map tiled over the plane (x, y any
    /// integers): whole periods times the map's totals plus the remainder, in wrap-around arithmetic
    /// (a box's count, a difference of four of these, is exact whenever it is below 2³²).
    pub fn cumulative(&self, x: i64, y: i64, bin: u32) -> u32 {
        let (w, h) = (self.width as i64, self.height as i64);
        let (qx, qy) = (x.div_euclid(w), y.div_euclid(h));
        let (rx, ry) = (x.rem_euclid(w) as u32, y.rem_euclid(h) as u32);
        let (qx, qy) = (qx as u32, qy as u32);
        let mut c = self.stored(rx, ry, bin);
        c = c.wrapping_add(qx.wrapping_mul(self.stored(self.width, ry, bin)));
        c = c.wrapping_add(qy.wrapping_mul(self.stored(rx, self.height, bin)));
        c.wrapping_add(qx.wrapping_mul(qy).wrapping_mul(self.stored(self.width, self.height, bin)))
    }

    /// The histogram of texels [x0, x1) × [y0, y1) of the tiled map: its K² bins, then its K rows.
    pub fn box_counts(&self, x0: i64, y0: i64, x1: i64, y1: i64) -> Vec<u32> {
        (0..stored_bins(self.bins))
            .map(|b| {
                self.cumulative(x1, y1, b)
                    .wrapping_sub(self.cumulative(x0, y1, b))
                    .wrapping_sub(self.cumulative(x1, y0, b))
                    .wrapping_add(self.cumulative(x0, y0, b))
            })
            .collect()
    }

    /// Normals in `bin` over the box [lo, hi) of texel space with real corners, each texel's normals
    /// spread evenly over it (texels partly inside count in proportion): the CPU twin of `box_count`
    /// in glints.wgsl, computed the same way (whole counts in wrap-around arithmetic, the fractional
    /// rest from small differences).
    pub fn box_count(&self, lo: Vec2, hi: Vec2, bin: u32) -> f32 {
        let corner = |p: Vec2| {
            let (x, y) = (p.x.floor() as i64, p.y.floor() as i64);
            let (fx, fy) = (p.x - p.x.floor(), p.y - p.y.floor());
            let c00 = self.cumulative(x, y, bin);
            let mut rest = 0.0;
            if fx > 0.0 || fy > 0.0 {
                let c10 = self.cumulative(x + 1, y, bin);
                let c01 = self.cumulative(x, y + 1, bin);
                let c11 = self.cumulative(x + 1, y + 1, bin);
                let dx = c10.wrapping_sub(c00) as i32 as f32;
                let dy = c01.wrapping_sub(c00) as i32 as f32;
                let dxy = c11.wrapping_sub(c10).wrapping_sub(c01).wrapping_add(c00) as i32 as f32;
                rest = fx * dx + fy * dy + fx * fy * dxy;
            }
            (c00, rest)
        };
        let (a, b, c, d) =
            (corner(hi), corner(Vec2::new(lo.x, hi.y)), corner(Vec2::new(hi.x, lo.y)), corner(lo));
        let whole = a.0.wrapping_sub(b.0).wrapping_sub(c.0).wrapping_add(d.0);
        whole as f32 + (a.1 - b.1 - c.1 + d.1)
    }
}

/// Counts stored per texel with `bins` bins along each axis: the K² bins, then the K rows of bins
/// (normals with the same y cell), which let a footprint skip whole empty rows at once.
pub fn stored_bins(bins: u32) -> u32 {
    bins * bins + bins
}

/// The bin of tangent-space normal `n` (CPU twin of the binning the histogram was built with).
pub fn bin_of(n: Vec3, radius: f32, bins: u32) -> u32 {
    let cell =
        |c: f32| (((c / radius + 1.0) * 0.5 * bins as f32).floor() as i64).clamp(0, bins as i64 - 1) as u32;
    cell(n.y) * bins + cell(n.x)
}

/// The unit normal at the centre of a bin; cells whose centre lies off the unit disc map to its rim.
pub fn bin_centre(bin: u32, radius: f32, bins: u32) -> Vec3 {
    let (i, j) = (bin % bins, bin / bins);
    let c = |k: u32| ((k as f32 + 0.5) / bins as f32 * 2.0 - 1.0) * radius;
    let xy = Vec2::new(c(i), c(j));
    let r2 = xy.length_squared();
    if r2 >= 1.0 { (xy / r2.sqrt()).extend(0.0) } else { xy.extend((1.0 - r2).sqrt()) }
}
