// Transfer per rigid part (SELF_TRANSFER: scenes with moving meshes, moving_transfer=self), composed
// before the precomputations (transfer.wgsl, glossy.wgsl): every point's transfer is that of its rigid
// part alone (interreflected light too bounces between the part's own surfaces only), in the part's
// own space: a moving mesh's points see only their own mesh (its instance's
// bottom level, in the space it was uploaded in), the static meshes' see only the static meshes (in
// world space). Such transfer stays true however the part moves, turned with it: the environment is
// turned into the part's space to light it (self_transfer.wgsl).

// SELF_TRANSFER: per vertex, its BVH instance, or NO_INSTANCE for the static meshes (GpuScene::bvh_parts).
@group(2) @binding(4) var<storage, read> vertex_instances: array<u32>;

// Where a vertex's transfer rays start, about which normal, and the part of the BVH they see.
struct TransferFrame {
    origin: vec3f,
    normal: vec3f,
    // Node reference of the part's root (0: the whole scene).
    root: u32,
    // Seeds the point's directions.
    seed: u32,
    // SELF_TRANSFER: the BVH instance whose space the frame is in (NO_INSTANCE: world space).
    instance: u32,
}

fn transfer_frame(point: u32) -> TransferFrame {
    let p = point_surface(point);
    let n = p.normal;
    let origin = offset_origin(p.position, n);
    if !SELF_TRANSFER {
        return TransferFrame(origin, n, 0u, p.seed, NO_INSTANCE);
    }
    let instance = vertex_instances[p.vertex];
    if instance == NO_INSTANCE {
        return TransferFrame(origin, n, STATIC_ROOT, p.seed, NO_INSTANCE);
    }
    // Rigid motion (and uniform scale) maps normals as directions.
    let part = bvh_instances[instance];
    return TransferFrame(
        bvh_affine(part, origin, 1.0),
        normalize(bvh_affine(part, n, 0.0)),
        part.root << 3u,
        p.seed,
        instance,
    );
}

fn transfer_occluded(f: TransferFrame, d: vec3f) -> bool {
    let ray = Ray(f.origin, d);
    return trace_any_from(ray, bvh_ray(ray), f.root, 0.0, FLT_MAX);
}

// A direction of the frame's space in world space, where the vertex buffer holds the surfaces as posed:
// the world-to-object map's linear part is a rotation times a uniform scale, so its transpose turns
// directions back (normalised).
fn transfer_world_direction(f: TransferFrame, d: vec3f) -> vec3f {
    if !SELF_TRANSFER || f.instance == NO_INSTANCE {
        return d;
    }
    let part = bvh_instances[f.instance];
    return normalize(part.row0.xyz * d.x + part.row1.xyz * d.y + part.row2.xyz * d.z);
}

// Where direction `d` of a frame meets a surface of its part that passes interreflected light on (a
// front face: transfer is for the side the normals point to), and the diffuse reflectance there.
struct BounceSource {
    found: bool,
    at: TrianglePoint,
    reflectance: vec3f,
}

fn bounce_source(f: TransferFrame, d: vec3f) -> BounceSource {
    let ray = Ray(f.origin, d);
    let hit = trace_closest_from(ray, bvh_ray(ray), f.root, 0.0, FLT_MAX);
    let world = transfer_world_direction(f, d);
    if !hit_found(hit) || hits_back_face(hit.triangle, hit.u, hit.v, world) {
        return BounceSource();
    }
    let q = surface_at(hit.triangle, hit.u, hit.v, world);
    let reflectance = brdf_lobe_weights(q.material, saturate(dot(q.normal, -world))).diffuse;
    return BounceSource(true, triangle_point(hit.triangle, hit.u, hit.v), reflectance);
}
