// glossy_lobe = phong (composed after shade_glossy.wgsl): the transferred radiance reflected by
// Sloan et al.'s radially symmetric lobes, Lambert about the normal plus a normalised Phong lobe about
// the mirror direction (common/sh_lobes.wgsl): no BRDF tables, order² terms per pixel.

#import common/sh_lobes.wgsl

fn environment_light(s: GSurface, p: TrianglePoint) -> vec3f {
    shaded = p;
    return phong_lobes_reflected(s.material, s.normal, s.view, shape.order);
}
