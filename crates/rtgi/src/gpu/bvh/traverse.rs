//! CPU traversal, mirroring `shaders/common/bvh.wgsl` operation for operation: the GPU result is
//! checked against it, and CPU-side references (tests, metrics) need the same notion of "hit".

use glam::Vec3;

use super::{BVH_STACK_SIZE, BVH_WIDTH, Bvh, BvhNode, Child, Hit, Ray, node_ref};

/// Exit distances of box tests are scaled by 1 + 16u (u = 2^-24) so that rounding never culls a box
/// the ray touches, e.g. a triangle lying in its box's face: Ize 2013 ("Robust BVH Ray Traversal")
/// with a reciprocal good to 2.5 ulp, which is all WGSL promises for `bvh.wgsl`'s twin (see there).
pub(crate) const BOX_EXIT_SCALE: f32 = 1.000_001;
/// Direction components smaller than this are replaced by ±this before inverting, keeping the slab
/// test free of inf × 0 = NaN.
pub(crate) const MIN_DIR_COMPONENT: f32 = 1e-20;

/// How the WGSL `fma` builtin is evaluated, and (as hooks for tests) the product difference and edge
/// functions built on it. The traversal is generic over it so that tests can run it as a GPU that
/// splits `fma` would, under other contractions, or with the old edge function as a counter-example;
/// everything else uses [`Fused`], monomorphised like hand-written code.
pub(crate) trait Arithmetic {
    fn fma(a: f32, b: f32, c: f32) -> f32;

    /// a·b − c·d as `bvh.wgsl` writes it, `fma(a, b, −(c·d))`.
    #[inline(always)]
    fn diff(a: f32, b: f32, c: f32, d: f32) -> f32 {
        Self::fma(a, b, -(c * d))
    }

    /// The edge function of the edge p → q, q.x·p.y − q.y·p.x: `bvh_edges`, which explains why it is
    /// evaluated on sorted endpoints (exactly antisymmetric whatever a compiler does to it).
    #[inline(always)]
    fn edge(px: f32, py: f32, qx: f32, qy: f32) -> f32 {
        if px == qx && py == qy {
            return 0.0;
        }
        let swap = px > qx || (px == qx && py > qy);
        let (lo_x, lo_y, hi_x, hi_y) = if swap { (qx, qy, px, py) } else { (px, py, qx, qy) };
        let e = Self::diff(hi_x, lo_y, hi_y, lo_x);
        if swap { -e } else { e }
    }
}

/// IEEE fused multiply-add, as GPUs evaluate WGSL's `fma` (checked on the test device by
/// `bvh_gpu_arithmetic_matches_the_cpu_twin`).
pub(crate) struct Fused;

impl Arithmetic for Fused {
    #[inline(always)]
    fn fma(a: f32, b: f32, c: f32) -> f32 {
        a.mul_add(b, c)
    }
}

/// WGSL's `fma` as an implementation may evaluate it: a multiply and an add, each rounded (WGSL
/// allows this). Tests compare a GPU with this arithmetic with the CPU twin in it.
#[cfg(test)]
pub(crate) struct Unfused;

#[cfg(test)]
impl Arithmetic for Unfused {
    #[inline(always)]
    fn fma(a: f32, b: f32, c: f32) -> f32 {
        a * b + c
    }
}

/// Per-ray constants of the watertight test (Woop, Benthin & Wald 2013) in `bvh.wgsl`'s form (see
/// `BvhRay` there): the columns of the map into the ray's frame (axes permuted, x and y scaled by the
/// dominant direction component instead of sheared by divisions) and the safe inverse direction.
#[derive(Clone)]
pub(crate) struct RayData {
    origin: Vec3,
    inv_dir: Vec3,
    m0: Vec3,
    m1: Vec3,
    m2: Vec3,
}

impl RayData {
    pub(crate) fn new(ray: &Ray) -> RayData {
        let d = ray.dir;
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        // Swapping keeps the winding, so the sign of the determinant says which side was hit.
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        // (d[kx], d[ky], d[kz]) times 2^-e for |d[kz]| in [2^e, 2^(e+1)): an exact scaling.
        let scale = f32::from_bits(0x7f00_0000u32.wrapping_sub(d[kz].to_bits() & 0x7f80_0000));
        let s = Vec3::new(d[kx], d[ky], d[kz]) * scale;
        let ez = Vec3::AXES[kz];
        let row_x = s.z * Vec3::AXES[kx] - s.x * ez;
        let row_y = s.z * Vec3::AXES[ky] - s.y * ez;
        let m = glam::Mat3::from_cols(row_x, row_y, (1.0 / d[kz]) * ez).transpose();
        let safe = Vec3::select(
            a.cmplt(Vec3::splat(MIN_DIR_COMPONENT)),
            Vec3::select(
                d.cmplt(Vec3::ZERO),
                Vec3::splat(-MIN_DIR_COMPONENT),
                Vec3::splat(MIN_DIR_COMPONENT),
            ),
            d,
        );
        RayData { origin: ray.origin, inv_dir: 1.0 / safe, m0: m.x_axis, m1: m.y_axis, m2: m.z_axis }
    }

    /// Entry distances into the children of `node` (`bvh_children_entry`): `f32::MAX` for a child the
    /// ray misses within `[tmin, tmax]` and for empty slots.
    #[inline(always)]
    fn children_entry(&self, node: &BvhNode, tmin: f32, tmax: f32) -> [f32; BVH_WIDTH] {
        std::array::from_fn(|j| {
            let (lo, hi) = node.child_box(j);
            let t0 = (lo - self.origin) * self.inv_dir;
            let t1 = (hi - self.origin) * self.inv_dir;
            let near = t0.min(t1).max_element().max(tmin);
            let far = (t0.max(t1).min_element() * BOX_EXIT_SCALE).min(tmax);
            if near <= far && node.child(j).is_some() { near } else { f32::MAX }
        })
    }

    /// A vertex in the ray's frame: `bvh_project`, one function of the vertex and the ray alone.
    #[inline(always)]
    pub(crate) fn project<A: Arithmetic>(&self, v: Vec3) -> Vec3 {
        let p = v - self.origin;
        let lane = |j: usize| A::fma(p.x, self.m0[j], A::fma(p.y, self.m1[j], p.z * self.m2[j]));
        Vec3::new(lane(0), lane(1), lane(2))
    }

    /// The watertight ray–triangle test (`bvh_triangle`). Returns `(t, u, v)` for `tmin < t < tmax`,
    /// u and v being the barycentrics of v1 and v2. Without the paper's double-precision fallback an
    /// edge function of exactly 0 counts as inside for both triangles sharing the edge: no gaps,
    /// possibly a double hit, which closest-hit queries resolve anyway.
    #[inline(always)]
    pub(crate) fn triangle<A: Arithmetic>(
        &self,
        v0: Vec3,
        v1: Vec3,
        v2: Vec3,
        tmin: f32,
        tmax: f32,
    ) -> Option<(f32, f32, f32)> {
        let a = self.project::<A>(v0);
        let b = self.project::<A>(v1);
        let c = self.project::<A>(v2);
        // Edges b → c, c → a, a → b: the weights of a, b, c (the paper's U, V, W).
        let eu = A::edge(b.x, b.y, c.x, c.y);
        let ev = A::edge(c.x, c.y, a.x, a.y);
        let ew = A::edge(a.x, a.y, b.x, b.y);
        if (eu < 0.0 || ev < 0.0 || ew < 0.0) && (eu > 0.0 || ev > 0.0 || ew > 0.0) {
            return None;
        }
        let det = eu + ev + ew;
        if det == 0.0 {
            return None;
        }
        // In det's order of summation, so that a triangle at one depth gets that depth exactly.
        let t = A::fma(ew, c.z, A::fma(ev, b.z, eu * a.z)) / det;
        if !(t > tmin && t < tmax) {
            return None;
        }
        Some((t, ev / det, ew / det))
    }
}

/// The children of a node ordered by entry distance, nearest first, misses (`f32::MAX`) last:
/// `bvh_sort_children`'s compare-exchange network, equal distances kept in slot order, so that CPU
/// and GPU visit children (and so break ties between equally near hits) alike.
#[inline(always)]
fn sort_children(mut t: [f32; BVH_WIDTH], mut c: [u32; BVH_WIDTH]) -> ([f32; BVH_WIDTH], [u32; BVH_WIDTH]) {
    for (a, b) in [(0, 1), (2, 3), (0, 2), (1, 3), (1, 2)] {
        if t[b] < t[a] {
            t.swap(a, b);
            c.swap(a, b);
        }
    }
    (t, c)
}

impl Bvh {
    /// Entering instance `index`: the ray in its space and its bottom level's root.
    fn enter_instance<A: Arithmetic>(&self, index: u32, ray: &Ray) -> (RayData, Option<u32>) {
        let instance = &self.instances[index as usize];
        (RayData::new(&instance.map_ray::<A>(ray)), Some(node_ref(instance.root, 0)))
    }

    /// Visits node `index`: returns its nearest child the ray enters within `[tmin, tmax]` and
    /// defers the others far to near through `defer(reference, entry)`, as `bvh.wgsl` does.
    #[inline(always)]
    fn visit(
        &self,
        r: &RayData,
        index: u32,
        tmin: f32,
        tmax: f32,
        mut defer: impl FnMut(u32, f32),
    ) -> Option<u32> {
        let node = &self.nodes[index as usize];
        let (t, c) = sort_children(r.children_entry(node, tmin, tmax), node.children);
        for j in (1..BVH_WIDTH).rev() {
            if t[j] < f32::MAX {
                defer(c[j], t[j]);
            }
        }
        (t[0] < f32::MAX).then_some(c[0])
    }

    /// Closest hit with `tmin < t < tmax`; alpha-tested triangles count as opaque.
    pub fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<Hit> {
        self.intersect_with(ray, tmin, tmax, |_, _, _| true)
    }

    /// Closest hit; a hit on an alpha-tested triangle counts only if `alpha(triangle, u, v)` is true
    /// (the CPU counterpart of the includer's `bvh_alpha_test` in `bvh.wgsl`).
    pub fn intersect_with(
        &self,
        ray: &Ray,
        tmin: f32,
        tmax: f32,
        alpha: impl FnMut(u32, f32, f32) -> bool,
    ) -> Option<Hit> {
        self.closest::<Fused>(ray, tmin, tmax, alpha)
    }

    /// [`Bvh::intersect_with`] in the given arithmetic.
    pub(crate) fn closest<A: Arithmetic>(
        &self,
        ray: &Ray,
        tmin: f32,
        tmax: f32,
        mut alpha: impl FnMut(u32, f32, f32) -> bool,
    ) -> Option<Hit> {
        let world = RayData::new(ray);
        let mut r = world.clone();
        // The stack depth at which the current instance was entered: entries below it are world space
        // (0 in world space, where no entry lies below).
        let mut instance_sp = 0;
        let mut best: Option<Hit> = None;
        let mut t_best = tmax;
        let mut stack = [(0u32, 0f32); BVH_STACK_SIZE as usize];
        let mut sp = 0;
        let mut current = Some(node_ref(0, 0));
        loop {
            let reference = match current.take() {
                Some(c) => c,
                None => {
                    if sp == 0 {
                        break;
                    }
                    sp -= 1;
                    if sp < instance_sp {
                        r = world.clone();
                        instance_sp = 0;
                    }
                    let (c, entry) = stack[sp];
                    if entry >= t_best {
                        continue;
                    }
                    c
                }
            };
            match Child::of(reference) {
                Child::Instance(index) => {
                    (r, current) = self.enter_instance::<A>(index, ray);
                    instance_sp = sp;
                }
                Child::Triangles { first, count } => {
                    for tri in &self.triangles[first as usize..(first + count) as usize] {
                        let [v0, v1, v2] = tri.vertices();
                        if let Some((t, u, v)) = r.triangle::<A>(v0, v1, v2, tmin, t_best)
                            && (!tri.is_alpha_tested() || alpha(tri.index, u, v))
                        {
                            t_best = t;
                            best = Some(Hit { t, triangle: tri.index, u, v });
                        }
                    }
                }
                Child::Node(index) => {
                    current = self.visit(&r, index, tmin, t_best, |c, t| {
                        stack[sp] = (c, t);
                        sp += 1;
                    });
                }
            }
        }
        best
    }

    /// Whether anything is hit with `tmin < t < tmax`; alpha-tested triangles count as opaque.
    pub fn occluded(&self, ray: &Ray, tmin: f32, tmax: f32) -> bool {
        self.occluded_with(ray, tmin, tmax, |_, _, _| true)
    }

    /// Any-hit query with an alpha test, see [`Bvh::intersect_with`].
    pub fn occluded_with(
        &self,
        ray: &Ray,
        tmin: f32,
        tmax: f32,
        alpha: impl FnMut(u32, f32, f32) -> bool,
    ) -> bool {
        self.any::<Fused>(ray, tmin, tmax, alpha)
    }

    /// [`Bvh::occluded_with`] in the given arithmetic.
    pub(crate) fn any<A: Arithmetic>(
        &self,
        ray: &Ray,
        tmin: f32,
        tmax: f32,
        mut alpha: impl FnMut(u32, f32, f32) -> bool,
    ) -> bool {
        let world = RayData::new(ray);
        let mut r = world.clone();
        let mut instance_sp = 0;
        let mut stack = [0u32; BVH_STACK_SIZE as usize];
        let mut sp = 0;
        let mut current = Some(node_ref(0, 0));
        loop {
            let reference = match current.take() {
                Some(c) => c,
                None if sp == 0 => return false,
                None => {
                    sp -= 1;
                    if sp < instance_sp {
                        r = world.clone();
                        instance_sp = 0;
                    }
                    stack[sp]
                }
            };
            match Child::of(reference) {
                Child::Instance(index) => {
                    (r, current) = self.enter_instance::<A>(index, ray);
                    instance_sp = sp;
                }
                Child::Triangles { first, count } => {
                    for tri in &self.triangles[first as usize..(first + count) as usize] {
                        let [v0, v1, v2] = tri.vertices();
                        if let Some((_, u, v)) = r.triangle::<A>(v0, v1, v2, tmin, tmax)
                            && (!tri.is_alpha_tested() || alpha(tri.index, u, v))
                        {
                            return true;
                        }
                    }
                }
                // Any order finds an occluder; nearest first is the closest-hit code.
                Child::Node(index) => {
                    current = self.visit(&r, index, tmin, tmax, |c, _| {
                        stack[sp] = c;
                        sp += 1;
                    });
                }
            }
        }
    }
}

/// Closest hit by testing every triangle (the reference for the BVH); `alpha_tested` and `alpha` as
/// in [`Bvh::build`] and [`Bvh::intersect_with`].
pub fn intersect_brute_force(
    triangles: &[[Vec3; 3]],
    alpha_tested: Option<&[bool]>,
    alpha: impl FnMut(u32, f32, f32) -> bool,
    ray: &Ray,
    tmin: f32,
    tmax: f32,
) -> Option<Hit> {
    brute_closest::<Fused>(triangles, alpha_tested, alpha, ray, tmin, tmax)
}

/// [`intersect_brute_force`] in the given arithmetic.
pub(crate) fn brute_closest<A: Arithmetic>(
    triangles: &[[Vec3; 3]],
    alpha_tested: Option<&[bool]>,
    mut alpha: impl FnMut(u32, f32, f32) -> bool,
    ray: &Ray,
    tmin: f32,
    tmax: f32,
) -> Option<Hit> {
    let r = RayData::new(ray);
    let mut best: Option<Hit> = None;
    let mut t_best = tmax;
    for (i, [v0, v1, v2]) in triangles.iter().enumerate() {
        if let Some((t, u, v)) = r.triangle::<A>(*v0, *v1, *v2, tmin, t_best) {
            let masked = alpha_tested.and_then(|a| a.get(i)).copied().unwrap_or(false);
            if !masked || alpha(i as u32, u, v) {
                t_best = t;
                best = Some(Hit { t, triangle: i as u32, u, v });
            }
        }
    }
    best
}

/// Any-hit counterpart of [`intersect_brute_force`].
pub fn occluded_brute_force(
    triangles: &[[Vec3; 3]],
    alpha_tested: Option<&[bool]>,
    mut alpha: impl FnMut(u32, f32, f32) -> bool,
    ray: &Ray,
    tmin: f32,
    tmax: f32,
) -> bool {
    let r = RayData::new(ray);
    triangles.iter().enumerate().any(|(i, [v0, v1, v2])| {
        r.triangle::<Fused>(*v0, *v1, *v2, tmin, tmax).is_some_and(|(_, u, v)| {
            !alpha_tested.and_then(|a| a.get(i)).copied().unwrap_or(false) || alpha(i as u32, u, v)
        })
    })
}
