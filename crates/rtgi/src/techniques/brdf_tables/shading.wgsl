// Environment shading of a surface from SH coefficients of its incident radiance (the thesis's §3.5.3
// with the SH basis or the HSH tables folded into it): the coefficients turned into the frame of the
// normal and dotted with the BRDF tables (lookup.wgsl) at the local outgoing direction. The composing
// shader declares `rotation_x90: array<f32>` (read-only storage: band l's (2l+1)² block of the SH matrix
// of Rx(90°), row-major, from l(4l² − 1)/3; `rotation_x90_blocks`) and defines
// `fn incident_sh(k: u32) -> vec3f`, coefficient k of the radiance arriving at the surface: the
// environment's own for env-harmonics, the transferred (shadowed) radiance for prt's glossy transfer.
// Everything runs band by band (rotations keep bands apart), so no invocation holds more than one
// band's 2l + 1 colours. The turn is R⁻¹ for R = Rz(φ) Ry(θ), (θ, φ) the normal's spherical angles,
// with Ry written as Rx(−90°) Rz(θ) Rx(90°), so per pixel only two cheap Z turns and two products with
// the one constant X matrix (band by band) are needed.

const MAX_BAND_WIDTH: u32 = 2u * HSH_MAX_ORDER - 1u;
alias Band = array<vec3f, MAX_BAND_WIDTH>;

// Band l of g(d) = f(Rz(−angle) d), as hsh.rs rotate_z: the (m, −m) pairs turn by m·angle.
fn rotate_z(b: ptr<function, Band>, l: u32, angle: f32) {
    for (var m = 1u; m <= l; m++) {
        let s = sin(f32(m) * angle);
        let co = cos(f32(m) * angle);
        let cos_part = (*b)[l + m];
        let sin_part = (*b)[l - m];
        (*b)[l + m] = cos_part * co - sin_part * s;
        (*b)[l - m] = sin_part * co + cos_part * s;
    }
}

// Band l turned by Rx(90°), or by its inverse (the transposed block).
fn rotate_x90(b: ptr<function, Band>, l: u32, inverse: bool) {
    let n = 2u * l + 1u;
    let block = sh_band_matrix_start(l);
    var out: Band;
    for (var i = 0u; i < n; i++) {
        var sum = vec3f(0.0);
        for (var j = 0u; j < n; j++) {
            let e = select(rotation_x90[block + i * n + j], rotation_x90[block + j * n + i], inverse);
            sum += e * (*b)[j];
        }
        out[i] = sum;
    }
    *b = out;
}

// ∫ L_in f cos over the hemisphere of `s` for the first `order` bands of L_in = incident_sh.
fn harmonic_shading(s: GSurface, order: u32) -> vec3f {
    let n = s.normal;
    let theta = acos(clamp(n.z, -1.0, 1.0));
    let phi = select(0.0, atan2(n.y, n.x), abs(n.x) + abs(n.y) > 0.0);
    // The view direction in the normal's frame: Ry(−θ) Rz(−φ) v.
    let v = s.view;
    let vz = vec2f(cos(phi) * v.x + sin(phi) * v.y, -sin(phi) * v.x + cos(phi) * v.y);
    let local_v = vec3f(cos(theta) * vz.x - sin(theta) * v.z, vz.y, sin(theta) * vz.x + cos(theta) * v.z);
    let t = brdf_table_lookup(local_v, s.material.roughness);
    let count = order * order;
    var lambert = vec3f(0.0);
    var lambert_fresnel = vec3f(0.0);
    var ggx = vec3f(0.0);
    var ggx_fresnel = vec3f(0.0);
    for (var l = 0u; l < order; l++) {
        var b: Band;
        for (var i = 0u; i < 2u * l + 1u; i++) {
            b[i] = incident_sh(l * l + i);
        }
        rotate_z(&b, l, -phi);
        rotate_x90(&b, l, false);
        rotate_z(&b, l, -theta);
        rotate_x90(&b, l, true);
        for (var i = 0u; i < 2u * l + 1u; i++) {
            let lobes = brdf_table_lobes(t, l * l + i, count);
            lambert += b[i] * lobes.x;
            lambert_fresnel += b[i] * lobes.y;
            ggx += b[i] * lobes.z;
            ggx_fresnel += b[i] * lobes.w;
        }
    }
    return max(brdf_table_combine(s.material, lambert, lambert_fresnel, ggx, ggx_fresnel), vec3f(0.0));
}

