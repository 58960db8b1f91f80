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

// A node's light this frame: Σ E_i A_i over its samples (W, rgb) and the irradiance-weighted mean of
// their positions (the area-weighted one where no light arrives).
struct NodeLight {
    power: vec3f,
    _pad0: f32,
    position: vec3f,
    _pad1: f32,
}

// The dipole of a material (all zero for opaque ones; whether a material is translucent, and its η,
// are in the scene's material table). Per channel: σ_tr, real source depth z_r, virtual source height
// z_v and the weights of the profile's flux and fluence terms.
struct Medium {
    transport: vec3f,
    _pad0: f32,
    z_r: vec3f,
    // B_s: the multiply-scattered light's spatial bandwidth (cycles per metre).
    spatial_bandwidth: f32,
    z_v: vec3f,
    _pad1: f32,
    k_e: vec3f,
    _pad2: f32,
    k_phi: vec3f,
    _pad3: f32,
}

// A cluster of pixels of one translucent mesh (a square of 1, 2², 4² or 8² pixels of one tile) that
// one tree traversal lights: the mean of its pixels' positions and the radius of the sphere about it
// that holds them all (0 for one pixel).
struct ClusterJob {
    center: vec3f,
    radius: f32,
    mesh: u32,
    material: u32,
    pixels: u32,
    _pad: u32,
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
// Per sample: irradiance E (rgb) this frame.
@group(2) @binding(1) var<storage, read_write> sample_irradiance: array<vec4f>;
@group(2) @binding(2) var<storage, read_write> nodes: array<TreeNode>;
@group(2) @binding(3) var<storage, read_write> node_light: array<NodeLight>;
// Per mesh: the root node of its illumination tree, or NO_NODE.
@group(2) @binding(4) var<storage, read_write> mesh_roots: array<u32>;
// Per material.
@group(2) @binding(5) var<storage, read_write> media: array<Medium>;
// Per material, ANGULAR_BINS values of B_θ(θ_o) (cycles per radian).
@group(2) @binding(6) var<storage, read_write> angular_bandwidth: array<f32>;
@group(2) @binding(7) var<storage, read_write> jobs: array<ClusterJob>;
// Per job: Σ R_d(r) E A over the tree's cut (rgb).
@group(2) @binding(8) var<storage, read_write> job_light: array<vec4f>;
// Per pixel: its cluster's job, or NO_JOB for pixels that are not translucent.
@group(2) @binding(9) var<storage, read_write> pixel_job: array<u32>;
@group(2) @binding(10) var<storage, read_write> counters: array<atomic<u32>, 5>;
// Nodes in the order the tree pass aggregates them: deepest level first.
@group(2) @binding(11) var<storage, read_write> node_order: array<u32>;
// Binding 12 is the output (shade.wgsl).

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
