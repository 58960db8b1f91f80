// Radiance estimate from the photon map (Jensen 2001): the light the photons within PHOTON_RADIUS of x
// reflect towards `view`, Σ f_r(ω_p, view) Φ_p / (π r²), over photons on surfaces that face like x's
// (shading normals within PHOTON_NORMAL_COS): a disc on the surface, so corners are biased low (the
// final gather averages many such lookups; records from photon density alone measure the covered area
// by a convex hull instead, radiance_cache/photon_record.wgsl). The includer binds `photons`
// (array<Photon>) and `photon_grid` (array<u32>: bucket b's photons are [photon_grid[b],
// photon_grid[b + 1])).

// Offset of corner c (bits x, y, z) of the 2×2×2 cells towards `toward`.
fn photon_corner(c: u32, toward: vec3i) -> vec3i {
    return vec3i(
        select(0, toward.x, (c & 1u) != 0u),
        select(0, toward.y, (c & 2u) != 0u),
        select(0, toward.z, (c & 4u) != 0u),
    );
}

fn photon_radiance(x: vec3f, n: vec3f, view: vec3f, m: SurfaceMaterial) -> vec3f {
    let g = x / PHOTON_CELL;
    let base = vec3i(floor(g));
    // Cells are two radii wide: the sphere around x lies in the cell of x and its neighbours on the
    // sides of x's nearer halves.
    let toward = select(vec3i(-1), vec3i(1), fract(g) >= vec3f(0.5));
    let r2 = PHOTON_RADIUS * PHOTON_RADIUS;
    var sum = vec3f(0.0);
    for (var c = 0u; c < 8u; c++) {
        let bucket = photon_bucket(base + photon_corner(c, toward));
        // Two cells hashing to one bucket are read once.
        var repeated = false;
        for (var e = 0u; e < c; e++) {
            repeated = repeated || photon_bucket(base + photon_corner(e, toward)) == bucket;
        }
        if repeated {
            continue;
        }
        let end = photon_grid[bucket + 1u];
        for (var i = photon_grid[bucket]; i < end; i++) {
            let p = photons[i];
            let d = p.position - x;
            if dot(d, d) < r2 && dot(p.normal, n) > PHOTON_NORMAL_COS {
                sum += brdf_eval(m, n, view, p.incoming) * p.flux;
            }
        }
    }
    return sum / (PI * r2);
}
