// Scene bindings (bind group 0) and surface reconstruction, shared by raster passes, compute passes
// and the path tracer. Layouts mirror the `#[repr(C)]` structs in gpu/scene.rs; a unit test checks
// sizes and offsets with naga reflection.

#import common/linear_texture.wgsl
#import common/math.wgsl
#import common/bvh.wgsl
#import common/brdf.wgsl

// 32 bytes. Normals and tangents are octahedral-encoded snorm16x2; the tangent's handedness is bit 31
// of `material_flags`, the material index its low 24 bits.
struct Vertex {
    position: vec3f,
    material_flags: u32,
    normal_oct: u32,
    tangent_oct: u32,
    uv: vec2f,
}

struct Material {
    base_color: vec4f,
    emissive: vec3f,
    normal_scale: f32,
    metallic: f32,
    roughness: f32,
    // Fragments with alpha below this are cut away; negative for opaque materials.
    alpha_cutoff: f32,
    // Scale of the dielectric specular layer (KHR_materials_specular); 0 = pure Lambertian.
    specular: f32,
    // Layers in the sRGB (base colour, emissive) and linear (metallic-roughness, normal) texture
    // arrays; -1 when absent.
    tex_base: i32,
    tex_metal_rough: i32,
    tex_emissive: i32,
    tex_normal: i32,
    // A translucent medium under the surface (scene::Subsurface, what the path tracer's random walk
    // reads): σ_a and σ_s' per scene unit and the boundary's index; medium_eta = 0 for opaque materials.
    medium_absorption: vec3f,
    medium_eta: f32,
    medium_scattering: vec3f,
    _pad_medium: f32,
}

const LIGHT_POINT: u32 = 0u;
const LIGHT_SPOT: u32 = 1u;
const LIGHT_DIRECTIONAL: u32 = 2u;

struct Light {
    position: vec3f,
    kind: u32,
    // Spot axis or the direction the directional light travels (towards the scene).
    direction: vec3f,
    // First layer of this light's shadow map (6 consecutive layers for point lights); -1 for none.
    shadow_layer: i32,
    // Radiant intensity (W/sr) or, for directional lights, irradiance (W/m²).
    intensity: vec3f,
    cos_outer: f32,
    cos_inner: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

// An emissive triangle for area-light sampling; `cdf` is the running sum of power up to and
// including this triangle, normalised to 1.
struct EmissiveTriangle {
    triangle: u32,
    cdf: f32,
    area: f32,
    power: f32,
}

const ENV_NONE: u32 = 0u;
const ENV_UNIFORM: u32 = 1u;
const ENV_SKY: u32 = 2u;
const ENV_MAP: u32 = 3u;

struct SceneInfo {
    triangle_count: u32,
    light_count: u32,
    emissive_count: u32,
    env_kind: u32,
    // Uniform radiance, or the sky's zenith radiance.
    env_radiance: vec3f,
    env_intensity: f32,
    sun_direction: vec3f,
    emissive_power: f32,
    sun_radiance: vec3f,
    _pad0: f32,
    ground_radiance: vec3f,
    _pad1: f32,
    bounds_min: vec3f,
    _pad2: f32,
    bounds_max: vec3f,
    _pad3: f32,
    // The environment's turn (Scene::environment_rotation): the environment's own frame to the world's.
    // Its transpose takes world directions back to the environment's frame.
    world_from_environment: mat3x3f,
}

@group(0) @binding(0) var<uniform> scene_info: SceneInfo;
@group(0) @binding(1) var<storage, read> vertices: array<Vertex>;
@group(0) @binding(2) var<storage, read> indices: array<u32>;
@group(0) @binding(3) var<storage, read> materials: array<Material>;
@group(0) @binding(4) var<storage, read> lights: array<Light>;
// The BVH's tables, where the scene's GpuBvh keeps them (gpu/bvh/mod.rs `BvhTables`).
#if BVH_TABLES_IN_BUFFERS
@group(0) @binding(5) var<storage, read> bvh_nodes: array<vec4u>;
@group(0) @binding(6) var<storage, read> bvh_tris: array<vec4u>;
#else
@group(0) @binding(5) var bvh_nodes: texture_storage_2d<rgba32uint, read>;
@group(0) @binding(6) var bvh_tris: texture_storage_2d<rgba32uint, read>;
#endif
@group(0) @binding(7) var<storage, read> emissive_triangles: array<EmissiveTriangle>;
@group(0) @binding(8) var textures_srgb: texture_2d_array<f32>;
@group(0) @binding(9) var textures_linear: texture_2d_array<f32>;
@group(0) @binding(10) var texture_sampler: sampler;
@group(0) @binding(11) var environment_map: texture_2d<f32>;
// Per material: the area density with which area-light sampling picks a point on a triangle of this
// material, luminance(emission) · mean texture / total emitted power (0 for non-emitters).
@group(0) @binding(12) var<storage, read> emission_pdf: array<f32>;
// Environment-map sampling table (gpu/scene.rs `environment_cdf`): height marginal CDF values over rows,
// then width conditional CDF values per row.
@group(0) @binding(13) var env_cdf: texture_2d<f32>;
// The instances of a two-level BVH (moving rigid meshes; one unused entry for a static scene).
@group(0) @binding(14) var<storage, read> bvh_instances: array<BvhInstance>;

const MATERIAL_MASK: u32 = 0x00ffffffu;
const TANGENT_FLIP_BIT: u32 = 0x80000000u;

fn vertex_normal(v: Vertex) -> vec3f {
    return oct_decode(unpack2x16snorm(v.normal_oct));
}

fn vertex_tangent(v: Vertex) -> vec4f {
    let w = select(1.0, -1.0, (v.material_flags & TANGENT_FLIP_BIT) != 0u);
    return vec4f(oct_decode(unpack2x16snorm(v.tangent_oct)), w);
}

// Whether material `material` has a translucent medium under its surface.
fn is_translucent(material: u32) -> bool {
    return materials[material].medium_eta > 0.0;
}

fn vertex_material(v: Vertex) -> u32 {
    return v.material_flags & MATERIAL_MASK;
}

// Samples a texture layer; `lod` < 0 means "let the hardware pick" (fragment shaders only use
// `sample_material_grad`, compute shaders pass an explicit level).
fn sample_srgb(layer: i32, uv: vec2f, lod: f32) -> vec4f {
    return textureSampleLevel(textures_srgb, texture_sampler, uv, layer, lod);
}

fn sample_linear(layer: i32, uv: vec2f, lod: f32) -> vec4f {
    return textureSampleLevel(textures_linear, texture_sampler, uv, layer, lod);
}

fn base_color_alpha(m: Material, uv: vec2f, lod: f32) -> vec4f {
    var c = m.base_color;
    if m.tex_base >= 0 {
        c *= sample_srgb(m.tex_base, uv, lod);
    }
    return c;
}

fn material_at(m: Material, uv: vec2f, lod: f32) -> SurfaceMaterial {
    var s: SurfaceMaterial;
    let c = base_color_alpha(m, uv, lod);
    s.base_color = c.rgb;
    s.alpha = c.a;
    s.metallic = m.metallic;
    s.roughness = m.roughness;
    if m.tex_metal_rough >= 0 {
        let mr = sample_linear(m.tex_metal_rough, uv, lod);
        s.roughness *= mr.g;
        s.metallic *= mr.b;
    }
    s.specular = m.specular;
    s.emission = m.emissive;
    if m.tex_emissive >= 0 {
        s.emission *= sample_srgb(m.tex_emissive, uv, lod).rgb;
    }
    return s;
}

// The tangent frame (columns: tangent, bitangent, normal) in which normal maps are expressed, from the
// shading normal n and a vertex tangent whose w is the bitangent's handedness.
fn tangent_frame(n: vec3f, tangent: vec4f) -> mat3x3f {
    let t = normalize(tangent.xyz - n * dot(n, tangent.xyz));
    return mat3x3f(t, cross(n, t) * tangent.w, n);
}

// Applies the material's tangent-space normal map; returns the unperturbed normal without one.
fn perturb_normal(m: Material, n: vec3f, tangent: vec4f, uv: vec2f, lod: f32) -> vec3f {
    if m.tex_normal < 0 {
        return n;
    }
    var tn = sample_linear(m.tex_normal, uv, lod).xyz * 2.0 - 1.0;
    tn = vec3f(tn.xy * m.normal_scale, tn.z);
    let p = normalize(tangent_frame(n, tangent) * tn);
    // A perturbed normal must stay in the geometric hemisphere or shading leaks light.
    return select(n, p, dot(p, n) > 0.01);
}

// Everything a shader needs about a ray hit.
struct SurfaceHit {
    position: vec3f,
    // Geometric normal, facing the incoming ray.
    geometric_normal: vec3f,
    // Interpolated (and normal-mapped) shading normal, on the same side as the geometric normal.
    normal: vec3f,
    uv: vec2f,
    material_index: u32,
    material: SurfaceMaterial,
}

fn triangle_vertices(triangle: u32) -> array<Vertex, 3> {
    let i = triangle * 3u;
    return array<Vertex, 3>(vertices[indices[i]], vertices[indices[i + 1u]], vertices[indices[i + 2u]]);
}

fn triangle_uv(triangle: u32, u: f32, v: f32) -> vec2f {
    let t = triangle_vertices(triangle);
    return t[0].uv * (1.0 - u - v) + t[1].uv * u + t[2].uv * v;
}

// Reconstructs the surface at barycentrics (u, v) of `triangle`, seen along `dir`, with textures read
// at their finest level (secondary hits carry no footprint).
fn surface_at(triangle: u32, u: f32, v: f32, dir: vec3f) -> SurfaceHit {
    return surface_at_lod(triangle, u, v, dir, 0.0);
}

// surface_at with the textures read at mip level `lod`.
fn surface_at_lod(triangle: u32, u: f32, v: f32, dir: vec3f, lod: f32) -> SurfaceHit {
    let t = triangle_vertices(triangle);
    let w = 1.0 - u - v;
    var s: SurfaceHit;
    s.position = t[0].position * w + t[1].position * u + t[2].position * v;
    let f = vertex_frame(t, u, v, dir);
    s.uv = t[0].uv * w + t[1].uv * u + t[2].uv * v;
    s.material_index = vertex_material(t[0]);
    let m = materials[s.material_index];
    s.material = material_at(m, s.uv, lod);
    s.normal = perturb_normal(m, f.normal, f.tangent, s.uv, lod);
    s.geometric_normal = f.geometric_normal;
    return s;
}

// A surface point's normals and tangent before normal mapping.
struct VertexFrame {
    // Facing the incoming ray.
    geometric_normal: vec3f,
    // Interpolated, on the geometric normal's side.
    normal: vec3f,
    // Interpolated; w is the bitangent's handedness (±1).
    tangent: vec4f,
}

// The frame at barycentrics (u, v) of triangle vertices `t` seen along `dir`. rtgi shades both sides
// of every surface: both normals are flipped to face the viewer.
fn vertex_frame(t: array<Vertex, 3>, u: f32, v: f32, dir: vec3f) -> VertexFrame {
    let w = 1.0 - u - v;
    var f: VertexFrame;
    f.geometric_normal = normalize(cross(t[1].position - t[0].position, t[2].position - t[0].position));
    if dot(f.geometric_normal, dir) > 0.0 {
        f.geometric_normal = -f.geometric_normal;
    }
    f.normal = normalize(vertex_normal(t[0]) * w + vertex_normal(t[1]) * u + vertex_normal(t[2]) * v);
    if dot(f.normal, f.geometric_normal) < 0.0 {
        f.normal = -f.normal;
    }
    let tangent = vertex_tangent(t[0]) * w + vertex_tangent(t[1]) * u + vertex_tangent(t[2]) * v;
    f.tangent = vec4f(tangent.xyz, select(-1.0, 1.0, tangent.w >= 0.0));
    return f;
}

// Whether a ray along `dir` meets `triangle` at barycentrics (u, v) from behind: the side its authored
// normals point away from (rtgi shades both sides, so only probes that must tell inside from outside ask).
fn hits_back_face(triangle: u32, u: f32, v: f32, dir: vec3f) -> bool {
    let t = triangle_vertices(triangle);
    let n = vertex_normal(t[0]) * (1.0 - u - v) + vertex_normal(t[1]) * u + vertex_normal(t[2]) * v;
    return dot(n, dir) > 0.0;
}

// A ray origin off the surface at p (geometric normal ng), by an offset relative to the scene's float
// precision at p, so secondary rays do not hit the surface they leave.
fn offset_origin(p: vec3f, ng: vec3f) -> vec3f {
    return p + ng * (1e-4 * max(1.0, max3(abs(p))));
}

// Alpha-mask test called by the BVH traversal for triangles flagged as alpha-tested.
fn bvh_alpha_test(triangle: u32, u: f32, v: f32) -> bool {
    let t = triangle_vertices(triangle);
    let m = materials[vertex_material(t[0])];
    let uv = t[0].uv * (1.0 - u - v) + t[1].uv * u + t[2].uv * v;
    return base_color_alpha(m, uv, 0.0).a >= m.alpha_cutoff;
}
