// The subsurface technique's resources (bind group 2), one layout for all its passes, and the dipole.
//
// Illumination samples sit on the surfaces of translucent meshes (placed once, in the order of their
// mesh's kd-tree, so that every tree node covers a contiguous range). Per frame: the samples'
// irradiance, then the nodes' aggregate light bottom-up, then pixel clusters, one tree traversal per
// cluster, and shading.

#import common/brdf.wgsl

// A point on a translucent surface standing for `area` square metres of it, at barycentrics (u, v) of
// the second and third vertices of the scene's `triangle`.
struct IlluminationSample {
    position: vec3f,
    area: f32,
    normal: vec3f,
    mesh: u32,
    triangle: u32,
    u: f32,
    v: f32,
    _pad: u32,
}

// A node of a mesh's illumination tree: the bounding box of its samples, which are samples
// [first, first + count); its left child is the next node (when count > 1), its right child `right`.
struct TreeNode {
    lo: vec3f,
    first: u32,
    hi: vec3f,
    count: u32,
    area: f32,
    right: u32,
    depth: u32,
    _pad: u32,
}

// A sample's light this frame: its irradiance E (rgb; with the entry Fresnel transmittance T₁₂ folded
// in for the directional dipole) and the sum of its light's refracted directions ω₁₂, each weighted by
// the luminance it brings.
struct SampleLight {
    irradiance: vec3f,
    _pad0: f32,
    direction: vec3f,
    _pad1: f32,
}

// A node's light this frame: Σ E_i A_i over its samples (W, rgb), the irradiance-weighted mean of
// their positions (the area-weighted one where no light arrives), and the luminance-weighted sums of
// their light's refracted directions and of their normals (for the directional dipole; normalised
// where used).
struct NodeLight {
    power: vec3f,
    _pad0: f32,
    position: vec3f,
    _pad1: f32,
    direction: vec3f,
    _pad2: f32,
    normal: vec3f,
    _pad3: f32,
}

// The diffusion profile of a material (all zero for opaque ones; whether a material is translucent,
// and its η, are in the scene's material table). For the radial dipoles (CPU twin
// `scene::subsurface::Dipole`), per channel: σ_tr, real source depth z_r, virtual source height z_v
// and the weights of the profile's flux and fluence terms. For the directional dipole (CPU twin
// `scene::subsurface::DirectionalDipole`): σ_tr, D, the extrapolation distance d_e, the squared depth
// of a source lit from behind, the virtual source's offset 2A d_e, and C_φ(η), C_E(η). `exit_scale`
// turns the sum over samples into radiance before the exit Fresnel: 1/π for the radial dipoles,
// 1/(4C_φ(1/η)) for the directional one.
struct Medium {
    transport: vec3f,
    exit_scale: f32,
    z_r: vec3f,
    // B_s: the multiply-scattered light's spatial bandwidth (cycles per metre).
    spatial_bandwidth: f32,
    z_v: vec3f,
    c_phi: f32,
    k_e: vec3f,
    c_e: f32,
    k_phi: vec3f,
    _pad0: f32,
    diffusion: vec3f,
    _pad1: f32,
    extrapolation: vec3f,
    _pad2: f32,
    backlit_depth2: vec3f,
    _pad3: f32,
    virtual_offset: vec3f,
    _pad4: f32,
}

// A cluster of pixels of one translucent mesh (a square of 1, 2², 4² or 8² pixels of one tile) that
// one tree traversal lights: the mean of its pixels' positions and the radius of the sphere about it
// that holds them all (0 for one pixel).
struct ClusterJob {
    center: vec3f,
    radius: f32,
    // The mean of the pixels' normals (normalised), for the directional dipole.
    normal: vec3f,
    mesh: u32,
    material: u32,
    pixels: u32,
    _pad0: u32,
    _pad1: u32,
}

const NO_NODE: u32 = 0xffffffffu;
const NO_JOB: u32 = 0xffffffffu;
// Angular bandwidth table entries per material, over θ_o in [0, π/2).
const ANGULAR_BINS: u32 = 32u;
const COUNTER_JOBS: u32 = 0u;
const COUNTER_EVALUATIONS: u32 = 1u;
const COUNTER_VISITS: u32 = 2u;
const COUNTER_PIXELS: u32 = 3u;
const COUNTER_TRUNCATED: u32 = 4u;

@group(2) @binding(0) var<storage, read_write> samples: array<IlluminationSample>;
@group(2) @binding(1) var<storage, read_write> sample_light: array<SampleLight>;
@group(2) @binding(2) var<storage, read_write> nodes: array<TreeNode>;
@group(2) @binding(3) var<storage, read_write> node_light: array<NodeLight>;
// Per mesh: the root node of its illumination tree, or NO_NODE.
@group(2) @binding(4) var<storage, read_write> mesh_roots: array<u32>;
// Per material.
@group(2) @binding(5) var<storage, read_write> media: array<Medium>;
// Per material, ANGULAR_BINS values of B_θ(θ_o) (cycles per radian).
@group(2) @binding(6) var<storage, read_write> angular_bandwidth: array<f32>;
@group(2) @binding(7) var<storage, read_write> jobs: array<ClusterJob>;
// Per job: Σ S E A over the tree's cut (rgb), S the profile R_d(r) or the directional dipole.
@group(2) @binding(8) var<storage, read_write> job_light: array<vec4f>;
// Per pixel: its cluster's job, or NO_JOB for pixels that are not translucent.
@group(2) @binding(9) var<storage, read_write> pixel_job: array<u32>;
@group(2) @binding(10) var<storage, read_write> counters: array<atomic<u32>, 5>;
// Nodes in the order the tree pass aggregates them: deepest level first.
@group(2) @binding(11) var<storage, read_write> node_order: array<u32>;
// Binding 12 is the output (shade.wgsl).
// Per pixel, this frame's single-scattered light (single.wgsl; one element when SINGLE_SCATTERING = 0).
@group(2) @binding(13) var<storage, read_write> single_light: array<vec4f>;

// The dipole's diffuse reflectance profile R_d(r), classical (Jensen et al. 2001) or better (d'Eon
// 2012) by its weights (CPU twin `scene::subsurface::Dipole::profile`).
fn dipole_profile(m: Medium, r: f32) -> vec3f {
    let r2 = vec3f(r * r);
    let d_r = sqrt(r2 + m.z_r * m.z_r);
    let d_v = sqrt(r2 + m.z_v * m.z_v);
    let fall_r = exp(-m.transport * d_r);
    let fall_v = exp(-m.transport * d_v);
    let real = m.z_r * (m.transport * d_r + 1.0) * fall_r / (d_r * d_r * d_r);
    let virt = m.z_v * (m.transport * d_v + 1.0) * fall_v / (d_v * d_v * d_v);
    return m.k_e * (real + virt) + m.k_phi * (fall_r / d_r - fall_v / d_v);
}

// Frisvad et al. 2014's directional dipole before its exit normalisation (`exit_scale`, applied in
// shading) and without the Fresnel transmittances: light entering at x_i (normal n_i) along the
// refracted direction w12 and leaving at x_o (normal n_o), clamped at zero (CPU twin
// `scene::subsurface::DirectionalDipole::eval`).
fn directional_dipole(m: Medium, x_i: vec3f, n_i: vec3f, w12: vec3f, x_o: vec3f, n_o: vec3f) -> vec3f {
    let x = x_o - x_i;
    let r2 = dot(x, x);
    // The modified tangent plane's normal: n_i turned about x until perpendicular to it.
    let side = cross(n_i, x);
    var n_star = n_i;
    if dot(side, side) > 1e-12 * max(r2, 1e-30) {
        n_star = cross(normalize(x), normalize(side));
    }
    let w_v = w12 - 2.0 * dot(w12, n_star) * n_star;
    let x_w = dot(x, w12);
    let cos_beta = -sqrt(max(r2 - x_w * x_w, 0.0) / (r2 + m.extrapolation * m.extrapolation));
    let mu0 = -dot(w12, n_o);
    var depth2 = m.backlit_depth2;
    if mu0 > 0.0 {
        depth2 = m.diffusion * mu0 * (m.diffusion * mu0 - 2.0 * m.extrapolation * cos_beta);
    }
    let real = ray_source(m, vec3f(x_w), dot(w12, n_o), vec3f(dot(x, n_o)), sqrt(r2 + depth2));
    // The virtual source sits at x_i + o n* with a per-channel offset o: x_v = x − o n*, its dot
    // products and length per channel.
    let o = m.virtual_offset;
    let v_w = dot(x, w_v) - o * dot(n_star, w_v);
    let v_n = dot(x, n_o) - o * dot(n_star, n_o);
    let x_star = dot(x, n_star);
    let d_v = sqrt(max(r2 - 2.0 * o * x_star + o * o, vec3f(0.0)));
    let virt = ray_source(m, v_w, dot(w_v, n_o), v_n, d_v);
    return max(real - virt, vec3f(0.0));
}

// S'_d(x, ω, r) of Frisvad et al.'s Eq. 17: one ray source's share, per channel, from x·ω and x·n_o
// (x from its entry point to the exit point), ω·n_o and r, the distance to the source.
fn ray_source(m: Medium, x_w: vec3f, w_n: f32, x_n: vec3f, r: vec3f) -> vec3f {
    let tr_r = m.transport * r;
    let r2 = r * r;
    let fall = exp(-tr_r) / (4.0 * PI * PI * r2 * r);
    let flux = r2 / m.diffusion + 3.0 * (1.0 + tr_r) * x_w;
    let fluence = 3.0 * m.diffusion * (1.0 + tr_r) * w_n
        - (1.0 + tr_r + 3.0 * m.diffusion * (3.0 * (1.0 + tr_r) + tr_r * tr_r) / r2 * x_w) * x_n;
    return fall * (m.c_phi * flux - m.c_e * fluence);
}
