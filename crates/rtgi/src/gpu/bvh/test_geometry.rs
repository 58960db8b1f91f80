//! Procedural triangle sets and ray sets for the BVH tests (CPU and GPU).

use std::f32::consts::PI;

use glam::Vec3;

use super::Ray;

/// SplitMix64: a tiny deterministic generator, so test inputs are the same on every run.
pub(crate) struct Rng(u64);

impl Rng {
    pub(crate) fn new(seed: u64) -> Rng {
        Rng(seed)
    }

    pub(crate) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub(crate) fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

    pub(crate) fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }

    pub(crate) fn index(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    pub(crate) fn in_box(&mut self, min: Vec3, max: Vec3) -> Vec3 {
        Vec3::new(self.range(min.x, max.x), self.range(min.y, max.y), self.range(min.z, max.z))
    }

    pub(crate) fn unit_vector(&mut self) -> Vec3 {
        let z = self.range(-1.0, 1.0);
        let phi = self.range(0.0, 2.0 * PI);
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

/// `n` random triangles of random size and orientation in the unit cube (overlapping, intersecting,
/// some slivers).
pub(crate) fn triangle_soup(n: usize, seed: u64) -> Vec<[Vec3; 3]> {
    let mut rng = Rng::new(seed);
    (0..n)
        .map(|i| {
            let c = rng.in_box(Vec3::ZERO, Vec3::ONE);
            // Mostly small, a few large, every 50th a sliver, to exercise the SAH and the leaf cutoff.
            let size = if i % 97 == 0 { 0.3 } else { rng.range(0.005, 0.05) };
            let a = c + rng.unit_vector() * size;
            let b = c + rng.unit_vector() * size;
            let d = if i % 50 == 0 {
                a + (b - a) * 0.5 + rng.unit_vector() * 1e-5
            } else {
                c + rng.unit_vector() * size
            };
            [a, b, d]
        })
        .collect()
}

/// Appends an indexed mesh's triangles.
fn push_indexed(out: &mut Vec<[Vec3; 3]>, positions: &[Vec3], indices: &[[u32; 3]]) {
    out.extend(indices.iter().map(|t| t.map(|i| positions[i as usize])));
}

/// A grid of `n × n` quads (two triangles each) over the parallelogram `origin + s·u + t·v`,
/// `s, t ∈ [0, 1]`, displaced along `normal` by `height(s, t)`. Vertices are shared between
/// neighbouring quads, so every interior edge is shared exactly as in an indexed mesh.
pub(crate) fn grid(
    out: &mut Vec<[Vec3; 3]>,
    n: u32,
    origin: Vec3,
    u: Vec3,
    v: Vec3,
    height: impl Fn(f32, f32) -> f32,
) {
    let normal = u.cross(v).normalize_or_zero();
    let mut positions = Vec::with_capacity(((n + 1) * (n + 1)) as usize);
    for j in 0..=n {
        for i in 0..=n {
            let (s, t) = (i as f32 / n as f32, j as f32 / n as f32);
            positions.push(origin + u * s + v * t + normal * height(s, t));
        }
    }
    let mut indices = Vec::with_capacity((2 * n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            // Alternate the diagonal so shared edges run in several directions.
            if (i + j) % 2 == 0 {
                indices.extend([[a, b, d], [a, d, c]]);
            } else {
                indices.extend([[a, b, c], [b, d, c]]);
            }
        }
    }
    push_indexed(out, &positions, &indices);
}

/// A closed UV sphere of `rings × segments` quads (poles as triangle fans).
pub(crate) fn uv_sphere(out: &mut Vec<[Vec3; 3]>, center: Vec3, radius: f32, rings: u32, segments: u32) {
    let mut positions = vec![center + Vec3::Y * radius];
    for r in 1..rings {
        let theta = PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = 2.0 * PI * s as f32 / segments as f32;
            positions.push(
                center + radius * Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()),
            );
        }
    }
    positions.push(center - Vec3::Y * radius);
    let south = positions.len() as u32 - 1;
    let ring = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    let mut indices = Vec::new();
    for s in 0..segments {
        indices.push([0, ring(1, s + 1), ring(1, s)]);
        indices.push([south, ring(rings - 1, s), ring(rings - 1, s + 1)]);
    }
    for r in 1..rings - 1 {
        for s in 0..segments {
            let (a, b, c, d) = (ring(r, s), ring(r, s + 1), ring(r + 1, s), ring(r + 1, s + 1));
            indices.extend([[a, b, d], [a, d, c]]);
        }
    }
    push_indexed(out, &positions, &indices);
}

/// A closed, finely tessellated box `[min, max]` (inward-facing; orientation does not matter to the
/// test) with a UV sphere inside: many shared edges and vertices, and any ray starting inside the box
/// but outside the sphere must hit something (a miss is a crack).
pub(crate) fn sphere_in_box() -> Vec<[Vec3; 3]> {
    let (min, max) = (Vec3::new(-1.0, -1.0, -1.0), Vec3::new(1.0, 1.5, 1.2));
    let e = max - min;
    let mut out = Vec::new();
    let flat = |_: f32, _: f32| 0.0;
    let (x, y, z) = (Vec3::X * e.x, Vec3::Y * e.y, Vec3::Z * e.z);
    grid(&mut out, 24, min, x, z, flat);
    grid(&mut out, 24, min + y, x, z, flat);
    grid(&mut out, 24, min, x, y, flat);
    grid(&mut out, 24, min + z, x, y, flat);
    grid(&mut out, 24, min, y, z, flat);
    grid(&mut out, 24, min + x, y, z, flat);
    uv_sphere(&mut out, Vec3::new(0.1, 0.2, 0.05), 0.6, 48, 96);
    out
}

/// Interior bounds of [`sphere_in_box`] and its sphere (centre, radius), for watertightness rays.
pub(crate) const SPHERE_IN_BOX: (Vec3, Vec3, Vec3, f32) =
    (Vec3::new(-1.0, -1.0, -1.0), Vec3::new(1.0, 1.5, 1.2), Vec3::new(0.1, 0.2, 0.05), 0.6);

/// A point where only rounding decides which of a triangle's neighbours a ray through it hits: one of
/// `tri`'s vertices exactly (a third of the time) or a point on one of its edges (up to the rounding
/// of a + (b − a)·f).
pub(crate) fn boundary_point(rng: &mut Rng, tri: [Vec3; 3]) -> Vec3 {
    let i = rng.index(3);
    if rng.index(3) == 0 {
        tri[i]
    } else {
        let (a, b) = (tri[i], tri[(i + 1) % 3]);
        a + (b - a) * rng.f32()
    }
}

/// A mesh and rays that must all hit it (see [`crack_scenes`]).
pub(crate) struct CrackScene {
    pub name: &'static str,
    pub tris: Vec<[Vec3; 3]>,
    pub rays: Vec<Ray>,
}

/// Meshes that every ray of [`crack_rays`] must hit, each with those rays: the inside of the closed
/// [`sphere_in_box`] (outside its sphere), the inside of a closed UV sphere (its poles are fans of
/// 48 triangles), and a flat 64 × 64 floor 40 units wide at an offset, the coordinates of a large
/// room, seen from above. Every ray aims exactly at a vertex or at an edge point of a triangle, from
/// close by (a few triangle sizes), where the rounding of edge functions matters most: the farther
/// the origin, the larger an edge function is against the rounding of its products.
pub(crate) fn crack_scenes(n: usize, seed: u64) -> Vec<CrackScene> {
    let mut rng = Rng::new(seed);
    let mut out = Vec::new();

    let tris = sphere_in_box();
    let (lo, hi, center, radius) = SPHERE_IN_BOX;
    let rays = crack_rays(&mut rng, &tris, n, |rng, target| {
        let o = target + rng.unit_vector() * rng.range(0.01, 0.3);
        let inside = o.cmpgt(lo + 0.005).all() && o.cmplt(hi - 0.005).all();
        (inside && (o - center).length() > radius + 0.005).then_some(o)
    });
    out.push(CrackScene { name: "sphere in box", tris, rays });

    // The polyhedron lies within 0.99 radius of the centre everywhere (cos(π/24) ≈ 0.991).
    let (center, radius) = (Vec3::new(0.3, -0.2, 0.1), 1.0);
    let mut tris = Vec::new();
    uv_sphere(&mut tris, center, radius, 24, 48);
    let rays = crack_rays(&mut rng, &tris, n, |rng, target| {
        let o = target + (center - target) * rng.range(0.05, 0.9) + rng.unit_vector() * 0.02;
        ((o - center).length() < 0.95 * radius).then_some(o)
    });
    out.push(CrackScene { name: "inside a sphere", tris, rays });

    let (corner, size) = (Vec3::new(-17.3, 1.1, 31.7), 40.0);
    let mut tris = Vec::new();
    grid(&mut tris, 64, corner, Vec3::X * size, Vec3::NEG_Z * size, |_, _| 0.0);
    let rays = crack_rays(&mut rng, &tris, n, |rng, target| {
        // Off the outer rim, where a ray may pass the floor's edge: only shared edges and vertices.
        let rim = (target.x - corner.x).min(corner.x + size - target.x).min(target.z - (corner.z - size));
        let rim = rim.min(corner.z - target.z);
        let offset = Vec3::new(rng.range(-2.0, 2.0), rng.range(0.05, 3.0), rng.range(-2.0, 2.0));
        (rim > 0.01).then_some(target + offset)
    });
    out.push(CrackScene { name: "floor", tris, rays });
    out
}

/// `n` rays aimed exactly at [`boundary_point`]s of random triangles, from origins `origin` picks
/// for each target (`None`: try another target).
fn crack_rays(
    rng: &mut Rng,
    tris: &[[Vec3; 3]],
    n: usize,
    mut origin: impl FnMut(&mut Rng, Vec3) -> Option<Vec3>,
) -> Vec<Ray> {
    let mut rays = Vec::with_capacity(n);
    while rays.len() < n {
        let tri = tris[rng.index(tris.len())];
        let target = boundary_point(rng, tri);
        if let Some(o) = origin(rng, target) {
            rays.push(Ray::new(o, target - o));
        }
    }
    rays
}

/// Appends an axis-aligned box as 12 triangles.
fn push_box(out: &mut Vec<[Vec3; 3]>, min: Vec3, max: Vec3) {
    let p = |i: u32| {
        Vec3::new(
            if i & 1 != 0 { max.x } else { min.x },
            if i & 2 != 0 { max.y } else { min.y },
            if i & 4 != 0 { max.z } else { min.z },
        )
    };
    let faces = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    for [a, b, c, d] in faces {
        out.push([p(a), p(b), p(c)]);
        out.push([p(a), p(c), p(d)]);
    }
}

/// A "city" of at least `min_triangles`: a displaced terrain grid with one tenth of the triangles,
/// the rest as boxes (buildings) standing on it, some floating and overlapping. About 1.2 M
/// triangles build in ~1 s; large enough to stress the build, the node layout and the GPU buffers.
pub(crate) fn city(min_triangles: usize, seed: u64) -> Vec<[Vec3; 3]> {
    let mut rng = Rng::new(seed);
    let size = 200.0;
    let n = (((min_triangles / 10) as f32 / 2.0).sqrt().ceil() as u32).max(2);
    let height =
        |s: f32, t: f32| 2.0 * (s * 17.0).sin() * (t * 13.0).cos() + 0.5 * (s * 71.0 + t * 53.0).sin();
    let mut out = Vec::with_capacity(min_triangles + 12);
    grid(&mut out, n, Vec3::new(-size / 2.0, 0.0, size / 2.0), Vec3::X * size, Vec3::NEG_Z * size, height);
    while out.len() < min_triangles {
        let (s, t) = (rng.f32(), rng.f32());
        let base = Vec3::new(-size / 2.0 + s * size, height(s, t) - 0.5, size / 2.0 - t * size);
        let footprint = Vec3::new(rng.range(0.2, 3.0), 0.0, rng.range(0.2, 3.0));
        let tall = rng.range(0.5, 1.0).powi(8) * 40.0 + 1.0;
        let lift = if rng.f32() < 0.1 { rng.range(2.0, 20.0) } else { 0.0 };
        let min = base + Vec3::Y * lift;
        push_box(&mut out, min, min + footprint + Vec3::Y * tall);
    }
    out
}

/// Bounds of a triangle list.
pub(crate) fn bounds(triangles: &[[Vec3; 3]]) -> (Vec3, Vec3) {
    triangles
        .iter()
        .flatten()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
}

/// What a test ray is meant to exercise; the reports break mismatches down by kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub(crate) enum RayKind {
    /// From outside the bounds towards a random point inside.
    Outside,
    /// From a random point inside the bounds in a random direction.
    Inside,
    /// From outside the bounding sphere, pointing away from it: must miss.
    Miss,
    /// Towards a triangle vertex or edge point: hits shared edges and vertices exactly.
    Vertex,
    /// Axis-aligned directions (zero direction components).
    Axis,
}

/// A test ray with its interval.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TestRay {
    pub ray: Ray,
    pub tmin: f32,
    pub tmax: f32,
    pub kind: RayKind,
}

/// `n` random rays of every [`RayKind`] for `triangles`; a third of the finite-interval rays get a
/// random `tmax` (which cuts some hits) and some a positive `tmin`.
pub(crate) fn test_rays(triangles: &[[Vec3; 3]], n: usize, seed: u64) -> Vec<TestRay> {
    let mut rng = Rng::new(seed);
    let (lo, hi) = bounds(triangles);
    let center = (lo + hi) * 0.5;
    let radius = (hi - lo).length() * 0.5;
    let kinds =
        [RayKind::Outside, RayKind::Inside, RayKind::Inside, RayKind::Miss, RayKind::Vertex, RayKind::Axis];
    (0..n)
        .map(|i| {
            let kind = kinds[i % kinds.len()];
            let (origin, dir) = match kind {
                RayKind::Outside => {
                    let o = center + rng.unit_vector() * radius * 1.5;
                    (o, rng.in_box(lo, hi) - o)
                }
                RayKind::Inside => (rng.in_box(lo, hi), rng.unit_vector()),
                RayKind::Miss => {
                    let out = rng.unit_vector();
                    let o = center + out * radius * rng.range(1.01, 3.0);
                    // Any direction with a positive component along `out` moves away from the sphere.
                    let d = (out + rng.unit_vector() * 0.9).normalize();
                    (o, if d.dot(out) > 0.0 { d } else { out })
                }
                RayKind::Vertex => {
                    let tri = triangles[rng.index(triangles.len())];
                    let target = match rng.index(3) {
                        0 => tri[rng.index(3)],
                        _ => {
                            let (a, b) = (tri[rng.index(3)], tri[rng.index(3)]);
                            a + (b - a) * rng.f32()
                        }
                    };
                    let o = if rng.f32() < 0.5 {
                        rng.in_box(lo, hi)
                    } else {
                        center + rng.unit_vector() * radius * 1.5
                    };
                    (o, target - o)
                }
                RayKind::Axis => {
                    let axis = Vec3::AXES[rng.index(3)] * if rng.f32() < 0.5 { 1.0 } else { -1.0 };
                    (rng.in_box(lo, hi), axis)
                }
            };
            let (tmin, tmax) = match (kind, rng.index(6)) {
                (RayKind::Miss, _) | (_, 0..=2) => (0.0, f32::MAX),
                (_, 3) => (0.0, rng.range(0.0, 1.0) * radius * 2.0 / dir.length()),
                (_, 4) => (rng.range(0.0, 0.5) * radius / dir.length(), f32::MAX),
                _ => (1e-4, f32::INFINITY),
            };
            TestRay { ray: Ray::new(origin, dir), tmin, tmax, kind }
        })
        .collect()
}

/// A pinhole camera's primary rays over `triangles` (`w × h`, row by row): coherent rays.
pub(crate) fn camera_rays(triangles: &[[Vec3; 3]], w: u32, h: u32) -> Vec<Ray> {
    let (lo, hi) = bounds(triangles);
    let center = (lo + hi) * 0.5;
    let eye = center + Vec3::new(0.3, 0.25, 0.6) * (hi - lo).length() * 0.6;
    let fwd = (center - eye).normalize();
    let right = fwd.cross(Vec3::Y).normalize();
    let up = right.cross(fwd);
    let tan = (30f32).to_radians().tan();
    let mut rays = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let sx = (2.0 * (x as f32 + 0.5) / w as f32 - 1.0) * tan * w as f32 / h as f32;
            let sy = (1.0 - 2.0 * (y as f32 + 0.5) / h as f32) * tan;
            rays.push(Ray::new(eye, (fwd + right * sx + up * sy).normalize()));
        }
    }
    rays
}

/// A scene for the two-level BVH: [`sphere_in_box`] (static) plus meshes that are instances: spheres
/// and soup clusters built around the origin, one of them empty, one mirrored, one scaled to nothing
/// (never hit). Returns (the scene's triangles as uploaded, which meshes move, per instance the map
/// from its uploaded geometry to where it is, and the world-space triangles for brute force).
pub(crate) struct InstancedScene {
    pub tris: super::SceneTriangles,
    pub moving: Vec<bool>,
    pub transforms: Vec<glam::Mat4>,
    pub world: Vec<[Vec3; 3]>,
}

pub(crate) fn instanced_scene(seed: u64) -> InstancedScene {
    use glam::{Mat4, Quat};
    let mut rng = Rng::new(seed);
    let mut meshes: Vec<(Vec<[Vec3; 3]>, bool)> = vec![(sphere_in_box(), false)];
    // A static mesh after the moving ones too, so the static bottom level is not one contiguous range.
    let mut sphere = Vec::new();
    uv_sphere(&mut sphere, Vec3::ZERO, 0.25, 12, 24);
    for i in 0..6 {
        let mesh = match i {
            2 => Vec::new(),
            3 => triangle_soup(400, seed ^ 7)
                .into_iter()
                .map(|t| t.map(|v| v * 0.3 - Vec3::splat(0.15)))
                .collect(),
            _ => sphere.clone(),
        };
        meshes.push((mesh, true));
    }
    let mut clutter = Vec::new();
    uv_sphere(&mut clutter, Vec3::new(-0.6, -0.6, 0.8), 0.2, 8, 16);
    meshes.push((clutter, false));

    let mut tris = super::SceneTriangles::default();
    for (mesh, _) in &meshes {
        tris.mesh_offsets.push(tris.triangles.len() as u32);
        tris.triangles.extend_from_slice(mesh);
    }
    tris.mesh_offsets.push(tris.triangles.len() as u32);
    tris.alpha_tested = (0..tris.triangles.len()).map(|i| i % 2 == 1).collect();
    let moving: Vec<bool> = meshes.iter().map(|(_, m)| *m).collect();

    let mut transforms = Vec::new();
    let mut world = tris.triangles.clone();
    let mut instance = 0;
    for (m, (mesh, moves)) in meshes.iter().enumerate() {
        if !moves || mesh.is_empty() {
            continue;
        }
        let rotation = Quat::from_axis_angle(rng.unit_vector(), rng.range(0.0, 6.0));
        let scale = match instance {
            1 => Vec3::new(-1.2, 0.8, 1.0), // mirrored, non-uniform
            4 => Vec3::ZERO,                // scaled to nothing
            _ => Vec3::splat(rng.range(0.6, 1.6)),
        };
        let translation = rng.in_box(Vec3::new(-0.6, -0.6, -0.6), Vec3::new(0.6, 1.1, 0.8));
        let t = Mat4::from_scale_rotation_translation(scale, rotation, translation);
        let range = tris.mesh_offsets[m] as usize..tris.mesh_offsets[m + 1] as usize;
        for tri in &mut world[range] {
            *tri = tri.map(|v| t.transform_point3(v));
        }
        transforms.push(t);
        instance += 1;
    }
    InstancedScene { tris, moving, transforms, world }
}
