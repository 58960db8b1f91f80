// Irradiance at x (normal n) from pixel light p (Dachsbacher & Stamminger 2005):
//   E_p(x, n) = I_p · max(0, ⟨n_p | x − x_p⟩) · max(0, ⟨n | x_p − x⟩) / ‖x − x_p‖⁴,
// with ‖x − x_p‖² clamped below at `min_d2` (the texel's own area: closer than that the pixel light is
// not a point, and the unclamped kernel diverges in corners).
fn rsm_irradiance(intensity: vec3f, xp: vec3f, np: vec3f, x: vec3f, n: vec3f, min_d2: f32) -> vec3f {
    let d = x - xp;
    let d2 = max(dot(d, d), min_d2);
    return intensity * (max(0.0, dot(np, d)) * max(0.0, dot(n, -d)) / (d2 * d2));
}
