// Glossy PRT (composed after shade.wgsl): the point's transferred radiance L' (glossy.wgsl: each
// vertex's transfer matrix times the environment's SH), interpolated from its triangle's vertices, as
// `incident_sh` for the lobes composed after this file: shade_glossy_tables.wgsl (glossy_lobe = ggx)
// or shade_glossy_phong.wgsl (glossy_lobe = phong).

// Per vertex, order² coefficients of transferred radiance (rgb).
@group(2) @binding(3) var<storage, read> transferred: array<vec4f>;

// The point being shaded, for incident_sh.
var<private> shaded: TrianglePoint;

// Makes p the point `incident_sh` reads, and returns s as the point's transferred radiance sees it:
// with SELF_TRANSFER a moving mesh's radiance is in its own space (glossy.wgsl), so its normals and
// view are turned into that space too (the lobes' integral is the same in any frame). The lobe files
// declare `vertex_instances` (per vertex its BVH instance, or NO_INSTANCE) after their own bindings.
fn glossy_surface(s: GSurface, p: TrianglePoint) -> GSurface {
    shaded = p;
    var local = s;
    if SELF_TRANSFER {
        // A triangle's vertices are all of one mesh.
        let instance = vertex_instances[indices[p.triangle * 3u]];
        if instance != NO_INSTANCE {
            let part = bvh_instances[instance];
            local.normal = normalize(bvh_affine(part, s.normal, 0.0));
            local.geometric_normal = normalize(bvh_affine(part, s.geometric_normal, 0.0));
            local.view = normalize(bvh_affine(part, s.view, 0.0));
        }
    }
    return local;
}

fn incident_sh(k: u32) -> vec3f {
    let count = shape.order * shape.order;
    let p = shaded;
    return p.weights.x * transferred[p.vertices.x * count + k].rgb
        + p.weights.y * transferred[p.vertices.y * count + k].rgb
        + p.weights.z * transferred[p.vertices.z * count + k].rgb;
}
