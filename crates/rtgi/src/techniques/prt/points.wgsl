// The points prt keeps transfer at: the scene's vertices (TEXELS_PER_EDGE = 0), or every triangle's own
// patch of texels (TEXELS_PER_EDGE = R > 0): the (R + 1)(R + 2)/2 points of its barycentric lattice,
// (u, v) = (i/R, j/R) with i + j ≤ R, so transfer is R times finer than the mesh along every edge
// without a UV unwrap. Point (i, j) of triangle t is t · PATCH_POINTS + j(2R + 3 − j)/2 + i. Points on
// an edge two triangles share are kept by both and come out alike (the same position and normal up to
// rounding, and the same precomputation directions, which are seeded by the position). POINT_COUNT points in all. Composed
// before the precomputation (transfer.wgsl, glossy.wgsl) and the shading (shade.wgsl).

#import common/scene.wgsl
#import common/random.wgsl

const PATCH_POINTS: u32 = (TEXELS_PER_EDGE + 1u) * (TEXELS_PER_EDGE + 2u) / 2u;

// Three points about a point of a triangle and the barycentric weights of the point between them: the
// triangle's vertices, or the lattice sub-triangle holding it.
struct TrianglePoint {
    vertices: vec3u,
    weights: vec3f,
    triangle: u32,
}

fn patch_point(triangle: u32, i: u32, j: u32) -> u32 {
    return triangle * PATCH_POINTS + j * (2u * TEXELS_PER_EDGE + 3u - j) / 2u + i;
}

// The points about the point at barycentrics (u, v) of `triangle` (weights 1 − u − v, u, v of its
// vertices 0, 1, 2).
fn triangle_point(triangle: u32, u: f32, v: f32) -> TrianglePoint {
    let first = triangle * 3u;
    if TEXELS_PER_EDGE == 0u {
        let corners = vec3u(indices[first], indices[first + 1u], indices[first + 2u]);
        return TrianglePoint(corners, vec3f(1.0 - u - v, u, v), triangle);
    }
    let r = f32(TEXELS_PER_EDGE);
    let x = saturate(u) * r;
    let y = saturate(v) * r;
    // The lattice cell (ci, cj): its lower sub-triangle (ci, cj), (ci + 1, cj), (ci, cj + 1), and the
    // upper one (ci + 1, cj + 1), (ci, cj + 1), (ci + 1, cj) where the cell lies inside the triangle.
    let ci = min(u32(x), TEXELS_PER_EDGE - 1u);
    let cj = min(u32(y), TEXELS_PER_EDGE - 1u - ci);
    let fx = x - f32(ci);
    let fy = y - f32(cj);
    if fx + fy > 1.0 && ci + cj + 2u <= TEXELS_PER_EDGE {
        let points = vec3u(
            patch_point(triangle, ci + 1u, cj + 1u),
            patch_point(triangle, ci, cj + 1u),
            patch_point(triangle, ci + 1u, cj),
        );
        return TrianglePoint(points, vec3f(fx + fy - 1.0, 1.0 - fx, 1.0 - fy), triangle);
    }
    let points =
        vec3u(patch_point(triangle, ci, cj), patch_point(triangle, ci + 1u, cj), patch_point(triangle, ci, cj + 1u));
    // Rounding can leave the point a hair outside the lower sub-triangle of a cell on the diagonal edge.
    let w = vec3f(max(1.0 - fx - fy, 0.0), fx, fy);
    return TrianglePoint(points, w / (w.x + w.y + w.z), triangle);
}

// A point's surface for the precomputation.
struct PointSurface {
    position: vec3f,
    normal: vec3f,
    // Seeds the point's directions (lattice.wgsl).
    seed: u32,
    // A vertex of its triangle (its mesh's), or the point's own vertex.
    vertex: u32,
}

// PointSurface::vertex of `point`, without the rest of its surface.
fn point_vertex(point: u32) -> u32 {
    if TEXELS_PER_EDGE == 0u {
        return point;
    }
    return indices[point / PATCH_POINTS * 3u];
}

fn point_surface(point: u32) -> PointSurface {
    if TEXELS_PER_EDGE == 0u {
        let v = vertices[point];
        return PointSurface(v.position, vertex_normal(v), point, point);
    }
    let triangle = point / PATCH_POINTS;
    let local = point % PATCH_POINTS;
    // Row j of the lattice starts at j(2R + 3 − j)/2.
    var j = 0u;
    while j < TEXELS_PER_EDGE && (j + 1u) * (2u * TEXELS_PER_EDGE + 2u - j) / 2u <= local {
        j++;
    }
    let i = local - j * (2u * TEXELS_PER_EDGE + 3u - j) / 2u;
    let u = f32(i) / f32(TEXELS_PER_EDGE);
    let v = f32(j) / f32(TEXELS_PER_EDGE);
    let t = triangle_vertices(triangle);
    let w = 1.0 - u - v;
    let position = t[0].position * w + t[1].position * u + t[2].position * v;
    let interpolated = vertex_normal(t[0]) * w + vertex_normal(t[1]) * u + vertex_normal(t[2]) * v;
    let geometric = normalize(cross(t[1].position - t[0].position, t[2].position - t[0].position));
    let normal = select(geometric, normalize(interpolated), dot(interpolated, interpolated) > 1e-12);
    // The two triangles of an edge interpolate its points in different orders, so their positions may
    // differ in the last bits: the seed hashes the position on a grid of 1/4096 m.
    let cell = bitcast<vec3u>(vec3i(round(position * 4096.0)));
    return PointSurface(position, normal, hash2(hash2(cell.x, cell.y), cell.z), point_vertex(point));
}
