//! Geometry helpers shared by the built-in scenes.
//!
//! Everything is accumulated in a [`MeshBuilder`] (positions, normals, UVs, indices) and turned into a
//! [`Mesh`] at the end, so tangents are always generated from the final UV layout. Conventions: triangles are
//! counter-clockwise seen from the side the normal points to, and UVs are in metres times a caller-chosen
//! scale, so a tiling texture has the same physical size on every surface that shares it.

use std::f32::consts::{PI, TAU};

use glam::{Vec2, Vec3};

use crate::scene::Mesh;

/// Vertex and index lists under construction.
#[derive(Clone, Debug, Default)]
pub struct MeshBuilder {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub indices: Vec<u32>,
}

/// Number of cells of at most `cell` metres that cover `length` metres (at least one).
pub fn cells(length: f32, cell: f32) -> u32 {
    ((length / cell).ceil() as u32).max(1)
}

impl MeshBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn vertex(&mut self, position: Vec3, normal: Vec3, uv: Vec2) -> u32 {
        let index = self.positions.len() as u32;
        self.positions.push(position);
        self.normals.push(normal);
        self.uvs.push(uv);
        index
    }

    pub fn triangle(&mut self, a: u32, b: u32, c: u32) {
        self.indices.extend([a, b, c]);
    }

    /// Finishes the mesh; tangents come from the UV layout.
    pub fn build(self, name: &str, material: u32) -> Mesh {
        Mesh::with_generated_tangents(name, self.positions, self.normals, self.uvs, self.indices, material)
    }

    /// Adds two triangles `(a, b, c)` and `(a, c, d)`, skipping one whose corners coincide (grids that
    /// collapse to a point, such as sphere poles, would otherwise produce zero-area triangles).
    fn grid_cell(&mut self, [a, b, c, d]: [u32; 4]) {
        for [p, q, r] in [[a, b, c], [a, c, d]] {
            let [pp, pq, pr] = [p, q, r].map(|i| self.positions[i as usize]);
            if pp != pq && pq != pr && pr != pp {
                self.triangle(p, q, r);
            }
        }
    }

    /// A flat parallelogram `origin + s·edge_u + t·edge_v` (s, t in [0, 1]) split into `nu × nv` cells.
    /// It faces `edge_u × edge_v`; the texture's u runs along `edge_u`.
    pub fn grid(&mut self, origin: Vec3, edge_u: Vec3, edge_v: Vec3, nu: u32, nv: u32, uv_per_metre: f32) {
        let normal = edge_u.cross(edge_v).normalize();
        let base = self.positions.len() as u32;
        let (len_u, len_v) = (edge_u.length() * uv_per_metre, edge_v.length() * uv_per_metre);
        for j in 0..=nv {
            let t = j as f32 / nv as f32;
            for i in 0..=nu {
                let s = i as f32 / nu as f32;
                self.vertex(origin + edge_u * s + edge_v * t, normal, Vec2::new(s * len_u, t * len_v));
            }
        }
        let row = nu + 1;
        for j in 0..nv {
            for i in 0..nu {
                let a = base + j * row + i;
                self.grid_cell([a, a + 1, a + row + 1, a + row]);
            }
        }
    }

    /// [`Self::grid`] with square-ish cells of at most `cell` metres.
    pub fn grid_cells(&mut self, origin: Vec3, edge_u: Vec3, edge_v: Vec3, cell: f32, uv_per_metre: f32) {
        let (nu, nv) = (cells(edge_u.length(), cell), cells(edge_v.length(), cell));
        self.grid(origin, edge_u, edge_v, nu, nv, uv_per_metre);
    }

    /// An axis-aligned rectangle in a plane of constant `axis` coordinate, facing `facing` (±1 along
    /// `axis`), with UVs in metres. `min` and `max` are in the plane's other two axes in cyclic order:
    /// (y, z) for x = const, (z, x) for y = const, (x, y) for z = const. Spares callers working out which
    /// edge order gives the wanted side.
    pub fn axis_rect(&mut self, axis: usize, at: f32, min: Vec2, max: Vec2, facing: f32, cell: f32) {
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        let mut origin = Vec3::ZERO;
        origin[axis] = at;
        origin[a] = min.x;
        origin[b] = min.y;
        let mut eu = Vec3::ZERO;
        eu[a] = max.x - min.x;
        let mut ev = Vec3::ZERO;
        ev[b] = max.y - min.y;
        // e_a × e_b = +e_axis for a cyclic (axis, a, b); swap the edges for the other side.
        if facing > 0.0 {
            self.grid_cells(origin, eu, ev, cell, 1.0);
        } else {
            self.grid_cells(origin, ev, eu, cell, 1.0);
        }
    }

    /// A horizontal grid at height `y` on the lattice `xs × zs` (sorted coordinates), keeping the cells whose
    /// centre passes `keep`. Neighbouring cells share vertices, so shapes with holes (a floor around a
    /// courtyard) have no T-junctions, which would open pixel-sized cracks; unused lattice points are not
    /// emitted.
    pub fn horizontal_lattice(
        &mut self,
        y: f32,
        xs: &[f32],
        zs: &[f32],
        facing_up: bool,
        uv_per_metre: f32,
        keep: impl Fn(Vec2) -> bool,
    ) {
        let normal = if facing_up { Vec3::Y } else { Vec3::NEG_Y };
        let mut index = vec![u32::MAX; xs.len() * zs.len()];
        let mut vertex = |b: &mut Self, i: usize, j: usize| {
            let slot = &mut index[j * xs.len() + i];
            if *slot == u32::MAX {
                let uv = Vec2::new(xs[i], zs[j]) * uv_per_metre;
                *slot = b.vertex(Vec3::new(xs[i], y, zs[j]), normal, uv);
            }
            *slot
        };
        for j in 0..zs.len().saturating_sub(1) {
            for i in 0..xs.len().saturating_sub(1) {
                if !keep(Vec2::new(xs[i] + xs[i + 1], zs[j] + zs[j + 1]) * 0.5) {
                    continue;
                }
                let [a, b, c, d] =
                    [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)].map(|(i, j)| vertex(self, i, j));
                // Walking +x then +z turns clockwise seen from above.
                self.grid_cell(if facing_up { [a, d, c, b] } else { [a, b, c, d] });
            }
        }
    }

    /// A convex planar polygon (fan-triangulated) with one flat normal, oriented so it faces `facing`.
    /// The corners may come in either winding, as published data often does.
    pub fn polygon(&mut self, corners: &[Vec3], facing: Vec3, uv_per_metre: f32) {
        // Newell's normal is the best-fit plane normal, robust to slightly non-planar published quads.
        let mut n = Vec3::ZERO;
        for (i, p) in corners.iter().enumerate() {
            let q = corners[(i + 1) % corners.len()];
            n += Vec3::new((p.y - q.y) * (p.z + q.z), (p.z - q.z) * (p.x + q.x), (p.x - q.x) * (p.y + q.y));
        }
        let mut ordered = corners.to_vec();
        if n.dot(facing) < 0.0 {
            ordered.reverse();
            n = -n;
        }
        let n = n.normalize();
        let u_axis = (ordered[1] - ordered[0]).reject_from(n).normalize();
        let v_axis = n.cross(u_axis);
        let base = self.positions.len() as u32;
        for p in &ordered {
            let d = *p - ordered[0];
            self.vertex(*p, n, Vec2::new(d.dot(u_axis), d.dot(v_axis)) * uv_per_metre);
        }
        for i in 1..ordered.len() as u32 - 1 {
            self.triangle(base, base + i, base + i + 1);
        }
    }

    /// A box with flat faces (separate vertices per face), given its centre and three orthogonal
    /// half-extent vectors. `outward` false turns it into a room seen from inside.
    pub fn cuboid(&mut self, center: Vec3, half: [Vec3; 3], outward: bool, cell: f32, uv_per_metre: f32) {
        for k in 0..3 {
            for sign in [1.0f32, -1.0] {
                let facing = half[k] * if outward { sign } else { -sign };
                let (mut eu, mut ev) = (half[(k + 1) % 3] * 2.0, half[(k + 2) % 3] * 2.0);
                if eu.cross(ev).dot(facing) < 0.0 {
                    std::mem::swap(&mut eu, &mut ev);
                }
                let origin = center + half[k] * sign - (eu + ev) * 0.5;
                self.grid_cells(origin, eu, ev, cell, uv_per_metre);
            }
        }
    }

    /// An axis-aligned box from `min` to `max` with outward faces.
    pub fn aabb(&mut self, min: Vec3, max: Vec3, uv_per_metre: f32) {
        let h = (max - min) * 0.5;
        let half = [Vec3::X * h.x, Vec3::Y * h.y, Vec3::Z * h.z];
        self.cuboid((min + max) * 0.5, half, true, f32::INFINITY, uv_per_metre);
    }

    /// A smooth parametric surface sampled on a `(nu+1) × (nv+1)` vertex grid. `position(i, j)` gives the
    /// vertices; the front side is `∂P/∂i × ∂P/∂j`. Normals are the area-weighted average of the adjacent
    /// faces, which needs no analytic derivative and stays correct for wavy or fluted shapes. With `wrap_u`
    /// the columns `i = 0` and `i = nu` must coincide (a closed loop): they keep separate UVs (the texture
    /// seam) but share their normal so the seam is invisible in shading.
    pub fn surface(
        &mut self,
        nu: u32,
        nv: u32,
        wrap_u: bool,
        position: impl Fn(u32, u32) -> Vec3,
        uv: impl Fn(u32, u32) -> Vec2,
    ) {
        let base = self.positions.len() as u32;
        let row = nu + 1;
        for j in 0..=nv {
            for i in 0..=nu {
                self.vertex(position(i, j), Vec3::ZERO, uv(i, j));
            }
        }
        let first_index = self.indices.len();
        for j in 0..nv {
            for i in 0..nu {
                let a = base + j * row + i;
                self.grid_cell([a, a + 1, a + row + 1, a + row]);
            }
        }
        for tri in self.indices[first_index..].chunks_exact(3) {
            let [a, b, c] = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
            let n = (self.positions[b] - self.positions[a]).cross(self.positions[c] - self.positions[a]);
            for v in [a, b, c] {
                self.normals[v] += n;
            }
        }
        if wrap_u {
            for j in 0..=nv {
                let (first, last) = ((base + j * row) as usize, (base + j * row + nu) as usize);
                let sum = self.normals[first] + self.normals[last];
                self.normals[first] = sum;
                self.normals[last] = sum;
            }
        }
        for n in &mut self.normals[base as usize..] {
            // A vertex only in skipped (degenerate) triangles keeps a valid, if arbitrary, normal.
            *n = n.try_normalize().unwrap_or(Vec3::Y);
        }
    }

    /// A UV sphere with analytic normals (the face average is visibly faceted near the poles). u wraps
    /// once around +Y, v runs from the north pole (0) to the south pole; `uv_scale` multiplies both.
    pub fn uv_sphere(&mut self, center: Vec3, radius: f32, segments: u32, rings: u32, uv_scale: Vec2) {
        let base = self.positions.len() as u32;
        let row = segments + 1;
        for j in 0..=rings {
            let theta = PI * j as f32 / rings as f32;
            // Exact poles, so the pole triangles collapse exactly and are skipped.
            let (sin_t, cos_t) = match j {
                0 => (0.0, 1.0),
                _ if j == rings => (0.0, -1.0),
                _ => theta.sin_cos(),
            };
            for i in 0..=segments {
                let phi = TAU * (i % segments) as f32 / segments as f32;
                let (sin_p, cos_p) = phi.sin_cos();
                // φ grows counter-clockwise seen from +Y (from +X towards −Z), so ∂P/∂θ × ∂P/∂φ points out.
                let n = Vec3::new(sin_t * cos_p, cos_t, -sin_t * sin_p);
                let uv = Vec2::new(i as f32 / segments as f32, j as f32 / rings as f32) * uv_scale;
                self.vertex(center + n * radius, n, uv);
            }
        }
        for j in 0..rings {
            for i in 0..segments {
                let a = base + j * row + i;
                // Columns grow with φ, rows with θ (downwards): a → a+row → a+row+1 is counter-clockwise
                // seen from outside.
                self.grid_cell([a, a + row, a + row + 1, a + 1]);
            }
        }
    }

    /// An upright cylinder (axis +Y) from `base_center` to `height` above it, with analytic side normals
    /// and flat caps. UVs in metres times `uv_per_metre`.
    pub fn cylinder(
        &mut self,
        base_center: Vec3,
        radius: f32,
        height: f32,
        segments: u32,
        caps: bool,
        uv_per_metre: f32,
    ) {
        let circumference = TAU * radius;
        let rings = cells(height, circumference / segments as f32 * 2.0);
        self.surface(
            segments,
            rings,
            true,
            |i, j| {
                let phi = TAU * (i % segments) as f32 / segments as f32;
                base_center
                    + Vec3::new(radius * phi.cos(), height * j as f32 / rings as f32, -radius * phi.sin())
            },
            |i, j| {
                Vec2::new(
                    circumference * i as f32 / segments as f32,
                    height * (1.0 - j as f32 / rings as f32),
                ) * uv_per_metre
            },
        );
        if caps {
            for (y, facing) in [(height, Vec3::Y), (0.0, Vec3::NEG_Y)] {
                let ring: Vec<Vec3> = (0..segments)
                    .map(|i| {
                        let phi = TAU * i as f32 / segments as f32;
                        base_center + Vec3::new(radius * phi.cos(), y, -radius * phi.sin())
                    })
                    .collect();
                self.polygon(&ring, facing, uv_per_metre);
            }
        }
    }
}

/// Sorted grid coordinates through every value of `breaks` (sorted), each interval split into equal cells
/// of at most `cell`.
pub fn subdivide(breaks: &[f32], cell: f32) -> Vec<f32> {
    let mut out = breaks[..1.min(breaks.len())].to_vec();
    for w in breaks.windows(2) {
        let n = cells(w[1] - w[0], cell);
        out.extend((1..n).map(|k| w[0] + (w[1] - w[0]) * k as f32 / n as f32));
        out.push(w[1]);
    }
    out
}

/// A small integer hash (lowbias32 by Chris Wellons): deterministic pseudo-randomness without an RNG.
pub fn hash(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// [`hash`] of a few integers mapped to [0, 1).
pub fn hash_unit(values: &[u32]) -> f32 {
    let h = values.iter().fold(0x9e37_79b9u32, |acc, &v| hash(acc ^ v.wrapping_add(0x632b_e5ab)));
    (h >> 8) as f32 / (1u32 << 24) as f32
}
