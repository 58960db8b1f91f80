// Camera pixels (prepended: volume.wgsl, cone.wgsl): this frame's direct light (accumulated while
// nothing moves, by the `direct` pass) plus the diffuse light of DIFFUSE_CONES cones over the normal's
// hemisphere and, SPECULAR_CONE, the glossy light of one cone about the mirror direction whose
// aperture follows the roughness. Cones start a voxel (of the finest level holding the surface) out
// along the geometric normal (against the surface's own voxel).

@group(2) @binding(7) var direct: texture_2d<f32>;
@group(2) @binding(8) var output: texture_storage_2d<rgba32float, write>;

// Half-angle tangent of the specular cone: GGX's α (the lobe's width at half its peak, roughly),
// bounded below so a mirror's cone still widens past one voxel.
fn specular_tan(roughness: f32) -> f32 {
    return clamp(ggx_alpha(roughness), MIN_SPECULAR_TAN, 1.0);
}

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if any(id.xy >= frame.size) {
        return;
    }
    var radiance = textureLoad(direct, id.xy, 0).rgb;
    let s = load_gsurface(id.xy);
    if s.valid {
        let weights = brdf_lobe_weights(s.material, dot(s.normal, s.view));
        let k = min(clip_at(s.position, CLIP_MARGIN), CLIPS - 1u);
        let origin = s.position + s.geometric_normal * voxel_size(k);
        radiance += weights.diffuse * INV_PI * cone_irradiance(origin, s.normal);
        if SPECULAR_CONE && max3(weights.specular) > 1e-3 {
            let r = reflect(-s.view, s.normal);
            let tan_half = specular_tan(s.material.roughness);
            radiance += weights.specular * cone_trace(origin, r, tan_half, max_cone_distance(),
                                                      dot(r, s.geometric_normal)).rgb;
        }
    }
    textureStore(output, id.xy, vec4f(radiance, 1.0));
}
