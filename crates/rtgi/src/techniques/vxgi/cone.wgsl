// Cone tracing through the filtered voxel radiance (prepended: volume.wgsl). Level 0 is the voxels'
// own radiance, premultiplied by their opacity (rgb = L·α, a = α; a surface voxel is opaque); each
// coarser level halves the resolution. ANISOTROPIC: levels 1.. are six directional volumes side by
// side along x (+x, −x, +y, −y, +z, −z), each the view of its 2×2×2 children along that direction
// (front to back, then averaged), read with weights dir² from the three facing the march; otherwise
// the isotropic box-filtered mips of level 0.

@group(2) @binding(4) var radiance_base: texture_3d<f32>;
@group(2) @binding(5) var radiance_directional: texture_3d<f32>;
@group(2) @binding(6) var voxel_sampler: sampler;

// Radiance is read from the cone's axis at distance t, in the level (clipmap level, then mip) whose
// voxel matches the cone's diameter there; steps are STEP diameters long. With clipmap levels, a
// level's block in the stacked textures is clamped half a texel inside along z, so filtering never
// reads the next level's voxels.
fn stacked_z(k: u32, z: f32, size: f32) -> f32 {
    var local = z;
    if CLIPS > 1u {
        local = clamp(z, 0.5, size - 0.5);
    }
    return (local + f32(k) * size) / (f32(CLIPS) * size);
}

// Level k's isotropic radiance at g (grid units of the level) and mip `level`.
fn sample_base(k: u32, g: vec3f, level: f32) -> vec4f {
    let size = f32(GRID) / exp2(ceil(level));
    let u = g / f32(GRID);
    let uvw = vec3f(u.xy, stacked_z(k, u.z * size, size));
    return textureSampleLevel(radiance_base, voxel_sampler, uvw, level);
}

// Directional mip m ≥ 1 of level k (mip m − 1 of the directional texture), clamped half a texel inside
// each block so filtering never reads a neighbouring direction.
fn sample_directional(k: u32, g: vec3f, m: u32, dir: vec3f) -> vec4f {
    let size = f32(GRID >> m);
    let local = clamp(g / f32(1u << m), vec3f(0.5), vec3f(size - 0.5));
    let w = dir * dir;
    var sum = vec4f(0.0);
    for (var axis = 0u; axis < 3u; axis++) {
        if w[axis] > 0.0 {
            let block = 2u * axis + select(1u, 0u, dir[axis] > 0.0);
            let uvw = vec3f((f32(block) * size + local.x) / (6.0 * size), local.y / size,
                            stacked_z(k, local.z, size));
            sum += w[axis] * textureSampleLevel(radiance_directional, voxel_sampler, uvw, f32(m - 1u));
        }
    }
    return sum;
}

fn sample_voxels(k: u32, g: vec3f, level: f32, dir: vec3f) -> vec4f {
    if !ANISOTROPIC {
        return sample_base(k, g, level);
    }
    let lo = u32(floor(level));
    let f = level - f32(lo);
    var a = vec4f(0.0);
    if lo == 0u {
        a = sample_base(k, g, 0.0);
    } else {
        a = sample_directional(k, g, lo, dir);
    }
    if f <= 0.0 || lo + 1u >= LEVELS {
        return a;
    }
    return mix(a, sample_directional(k, g, lo + 1u, dir), f);
}

// How far cones go (world units): MAX_DISTANCE voxels of the coarsest level.
fn max_cone_distance() -> f32 {
    return MAX_DISTANCE * voxel_size(CLIPS - 1u);
}

// Premultiplied radiance (rgb) and opacity (a) a cone gathers from `origin` along `dir` (world space)
// with half-angle tangent `tan_half`, front to back, from CONE_START voxels (of the finest level holding
// the origin) out to `max_t` or the coarsest level's border. `rise` is the cosine between `dir` and the
// normal of the surface it leaves: a sample's footprint stays within FOOTPRINT_CAP of its height above
// that surface. Each sample reads the finest level that holds it (CLIP_MARGIN voxels inside) and is at
// least as fine as the cone's diameter needs, at the mip of that diameter.
fn cone_trace(origin: vec3f, dir: vec3f, tan_half: f32, max_t: f32, rise: f32) -> vec4f {
    var acc = vec4f(0.0);
    let start = clip_at(origin, CLIP_MARGIN);
    if start >= CLIPS {
        return acc;
    }
    var t = CONE_START * voxel_size(start);
    for (var i = 0u; i < MAX_CONE_STEPS; i++) {
        if t > max_t || acc.a >= 0.99 {
            break;
        }
        let p = origin + t * dir;
        let holding = clip_at(p, CLIP_MARGIN);
        if holding >= CLIPS {
            break;
        }
        let wanted = min(2.0 * t * tan_half, FOOTPRINT_CAP * t * rise);
        // The level whose voxel is at most the diameter (its mip 1 is the next level's voxels).
        let by_size = u32(clamp(floor(log2(max(wanted, 1e-30) / voxel_size(0u))), 0.0, f32(CLIPS - 1u)));
        let k = max(holding, by_size);
        let voxel = voxel_size(k);
        let diameter = max(wanted, voxel);
        let g = grid_position(k, p);
        let level = min(log2(diameter / voxel), f32(LEVELS - 1u));
        // Finer than mip 1 the cone is a voxel wide: a surface voxel it is in is solid. (Trilinear
        // opacity spreads a one-voxel wall over two voxels at half strength, and half-voxel steps
        // through it would let a sixth of what lies behind through.)
        if level < 1.0 {
            let c = clip_texel(k, min(vec3u(max(g, vec3f(0.0))), vec3u(GRID - 1u)));
            let v = textureLoad(radiance_base, c, 0);
            if v.a >= 0.5 {
                acc += (1.0 - acc.a) * vec4f(v.rgb / v.a, 1.0);
                break;
            }
        }
        let s = sample_voxels(k, g, level, dir);
        // The level's opacity is for crossing one of its voxels (one diameter); a step crosses STEP.
        let alpha = 1.0 - pow(saturate(1.0 - s.a), STEP);
        let colour = s.rgb * (alpha / max(s.a, 1e-6));
        acc += (1.0 - acc.a) * vec4f(colour, alpha);
        t += STEP * diameter;
    }
    return acc;
}

// Cone i of the DIFFUSE_CONES over the hemisphere about +z, each standing for an equal share of the
// cosine-weighted hemisphere (so each weighs π / DIFFUSE_CONES in the irradiance): one about the
// normal holding the cap sin²θ < 1/n, the others on a ring at the median of the rest.
fn diffuse_cone_local(i: u32) -> vec3f {
    if i == 0u || DIFFUSE_CONES == 1u {
        return vec3f(0.0, 0.0, 1.0);
    }
    let n = f32(DIFFUSE_CONES);
    let sin_theta = sqrt(0.5 * (1.0 + 1.0 / n));
    let phi = 2.0 * PI * f32(i - 1u) / (n - 1.0);
    return vec3f(sin_theta * cos(phi), sin_theta * sin(phi), sqrt(1.0 - sin_theta * sin_theta));
}

// Irradiance at a surface (normal n, cones starting from `origin`, world space) from the voxels.
fn cone_irradiance(origin: vec3f, n: vec3f) -> vec3f {
    var sum = vec3f(0.0);
    for (var i = 0u; i < DIFFUSE_CONES; i++) {
        let d = local_to_world(diffuse_cone_local(i), n);
        sum += cone_trace(origin, d, DIFFUSE_TAN, max_cone_distance(), dot(d, n)).rgb;
    }
    return sum * (PI / f32(DIFFUSE_CONES));
}
