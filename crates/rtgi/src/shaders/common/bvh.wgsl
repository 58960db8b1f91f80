// TEMPORARY brute-force stand-in (replaced by the BVH branch): same interface as the real module.
// Requires the includer to declare `bvh_nodes: array<BvhNode>`, `bvh_tris: array<vec4f>` and
// `fn bvh_alpha_test(triangle: u32, u: f32, v: f32) -> bool`.

#import common/math.wgsl

struct BvhNode {
    aabb_min: vec3f,
    left_first: u32,
    aabb_max: vec3f,
    count: u32,
}

struct Ray {
    origin: vec3f,
    dir: vec3f,
}

struct Hit {
    t: f32,
    triangle: u32,
    u: f32,
    v: f32,
}

fn intersect_triangle_mt(ray: Ray, i: u32) -> vec3f {
    let a = bvh_tris[i * 3u].xyz;
    let e1 = bvh_tris[i * 3u + 1u].xyz - a;
    let e2 = bvh_tris[i * 3u + 2u].xyz - a;
    let p = cross(ray.dir, e2);
    let det = dot(e1, p);
    if abs(det) < 1e-12 {
        return vec3f(FLT_MAX, 0.0, 0.0);
    }
    let inv = 1.0 / det;
    let s = ray.origin - a;
    let u = dot(s, p) * inv;
    let q = cross(s, e1);
    let v = dot(ray.dir, q) * inv;
    if u < 0.0 || v < 0.0 || u + v > 1.0 {
        return vec3f(FLT_MAX, 0.0, 0.0);
    }
    return vec3f(dot(e2, q) * inv, u, v);
}

fn trace_closest(ray: Ray, tmin: f32, tmax: f32) -> Hit {
    var best = Hit(FLT_MAX, 0u, 0.0, 0.0);
    let n = arrayLength(&bvh_tris) / 3u;
    var tm = tmax;
    for (var i = 0u; i < n; i++) {
        let h = intersect_triangle_mt(ray, i);
        if h.x > tmin && h.x < tm {
            tm = h.x;
            best = Hit(h.x, bitcast<u32>(bvh_tris[i * 3u].w), h.y, h.z);
        }
    }
    return best;
}

fn trace_any(ray: Ray, tmin: f32, tmax: f32) -> bool {
    let n = arrayLength(&bvh_tris) / 3u;
    for (var i = 0u; i < n; i++) {
        let h = intersect_triangle_mt(ray, i);
        if h.x > tmin && h.x < tmax {
            return true;
        }
    }
    return false;
}
