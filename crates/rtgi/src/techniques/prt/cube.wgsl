// The cube-map parameterisation of directions that wavelet transfer works in (Ng, Ramamoorthi &
// Hanrahan 2003): 6 faces of CUBE_SIZE² texels, texel t = face · CUBE_SIZE² + y · CUBE_SIZE + x. Face f
// is the plane where axis f / 2 is +1 (f even) or −1 (f odd); its coordinates (a, b) ∈ [−1, 1]² run
// along the next two axes, cyclically. The faces are fixed in the world: a turning environment is
// resampled onto them, the transfer never changes. The CPU twin is `wavelet::cube_direction`.

const CUBE_AREA: u32 = CUBE_SIZE * CUBE_SIZE;
const CUBE_TEXELS: u32 = 6u * CUBE_AREA;

// The (unnormalised) direction through point (a, b) of face `face`.
fn cube_point(face: u32, ab: vec2f) -> vec3f {
    let axis = face / 2u;
    let sign = select(-1.0, 1.0, face % 2u == 0u);
    var p = vec3f(0.0);
    p[axis] = sign;
    p[(axis + 1u) % 3u] = ab.x;
    p[(axis + 2u) % 3u] = ab.y;
    return p;
}

// Face coordinates of the texel's corner (x, y) + `offset` (offset in texels).
fn cube_coordinates(xy: vec2u, offset: vec2f) -> vec2f {
    return (vec2f(xy) + offset) * (2.0 / f32(CUBE_SIZE)) - 1.0;
}

fn cube_texel_face(texel: u32) -> u32 {
    return texel / CUBE_AREA;
}

fn cube_texel_xy(texel: u32) -> vec2u {
    let i = texel % CUBE_AREA;
    return vec2u(i % CUBE_SIZE, i / CUBE_SIZE);
}

// The unit direction through the texel's centre.
fn cube_texel_direction(texel: u32) -> vec3f {
    return normalize(cube_point(cube_texel_face(texel), cube_coordinates(cube_texel_xy(texel), vec2f(0.5))));
}

// ∫∫ (1 + a² + b²)^(−3/2) da db from (0, 0) to (a, b): the solid angle a face rectangle subtends.
fn cube_corner_solid_angle(ab: vec2f) -> f32 {
    return atan2(ab.x * ab.y, sqrt(dot(ab, ab) + 1.0));
}

// The texel's exact solid angle (the 6 faces' texels sum to 4π).
fn cube_texel_solid_angle(texel: u32) -> f32 {
    let xy = cube_texel_xy(texel);
    let lo = cube_coordinates(xy, vec2f(0.0));
    let hi = cube_coordinates(xy, vec2f(1.0));
    return cube_corner_solid_angle(hi) - cube_corner_solid_angle(vec2f(lo.x, hi.y))
        - cube_corner_solid_angle(vec2f(hi.x, lo.y)) + cube_corner_solid_angle(lo);
}
