// Transfer per rigid part (SELF_TRANSFER: scenes with moving meshes, moving_transfer=self), composed
// before the precomputations (transfer.wgsl, glossy.wgsl): every point's transfer is that of its rigid
// part alone, in the part's own space: a moving mesh's points see only their own mesh (its instance's
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
}

fn transfer_frame(point: u32) -> TransferFrame {
    let p = point_surface(point);
    let n = p.normal;
    let origin = offset_origin(p.position, n);
    if !SELF_TRANSFER {
        return TransferFrame(origin, n, 0u, p.seed);
    }
    let instance = vertex_instances[p.vertex];
    if instance == NO_INSTANCE {
        return TransferFrame(origin, n, STATIC_ROOT, p.seed);
    }
    // Rigid motion (and uniform scale) maps normals as directions.
    let part = bvh_instances[instance];
    return TransferFrame(
        bvh_affine(part, origin, 1.0),
        normalize(bvh_affine(part, n, 0.0)),
        part.root << 3u,
        p.seed,
    );
}

fn transfer_occluded(f: TransferFrame, d: vec3f) -> bool {
    let ray = Ray(f.origin, d);
    return trace_any_from(ray, bvh_ray(ray), f.root, 0.0, FLT_MAX);
}
