// glossy_lobe = phong (composed after shade_glossy.wgsl): the transferred radiance reflected by
// Sloan et al.'s radially symmetric lobes, Lambert about the normal plus a normalised Phong lobe about
// the mirror direction (common/sh_lobes.wgsl): no BRDF tables, order² terms per pixel.

#import common/sh_lobes.wgsl

@group(2) @binding(4) var<storage, read> vertex_instances: array<u32>;

fn environment_light(s: GSurface, p: TrianglePoint) -> vec3f {
    let local = glossy_surface(s, p);
    return phong_lobes_reflected(local.material, local.normal, local.view, shape.order);
}
