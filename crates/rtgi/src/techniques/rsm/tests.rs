//! Shader validation, the interleaving layout, the sample pattern and the RSM kernel.

use super::interleave::{self, AtlasLayout};
use super::*;
use crate::shaders::{Defines, layout::assert_layout, layout::assert_u32_constants, validate};
use crate::techniques::fixture::fixture;

fn atlas_defines(l: &AtlasLayout) -> Defines {
    l.defines(Defines::new().u32("TILE", 8))
}

#[test]
fn shaders_validate() {
    let l = AtlasLayout::interleaved(64, 48, 4, 2);
    let view = format!("{}\n{}", map::VIEW_WGSL, include_str!("map.wgsl"));
    validate("rsm map", &view, &Defines::new());
    for (brute, fixup) in [(false, false), (true, false), (false, true)] {
        let src = reader_source(&format!(
            "{}\n{}\n{}",
            interleave::ATLAS_WGSL,
            interleave::SURFACES_WGSL,
            include_str!("gather.wgsl")
        ));
        validate(
            "rsm gather",
            &src,
            &atlas_defines(&l)
                .u32("SAMPLES_PER_SUBSET", 16)
                .bool("BRUTE_FORCE", brute)
                .bool("FIXUP", fixup)
                .bool("SPLIT_GBUFFER", true),
        );
    }
    validate(
        "upsample",
        include_str!("upsample.wgsl"),
        &Defines::new()
            .u32("TILE", 8)
            .u32("DOWNSAMPLE", 2)
            .f32("DEPTH_THRESHOLD", 0.02)
            .f32("NORMAL_COS", 0.9),
    );
    validate("composite", include_str!("composite.wgsl"), &Defines::new().u32("TILE", 8));
    let atlas = |body: &str| format!("{}\n{body}", interleave::ATLAS_WGSL);
    validate("split", &atlas(include_str!("split.wgsl")), &atlas_defines(&l));
    validate("merge", &atlas(include_str!("merge.wgsl")), &atlas_defines(&l));
    validate(
        "merge gbuffer",
        &atlas(&format!("{}\n{}", interleave::SURFACES_WGSL, include_str!("merge_gbuffer.wgsl"))),
        &atlas_defines(&l).bool("SPLIT_GBUFFER", true),
    );
    let vpl = validate("vpl", &splat::vpl_source(), &Defines::new().u32("TILE", 8));
    assert_layout(
        &vpl,
        "Vpl",
        size_of::<splat::GpuVpl>(),
        &[("position", 0), ("radius", 12), ("normal", 16), ("area", 28), ("intensity", 32), ("subset", 44)],
    );
    assert_layout(
        &vpl,
        "VplParams",
        size_of::<splat::VplParams>(),
        &[("count", 0), ("subsets", 4), ("jitter", 8), ("threshold", 12)],
    );
    assert_layout(
        &vpl,
        "RsmView",
        size_of::<RsmView>(),
        &[("view_proj", 0), ("light", 64), ("orthographic", 68), ("texel", 72), ("size", 76)],
    );
    validate(
        "splat",
        &splat::splat_source(),
        &atlas_defines(&l).bool("SPLIT_GBUFFER", true).f32("SCALE", 8.0),
    );
    for (name, source) in [("splat bins", splat::bins_source()), ("splat tiles", splat::tiles_source())] {
        let module = validate(
            name,
            &source,
            &atlas_defines(&l)
                .bool("SPLIT_GBUFFER", true)
                .f32("SCALE", 8.0)
                .u32("VPL_COUNT", 100)
                .u32("BIN_WORDS", 4)
                .u32("TILES_X", 3),
        );
        assert_u32_constants(&module, &[("VPL_TABLE_TEXELS", splat::VPL_TABLE_TEXELS as u32)]);
    }
}

/// The adapter check (`gpu::context::REQUIRED_FORMAT_USAGES`) asks for the RSM's render targets.
#[test]
fn the_adapter_check_covers_the_rsm_formats() {
    let required = crate::gpu::context::REQUIRED_FORMAT_USAGES;
    for format in [map::POSITION_FORMAT, map::NORMAL_FORMAT, map::INTENSITY_FORMAT] {
        assert!(
            required.iter().any(|(f, u)| *f == format && u.contains(wgpu::TextureUsages::RENDER_ATTACHMENT)),
            "{format:?}"
        );
    }
}

/// What `atlas.wgsl` computes for one layout, evaluated on the GPU: per atlas texel (subset, source
/// pixel x, y, valid), per image pixel its atlas texel.
struct GpuAtlas {
    texels: Vec<[u32; 4]>,
    pixels: Vec<[u32; 2]>,
}

fn evaluate_atlas_on_gpu(ctx: &crate::gpu::GpuContext, l: &AtlasLayout, w: u32, h: u32) -> GpuAtlas {
    use crate::gpu::readback::read_buffer;
    use wgpu::util::DeviceExt;
    let (aw, ah) = l.size();
    let size = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("frame size"),
        contents: bytemuck::cast_slice(&[w, h, 0, 0]),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let texel_bytes = u64::from(aw * ah) * 16;
    let pixel_bytes = u64::from(w * h) * 8;
    let texels = compute::storage_buffer(ctx, "atlas texels", texel_bytes);
    let pixels = compute::storage_buffer(ctx, "atlas pixels", pixel_bytes);
    let bgl = compute::layout(
        ctx,
        "atlas probe",
        &[
            compute::uniform_entry(0),
            compute::storage_buffer_entry(1, false),
            compute::storage_buffer_entry(2, false),
        ],
    );
    let group = compute::bind_group(
        ctx,
        "atlas probe",
        &bgl,
        &[size.as_entire_binding(), texels.as_entire_binding(), pixels.as_entire_binding()],
    );
    // `atlas.wgsl` reads the image size from the frame uniforms; this stands in for them.
    let source = format!(
        "{}\n{}",
        interleave::ATLAS_WGSL,
        r"
struct FrameSize { size: vec2u, unused: vec2u }
@group(0) @binding(0) var<uniform> frame: FrameSize;
@group(0) @binding(1) var<storage, read_write> texels: array<vec4u>;
@group(0) @binding(2) var<storage, read_write> pixels: array<vec2u>;
@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let size = atlas_size();
    if all(id.xy < size) {
        let s = atlas_source(id.xy);
        texels[id.y * size.x + id.x] = vec4u(atlas_subset(id.xy), s.pixel, u32(s.valid));
    }
    if all(id.xy < frame.size) {
        pixels[id.y * frame.size.x + id.x] = atlas_of_pixel(id.xy);
    }
}
"
    );
    let pipeline = compute::pipeline(ctx, "atlas probe", &source, l.defines(Defines::new()), "main", &[&bgl])
        .expect("atlas probe pipeline");
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    let groups = [aw.max(w).div_ceil(8), ah.max(h).div_ceil(8), 1];
    compute::dispatch(&mut encoder, "atlas probe", &pipeline, &[&group], groups);
    ctx.queue.submit([encoder.finish()]);
    let texels = read_buffer(ctx, &texels, 0, texel_bytes).expect("texels");
    let pixels = read_buffer(ctx, &pixels, 0, pixel_bytes).expect("pixels");
    GpuAtlas {
        texels: bytemuck::cast_slice(&texels).to_vec(),
        pixels: bytemuck::cast_slice(&pixels).to_vec(),
    }
}

/// The interleaved layout as the GPU computes it (`atlas.wgsl`, read back, not its Rust twin): every
/// pixel lands in exactly one texel of its own sub-buffer, `atlas_of_pixel` inverts `atlas_source`,
/// and sub-buffers are decimated copies. The Rust twin, which tests use to interpret atlases, agrees.
#[test]
fn atlas_layout_is_a_bijection() {
    let ctx = crate::gpu::GpuContext::new(&crate::gpu::GpuOptions::default()).expect("GPU adapter");
    for (w, h) in [(64, 48), (61, 37)] {
        for (n, m) in [(1, 1), (2, 2), (2, 4), (4, 4), (8, 8), (3, 5)] {
            let l = AtlasLayout::interleaved(w, h, n, m);
            let gpu = evaluate_atlas_on_gpu(&ctx, &l, w, h);
            let (aw, ah) = l.size();
            let mut seen = vec![0u32; (w * h) as usize];
            let mut per_subset = vec![0u32; (n * m) as usize];
            for ay in 0..ah {
                for ax in 0..aw {
                    let [subset, px, py, valid] = gpu.texels[(ay * aw + ax) as usize];
                    let twin = l.source((ax, ay), w, h);
                    assert_eq!(subset, l.subset((ax, ay)), "{w}x{h} {n}x{m}: subset of texel ({ax}, {ay})");
                    assert_eq!(valid == 1, twin.is_some(), "{w}x{h} {n}x{m}: texel ({ax}, {ay}) valid");
                    if valid == 0 {
                        continue;
                    }
                    assert_eq!(Some((px, py)), twin, "{w}x{h} {n}x{m}: source of texel ({ax}, {ay})");
                    seen[(py * w + px) as usize] += 1;
                    assert_eq!(gpu.pixels[(py * w + px) as usize], [ax, ay], "atlas_of_pixel({px}, {py})");
                    assert_eq!(subset, px % n + n * (py % m), "sub-buffer of pixel ({px}, {py})");
                    per_subset[subset as usize] += 1;
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "{w}x{h} {n}x{m}: every pixel exactly once");
            // Each sub-buffer is a decimated copy: ceil/floor of W/N × H/M pixels.
            for (s, &c) in per_subset.iter().enumerate() {
                let (i, j) = (s as u32 % n, s as u32 / n);
                let cols = (w - i).div_ceil(n);
                let rows = (h - j).div_ceil(m);
                assert_eq!(c, cols * rows, "{w}x{h} {n}x{m}: sub-buffer {s}");
            }
        }
    }
}

/// The reduced-resolution layout on the GPU: texel c stands for pixel c·f + f/2 (clamped to the image),
/// one subset, and texels are valid exactly where c·f lies inside the image.
#[test]
fn reduced_atlas_texels_stand_for_the_centre_of_their_block() {
    let ctx = crate::gpu::GpuContext::new(&crate::gpu::GpuOptions::default()).expect("GPU adapter");
    for (w, h, f) in [(64, 48, 2), (61, 37, 2), (61, 37, 4)] {
        let l = AtlasLayout::reduced(w, h, f);
        let gpu = evaluate_atlas_on_gpu(&ctx, &l, w, h);
        let (aw, ah) = l.size();
        for ay in 0..ah {
            for ax in 0..aw {
                let [subset, px, py, valid] = gpu.texels[(ay * aw + ax) as usize];
                assert_eq!(subset, 0);
                assert_eq!(valid == 1, ax * f < w && ay * f < h, "{w}x{h}/{f}: texel ({ax}, {ay})");
                let expected = ((ax * f + f / 2).min(w - 1), (ay * f + f / 2).min(h - 1));
                assert_eq!((px, py), expected, "{w}x{h}/{f}: texel ({ax}, {ay})");
            }
        }
    }
}

#[test]
fn sample_pattern_is_the_polar_disc_and_subsets_are_disjoint_nets() {
    let s = Sampling { count: 1024, per_subset: 64, r_max: 0.3, xi2: false, rsm_size: 128 };
    let samples = gather_samples(&s, 7, 3);
    let texels = std::f64::consts::PI * 0.09 * 128.0 * 128.0;
    for block in samples.chunks(64) {
        // Every sample inside r_max; the radius is r_max·ξ1.
        for p in block {
            let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
            assert!(r <= 0.3 + 1e-6 && (r - 0.3 * p[3]).abs() < 1e-5, "{p:?}");
        }
        // A (0,6,2)-net: each of the 64 ξ1 strata holds exactly one sample...
        let mut strata = [0u32; 64];
        for p in block {
            strata[(p[3] * 64.0) as usize] += 1;
        }
        assert!(strata.iter().all(|&c| c == 1), "{strata:?}");
        // ...and the weights estimate the texel count of the disc (∫ 2ξ dξ = 1) to within the stratification.
        let sum: f64 = block.iter().map(|p| f64::from(p[2])).sum();
        assert!((sum / texels - 1.0).abs() < 0.02, "{}", sum / texels);
    }
}

/// A GPU context, a built-in scene with its G-buffer rendered, for the GPU tests below.
#[test]
fn split_then_merge_reproduces_the_gbuffer_exactly() {
    use crate::frame::{ALBEDO_FORMAT, DISTANCE_FORMAT, MATERIAL_FORMAT, NORMAL_FORMAT};
    use crate::gpu::readback::read_texture;
    let f = fixture("cornell-spot", 61, 37);
    let ctx = &f.ctx;
    let formats = [(ALBEDO_FORMAT, 8), (NORMAL_FORMAT, 8), (MATERIAL_FORMAT, 8), (DISTANCE_FORMAT, 4)];
    let g = &f.frame.gbuffer;
    let originals: Vec<Vec<u8>> = [&g.albedo, &g.normal, &g.material, &g.distance]
        .iter()
        .zip(formats)
        .map(|(t, (_, bpp))| read_texture(ctx, t, bpp).expect("readback"))
        .collect();
    // The G-buffer is not trivial: some pixels see the scene.
    assert!(originals[3].chunks(4).any(|d| f32::from_le_bytes([d[0], d[1], d[2], d[3]]) > 0.0));
    for (n, m) in [(2, 2), (2, 4), (4, 4), (8, 8), (3, 5)] {
        let l = AtlasLayout::interleaved(61, 37, n, m);
        let split =
            interleave::SplitGBuffer::new(ctx, &f.frame, l, &f.gpu_scene.bind_group_layout).expect("split");
        let outputs: Vec<wgpu::Texture> =
            formats.iter().map(|(fmt, _)| compute::storage_texture(ctx, "merged", 61, 37, *fmt)).collect();
        let mut entries: Vec<wgpu::BindGroupLayoutEntry> = formats
            .iter()
            .enumerate()
            .map(|(i, (fmt, _))| storage_texture_entry(i as u32, *fmt, wgpu::StorageTextureAccess::WriteOnly))
            .collect();
        entries.extend(interleave::surface_entries(wgpu::ShaderStages::COMPUTE));
        let bgl = compute::layout(ctx, "merge gbuffer", &entries);
        let views: Vec<wgpu::TextureView> =
            outputs.iter().map(|t| t.create_view(&Default::default())).collect();
        let own: Vec<wgpu::BindingResource> = views.iter().map(wgpu::BindingResource::TextureView).collect();
        let group = split.bind_group(ctx, "merge gbuffer", &bgl, &own);
        let source = format!(
            "{}\n{}\n{}",
            interleave::ATLAS_WGSL,
            interleave::SURFACES_WGSL,
            include_str!("merge_gbuffer.wgsl")
        );
        let pipeline = compute::pipeline(
            ctx,
            "merge gbuffer",
            &source,
            l.defines(Defines::new()).bool("SPLIT_GBUFFER", true),
            "merge_gbuffer",
            &[&f.gpu_scene.bind_group_layout, &f.frame.bind_group_layout, &bgl],
        )
        .expect("pipeline");
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        split.record(&mut encoder, &f.gpu_scene.bind_group, &f.frame.bind_group);
        compute::dispatch_pixels(
            &mut encoder,
            "merge gbuffer",
            &pipeline,
            &[&f.gpu_scene.bind_group, &f.frame.bind_group, &group],
            61,
            37,
        );
        ctx.queue.submit([encoder.finish()]);
        for ((t, (_, bpp)), original) in outputs.iter().zip(formats).zip(&originals) {
            let merged = read_texture(ctx, t, bpp).expect("readback");
            assert!(merged == *original, "{n}x{m}: {:?} differs after split + merge", t.format());
        }
    }
}

#[test]
fn rsm_kernel_is_phi_over_d_squared_head_on() {
    use crate::gpu::readback::read_buffer;
    use wgpu::util::DeviceExt;
    let ctx = crate::gpu::GpuContext::new(&crate::gpu::GpuOptions::default()).expect("GPU adapter");
    let phi = 2.0f32;
    // (x_p, n_p, x, n, expected E): head-on at several distances, oblique, facing away, behind.
    let (s, c) = (0.6f32, 0.8f32);
    type Case = ([f32; 3], [f32; 3], [f32; 3], [f32; 3], f32);
    let cases: Vec<Case> = vec![
        ([0.0; 3], [0.0, 0.0, 1.0], [0.0, 0.0, 0.5], [0.0, 0.0, -1.0], phi / 0.25),
        ([0.0; 3], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0], phi),
        ([1.0, 2.0, 3.0], [0.0, 1.0, 0.0], [1.0, 5.0, 3.0], [0.0, -1.0, 0.0], phi / 9.0),
        // Oblique sender (cos 0.8), receiver facing it: Φ·cos/d².
        ([0.0; 3], [0.0, 0.0, 1.0], [2.0 * s, 0.0, 2.0 * c], [-s, 0.0, -c], phi * c / 4.0),
        // Receiver facing away, or behind the sender: nothing.
        ([0.0; 3], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], 0.0),
        ([0.0; 3], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.0, 0.0, 1.0], 0.0),
    ];
    let data: Vec<[f32; 16]> = cases
        .iter()
        .map(|(xp, np, x, n, _)| {
            [xp[0], xp[1], xp[2], phi, np[0], np[1], np[2], 0.0, x[0], x[1], x[2], 0.0, n[0], n[1], n[2], 0.0]
        })
        .collect();
    let input = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("cases"),
        contents: bytemuck::cast_slice(&data),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let output = compute::storage_buffer(&ctx, "results", cases.len() as u64 * 4);
    let bgl = compute::layout(
        &ctx,
        "kernel",
        &[compute::storage_buffer_entry(0, true), compute::storage_buffer_entry(1, false)],
    );
    let group =
        compute::bind_group(&ctx, "kernel", &bgl, &[input.as_entire_binding(), output.as_entire_binding()]);
    let source = format!(
        "{}\n{}",
        map::KERNEL_WGSL,
        r"
struct Case { xp: vec4f, np: vec4f, x: vec4f, n: vec4f }
@group(0) @binding(0) var<storage, read> cases: array<Case>;
@group(0) @binding(1) var<storage, read_write> results: array<f32>;
@compute @workgroup_size(1)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let c = cases[id.x];
    results[id.x] = rsm_irradiance(vec3f(c.xp.w), c.xp.xyz, c.np.xyz, c.x.xyz, c.n.xyz, 1e-8).x;
}
"
    );
    let pipeline =
        compute::pipeline(&ctx, "kernel", &source, Defines::new(), "main", &[&bgl]).expect("pipeline");
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    compute::dispatch(&mut encoder, "kernel", &pipeline, &[&group], [cases.len() as u32, 1, 1]);
    ctx.queue.submit([encoder.finish()]);
    let bytes = read_buffer(&ctx, &output, 0, cases.len() as u64 * 4).expect("readback");
    let got: &[f32] = bytemuck::cast_slice(&bytes);
    for (g, case) in got.iter().zip(&cases) {
        assert!((g - case.4).abs() <= 1e-5 * case.4.max(1.0), "E = {g}, expected {} for {case:?}", case.4);
    }
}

#[test]
fn every_vpl_reaches_exactly_one_sub_buffer() {
    use crate::gpu::readback::{read_buffer, read_texture};
    let (n, m, count) = (4u32, 2u32, 64u32);
    let (f, sii) =
        sii_frame(&[("interleave", "4x2"), ("vpls", "64"), ("rescale", "false"), ("splat", "raster")]);
    // Each VPL belongs to one sub-buffer, k mod N·M, so every sub-buffer gets count/(N·M).
    let bytes = read_buffer(&f.ctx, &sii.vpl_buffer, 0, u64::from(count) * 48).expect("vpls");
    let vpls: &[splat::GpuVpl] = bytemuck::cast_slice(&bytes);
    for (k, v) in vpls.iter().enumerate() {
        assert_eq!(v.subset, k as u32 % (n * m));
        assert!(v.intensity.iter().any(|&c| c > 0.0) && v.radius > 0.0, "VPL {k} is empty: {v:?}");
    }
    // Alpha counts splats per atlas texel: 1 per VPL of the texel's own sub-buffer, 65536 per foreign one.
    let atlas = read_texture(&f.ctx, &sii.atlas, 16).expect("atlas");
    let texels: &[f32] = bytemuck::cast_slice(&atlas);
    let l = AtlasLayout::interleaved(64, 48, n, m);
    let (aw, _) = l.size();
    let mut reached = vec![0.0f64; (n * m) as usize];
    for (i, t) in texels.chunks_exact(4).enumerate() {
        assert!(t[3] < 65536.0, "texel {i} received a VPL of another sub-buffer (alpha {})", t[3]);
        reached[l.subset((i as u32 % aw, i as u32 / aw)) as usize] += f64::from(t[3]);
    }
    // Every sub-buffer received splats: the cornell box fills the view and the VPLs reach the whole box.
    assert!(reached.iter().all(|&r| r > 0.0), "{reached:?}");
}

/// One `sii` frame with `settings` on cornell-spot at 64×48, and the fixture it ran on.
fn sii_frame(settings: &[(&str, &str)]) -> (crate::techniques::fixture::Fixture, splat::Splat) {
    let f = fixture("cornell-spot", 64, 48);
    let settings: Vec<(String, String)> =
        settings.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
    let (_, params) = crate::techniques::resolve("sii", &settings).expect("params");
    let setup = f.setup(&params);
    let mut sii = splat::Splat::new(&setup, super::interleave_param(&params).expect("pattern")).expect("sii");
    let fc = FrameContext::still(&f.ctx, &f.gpu_scene, &f.frame);
    crate::techniques::Technique::render_frame(
        &mut sii,
        &fc,
        &mut crate::gpu::Profiler::new(&f.ctx, crate::gpu::TimingMode::Passes),
    )
    .expect("frame");
    (f, sii)
}

/// The atlas of one `sii` frame with `settings` on cornell-spot at 64×48 (rgba, f32).
fn sii_atlas(settings: &[(&str, &str)]) -> (Vec<f32>, wgpu::TextureFormat) {
    let (f, sii) = sii_frame(settings);
    let format = sii.atlas.format();
    let bytes =
        crate::gpu::readback::read_texture(&f.ctx, &sii.atlas, format.block_copy_size(None).expect("size"))
            .expect("atlas");
    let texels = if format == wgpu::TextureFormat::Rgba32Float {
        bytemuck::cast_slice::<u8, f32>(&bytes).to_vec()
    } else {
        bytemuck::cast_slice::<u8, u16>(&bytes).iter().map(|h| half::f16::from_bits(*h).to_f32()).collect()
    };
    (texels, format)
}

/// The tiled compute splat, with each tile's VPLs read per texel and from workgroup memory, reaches the
/// texels the raster splat reaches, with the same sums: same VPLs, same order of addition. Whole image
/// and interleaved 4x2, with VPLs enough to span three 32-VPL words of the tile sets (an odd count: the
/// workgroup-memory pass reads them two at a time).
#[test]
fn tiled_splatting_equals_raster_splatting() {
    for (interleave, tiled) in
        [("1x1", "tiles-texel"), ("4x2", "tiles-texel"), ("1x1", "tiles-shared"), ("4x2", "tiles-shared")]
    {
        let common = [("interleave", interleave), ("vpls", "80"), ("splat_threshold", "0.1")];
        let (raster, format) = sii_atlas(&[common.as_slice(), &[("splat", "raster")]].concat());
        let (tiles, _) = sii_atlas(&[common.as_slice(), &[("splat", tiled)]].concat());
        assert_eq!(raster.len(), tiles.len());
        let mut worst = 0.0f32;
        let mut covered = 0;
        for (r, t) in raster.chunks_exact(4).zip(tiles.chunks_exact(4)) {
            assert_eq!(
                r[3], t[3],
                "{interleave} {tiled}: a texel got {} VPLs from the raster splat and {} from tiles",
                r[3], t[3]
            );
            covered += usize::from(r[3] > 0.0);
            for c in 0..3 {
                worst = worst.max((r[c] - t[c]).abs() / r[c].abs().max(1e-3));
            }
        }
        assert!(covered > raster.len() / 8, "{interleave} {tiled}: only {covered} texels splatted");
        // Measured 0 on lavapipe (the same f32 additions in the same order); a driver may contract the
        // shading into FMAs differently in a fragment and a compute shader, and the raster atlas is
        // rgba16float where blending rgba32float is unsupported.
        let allowed = if format == wgpu::TextureFormat::Rgba32Float { 1e-5 } else { 2e-3 };
        assert!(worst <= allowed, "{interleave} {tiled}: tiles differ from raster by {worst} (relative)");
    }
}

/// Sum over all RSM texels of the reflected flux Φ_p = π·I_p, per colour channel.
fn rsm_total_flux(ctx: &crate::gpu::GpuContext, rsm: &map::ReflectiveShadowMap) -> [f64; 3] {
    let mut sum = [0.0f64; 3];
    for layer in 0..rsm.views.len() as u32 {
        let temp = ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("rsm layer"),
            size: wgpu::Extent3d { width: rsm.size, height: rsm.size, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: map::INTENSITY_FORMAT,
            usage: wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &rsm.intensity,
                mip_level: 0,
                origin: wgpu::Origin3d { x: 0, y: 0, z: layer },
                aspect: wgpu::TextureAspect::All,
            },
            temp.as_image_copy(),
            wgpu::Extent3d { width: rsm.size, height: rsm.size, depth_or_array_layers: 1 },
        );
        ctx.queue.submit([encoder.finish()]);
        let bytes = crate::gpu::readback::read_texture(ctx, &temp, 16).expect("readback");
        for t in bytemuck::cast_slice::<u8, f32>(&bytes).chunks_exact(4) {
            for c in 0..3 {
                sum[c] += f64::from(t[c]) * std::f64::consts::PI;
            }
        }
    }
    sum
}

/// The RSM's texels carry all the light a light sends into a closed grey box (albedo 0.8), reflected:
/// 0.8 · 4π·I for a point light (six cube faces), 0.8 · I·∫cone for a spot light, 0.8 · E·A for a
/// directional light on the box's 2 m × 2 m top. This checks each view's texel solid angle or area.
#[test]
fn rsm_texels_carry_the_reflected_flux_of_every_light_type() {
    use crate::gpu::{GpuContext, GpuOptions, GpuScene, Profiler};
    use crate::scene::Light;
    use glam::Vec3;
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    let settings = [("emission".to_string(), "0".to_string()), ("albedo".to_string(), "0.8".to_string())];
    let base = crate::scene::builtin::build("furnace", &settings).expect("scene");
    let intensity = Vec3::new(1.0, 2.0, 3.0);
    let (inner, outer) = (20f64.to_radians(), 30f64.to_radians());
    // ∫ over the cone of the spot's squared linear ramp in cos θ, 2π sin θ dθ.
    let steps = 100_000;
    let cone: f64 = (0..steps)
        .map(|i| {
            let t = (i as f64 + 0.5) / steps as f64 * outer;
            let a = ((t.cos() - outer.cos()) / (inner.cos() - outer.cos())).clamp(0.0, 1.0);
            a * a * 2.0 * std::f64::consts::PI * t.sin() * (outer / steps as f64)
        })
        .sum();
    let cases = [
        (Light::Point { position: Vec3::new(0.1, 0.2, -0.3), intensity }, 4.0 * std::f64::consts::PI),
        (
            Light::Spot {
                position: Vec3::new(0.0, 0.5, 0.0),
                direction: Vec3::NEG_Y,
                intensity,
                inner_angle: inner as f32,
                outer_angle: outer as f32,
            },
            cone,
        ),
        (Light::Directional { direction: Vec3::NEG_Y, irradiance: intensity }, 4.0),
    ];
    for (light, factor) in cases {
        let mut scene = base.clone();
        scene.lights = vec![light];
        let gpu_scene = GpuScene::new(&ctx, &scene).expect("upload");
        let mut rsm = map::ReflectiveShadowMap::new(&ctx, &scene, &gpu_scene, 128).expect("rsm");
        rsm.render(&ctx, &gpu_scene, &mut Profiler::new(&ctx, crate::gpu::TimingMode::Passes))
            .expect("render");
        let got = rsm_total_flux(&ctx, &rsm);
        for c in 0..3 {
            let expected = 0.8 * f64::from(intensity[c]) * factor;
            assert!(
                (got[c] / expected - 1.0).abs() < 0.01,
                "{}: channel {c}: Σ Φ_p = {}, expected {expected}",
                light.kind_name(),
                got[c]
            );
        }
    }
}
