//! Shader validation, voxelisation of a known box, and cones through empty and walled volumes.

use super::*;
use crate::shaders::validate;

fn settings(grid: u32, anisotropic: bool, conservative: bool) -> ShaderSettings {
    ShaderSettings {
        grid,
        clips: 3,
        diffuse_cones: 5,
        diffuse_tan: 0.7,
        step: 0.5,
        max_distance: grid as f32,
        specular_cone: true,
        anisotropic,
        inject_samples: 4,
        conservative,
    }
}

#[test]
fn shaders_validate_and_the_volume_matches() {
    for (anisotropic, conservative) in [(true, true), (false, false)] {
        let defines = || settings(16, anisotropic, conservative).defines().u32("TILE", 8);
        validate("vxgi voxelization", &voxelize_source(), &defines());
        if conservative {
            let defines = defines().u32("MAX_WORKGROUPS", 65535);
            validate("vxgi conservative voxelization", &conservative_source(), &defines);
        }
        validate("vxgi injection", &inject_source(), &defines());
        validate("vxgi mips", &mips_source(), &defines());
        validate("vxgi scroll", &scroll_source(), &defines());
        let m = validate("vxgi cone tracing", &shade_source(), &defines());
        crate::shaders::layout::assert_layout(
            &m,
            "VxgiVolume",
            size_of::<VxgiVolume>(),
            &[
                ("clips", std::mem::offset_of!(VxgiVolume, clips)),
                ("corners", std::mem::offset_of!(VxgiVolume, corners)),
                ("shifts", std::mem::offset_of!(VxgiVolume, shifts)),
                ("boxes", std::mem::offset_of!(VxgiVolume, boxes)),
                ("origin", std::mem::offset_of!(VxgiVolume, origin)),
            ],
        );
    }
}

use crate::gpu::TimingMode;
use crate::gpu::readback::read_texture_level;
use crate::params::ParamValues;
use crate::techniques::fixture::Fixture;

fn vxgi_with(f: &Fixture, settings: &[(&str, &str)]) -> Vxgi {
    let settings: Vec<(String, String)> =
        settings.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
    let params = ParamValues::from_settings("vxgi", INFO.params, &settings).expect("params");
    Vxgi::new(&f.setup(&params)).expect("vxgi")
}

fn words(ctx: &GpuContext, texture: &wgpu::Texture) -> Vec<u32> {
    bytemuck::cast_slice(&read_texture_level(ctx, texture, 0).expect("readback")).to_vec()
}

/// Cones traced by a test entry point through `v`'s final volume: each probe is (origin, half-angle
/// tangent), (direction, max distance), world space; returns premultiplied radiance and opacity.
fn trace_probes(f: &Fixture, v: &Vxgi, probes: &[([f32; 4], [f32; 4])]) -> Vec<[f32; 4]> {
    let ctx = &f.ctx;
    let wgsl = format!(
        "{}\n@group(3) @binding(0) var<storage, read_write> probes: array<vec4f>;\n\
         @compute @workgroup_size(1) fn trace_probe(@builtin(global_invocation_id) id: vec3u) {{\n\
         let o = probes[3u * id.x]; let d = probes[3u * id.x + 1u];\n\
         probes[3u * id.x + 2u] = cone_trace(o.xyz, normalize(d.xyz), o.w, d.w, 1.0); }}",
        shade_source()
    );
    let data: Vec<[f32; 4]> = probes.iter().flat_map(|(o, d)| [*o, *d, [0.0; 4]]).collect();
    let buffer = compute::storage_buffer(ctx, "probes", (data.len() * 16) as u64);
    ctx.queue.write_buffer(&buffer, 0, bytemuck::cast_slice(&data));
    let layout = compute::layout(ctx, "probes", &[compute::storage_buffer_entry(0, false)]);
    let group = compute::bind_group(ctx, "probes", &layout, &[buffer.as_entire_binding()]);
    let layouts = [&f.gpu_scene.bind_group_layout, &f.frame.bind_group_layout, &v.layout, &layout];
    let pipeline = compute::pipeline(ctx, "probes", &wgsl, v.settings.defines(), "trace_probe", &layouts)
        .expect("pipeline");
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    {
        let groups = [&f.gpu_scene.bind_group, &f.frame.bind_group, &v.shade_group, &group];
        let mut pass = crate::gpu::dispatch::compute_pass(&mut encoder, "probes", &pipeline, &groups[..2]);
        pass.set_bind_group(2, groups[2], &[0]);
        pass.set_bind_group(3, groups[3], &[]);
        pass.dispatch_workgroups(probes.len() as u32, 1, 1);
    }
    ctx.queue.submit([encoder.finish()]);
    let out: Vec<[f32; 4]> = bytemuck::cast_slice(
        &crate::gpu::readback::read_buffer(ctx, &buffer, 0, buffer.size()).expect("readback"),
    )
    .to_vec();
    (0..probes.len()).map(|i| out[3 * i + 2]).collect()
}

/// A scene of `meshes` (material 0 white, 1 black) under a uniform environment, camera outside.
fn scene_of(meshes: Vec<crate::scene::Mesh>) -> crate::scene::Scene {
    use crate::scene::{Camera, Environment, Material, Scene};
    Scene {
        name: "vxgi test".into(),
        meshes,
        materials: vec![
            Material::diffuse("white", glam::Vec3::splat(0.8)),
            Material::diffuse("black", glam::Vec3::ZERO),
        ],
        environment: Environment::Uniform(glam::Vec3::ONE),
        camera: Camera {
            position: glam::Vec3::new(0.5, 0.5, 4.0),
            target: glam::Vec3::splat(0.5),
            ..Default::default()
        },
        ..Default::default()
    }
}

fn voxelized(f: &Fixture, settings: &[(&str, &str)]) -> Vxgi {
    let mut v = vxgi_with(f, settings);
    let fc = FrameContext::still(&f.ctx, &f.gpu_scene, &f.frame);
    v.render_frame(&fc, &mut Profiler::new(&f.ctx, TimingMode::Passes)).expect("frame");
    v
}

/// The box [0, 1]³ in a 16³ volume (a voxel of 1/14, one of margin): its faces lie on voxel faces, so
/// it must fill exactly the shell of voxels 1..=14 (a surface on a voxel face belongs to the voxel
/// behind it), with its albedo and, at each face's middle, that face's outward normal.
#[test]
fn voxelization_fills_exactly_the_cells_of_a_box() {
    let mut b = crate::scene::builtin::shapes::MeshBuilder::new();
    b.aabb(glam::Vec3::ZERO, glam::Vec3::ONE, 1.0);
    let f = crate::techniques::fixture::fixture_of(scene_of(vec![b.build("box", 0)]), 16, 16);
    let v = voxelized(&f, &[("resolution", "16")]);
    let camera = f.frame.view.camera.position;
    assert_eq!(v.volume.clips[0], place_volume(f.gpu_scene.bounds(), camera, 16, 1).clips[0]);
    let albedo = words(&f.ctx, &v.voxel_albedo);
    let normal = words(&f.ctx, &v.voxel_normal);
    let mut wrong = Vec::new();
    for z in 0..16usize {
        for y in 0..16usize {
            for x in 0..16usize {
                let c = [x, y, z];
                let inside = c.iter().all(|&k| (1..=14).contains(&k));
                let shell = inside && c.iter().any(|&k| k == 1 || k == 14);
                let word = albedo[(z * 16 + y) * 16 + x];
                if (word >> 24 > 0) != shell {
                    wrong.push(c);
                }
                if shell {
                    let r = (word & 0xff) as f32 / 255.0;
                    assert!((r - 0.8).abs() <= 1.0 / 255.0, "albedo {r} at {c:?}");
                }
            }
        }
    }
    assert!(wrong.is_empty(), "{} voxels wrong, e.g. {:?}", wrong.len(), &wrong[..wrong.len().min(8)]);
    // Face middles: (1, 7, 7) on −x, (14, 7, 7) on +x, (7, 1, 7) on −y ...
    for (c, n) in
        [([1, 7, 7], [-1, 0, 0]), ([14, 7, 7], [1, 0, 0]), ([7, 1, 7], [0, -1, 0]), ([7, 7, 14], [0, 0, 1])]
    {
        let w = normal[(c[2] * 16 + c[1]) * 16 + c[0]];
        let got: Vec<i8> = (0..3).map(|k| ((w >> (8 * k)) & 0xff) as u8 as i8).collect();
        let want: Vec<i8> = n.iter().map(|&k| (k * 127) as i8).collect();
        assert_eq!(got, want, "normal at {c:?}");
    }
}

/// Two parallel walls under a uniform environment: a white one (x = 0.25, facing −x, lit by the
/// environment) and a black one (x = 0.75, facing +x) behind it as seen from +x. A cone between them
/// along the walls crosses empty space: no opacity, no radiance (all it would see is the environment
/// beyond). A cone from −x sees the white wall's light; one from +x towards it meets the black wall
/// first and returns none of it: opaque, black. Measured on lavapipe: the white wall returns 0.7998
/// (albedo 0.8 × the environment's 1), the black wall 0 with opacity 1; a wide cone (tan 0.3) through
/// the black wall lets 0.058 through (7.2 % of the white wall's light).
fn two_walls() -> crate::techniques::fixture::Fixture {
    let mut white = crate::scene::builtin::shapes::MeshBuilder::new();
    white.axis_rect(0, 0.25, glam::Vec2::ZERO, glam::Vec2::ONE, -1.0, f32::INFINITY);
    let mut black = crate::scene::builtin::shapes::MeshBuilder::new();
    black.axis_rect(0, 0.75, glam::Vec2::ZERO, glam::Vec2::ONE, 1.0, f32::INFINITY);
    let mut scene = scene_of(vec![white.build("white", 0), black.build("black", 1)]);
    // Between the walls, near the white one: the finer clipmap levels are centred there (with 16³
    // levels, level 0 spans x 0.18-0.46 and holds the white wall, level 1 x 0-0.57).
    scene.camera.position = glam::Vec3::new(0.35, 0.5, 0.5);
    scene.camera.target = glam::Vec3::new(0.35, 0.5, 1.0);
    crate::techniques::fixture::fixture_of(scene, 16, 16)
}

/// The four probes of the two-walls scene: along the walls through empty space, from −x at the white
/// wall, from +x at the black wall (narrow and wide).
fn wall_probes(f: &Fixture, v: &Vxgi) -> Vec<[f32; 4]> {
    let reach = 64.0 * v.volume.clips[v.settings.clips as usize - 1][3];
    let probe =
        |p: [f32; 3], dir: [f32; 3], tan: f32| ([p[0], p[1], p[2], tan], [dir[0], dir[1], dir[2], reach]);
    trace_probes(
        f,
        v,
        &[
            probe([0.5, 0.5, 0.1], [0.0, 0.0, 1.0], 0.02),
            probe([0.0, 0.5, 0.5], [1.0, 0.0, 0.0], 0.02),
            probe([1.0, 0.5, 0.5], [-1.0, 0.0, 0.0], 0.02),
            probe([1.0, 0.5, 0.5], [-1.0, 0.0, 0.0], 0.3),
        ],
    )
}

/// Two parallel walls under a uniform environment: a white one (x = 0.25, facing −x, lit by the
/// environment) and a black one (x = 0.75, facing +x) behind it as seen from +x. A cone between them
/// along the walls crosses empty space: no opacity, no radiance (the environment beyond is the direct
/// pass's, not the voxels'). A cone from −x sees the white wall's light; one from +x towards it meets
/// the black wall first and returns none of it: opaque, black. Measured on lavapipe: the white wall
/// returns 0.7998 (albedo 0.8 × the environment's 1), the black wall 0 with opacity 1; a wide cone
/// (tan 0.3) through the black wall lets 0.058 through (7.2 % of the white wall's light).
#[test]
fn cones_cross_empty_space_and_stop_at_walls() {
    let f = two_walls();
    let v = voxelized(&f, &[("resolution", "32"), ("inject_samples", "64")]);
    let r = wall_probes(&f, &v);
    eprintln!("empty {:?} white {:?} through black {:?}, wide {:?}", r[0], r[1], r[2], r[3]);
    const LEAK: f32 = 0.072;
    assert_eq!(r[0], [0.0; 4], "a cone through empty space gathered something");
    assert!(r[1][3] > 0.99 && (r[1][0] - 0.8).abs() < 0.01, "the white wall: {:?}", r[1]);
    assert_eq!(r[2], [0.0, 0.0, 0.0, 1.0], "through the black wall: {:?}", r[2]);
    // A wide cone meets the wall in the coarse levels, where it is part of a voxel's opacity: what
    // leaks through is the method's (measured: LEAK of the white wall's light).
    assert!(
        r[3][3] > 0.8 && r[3][0] < 2.0 * LEAK * r[1][0],
        "a wide cone through the black wall: {:?}",
        r[3]
    );
}

/// Clipmaps: three levels of 16³ (voxels 1/56, 1/28, 1/14 of the walls' scene; the finer two centred
/// on the camera near the white wall, the black wall only in the coarsest). Every voxel a finer level fills lies in a voxel the next coarser
/// one fills (the same surfaces at twice the resolution), the finer levels hold the walls in their
/// voxels, and the probes read the same as through one volume of 32³: the white wall 0.8, the black
/// one opaque and black, empty space nothing. Measured on lavapipe: white wall 0.7998 with opacity 1.
#[test]
fn clipmap_levels_nest_and_cones_cross_them() {
    let f = two_walls();
    let v = voxelized(&f, &[("resolution", "16"), ("clipmap_levels", "3"), ("inject_samples", "64")]);
    let clips = v.volume.clips;
    for k in 0..2 {
        assert!((clips[k][3] * 2.0 - clips[k + 1][3]).abs() < 1e-6, "level {k}'s voxel");
        for a in 0..3 {
            let snapped = (clips[k][a] - clips[2][a]) / (2.0 * clips[k][3]);
            assert!((snapped - snapped.round()).abs() < 1e-3, "level {k} is off its 2-voxel lattice");
            assert_eq!(v.volume.corners[k][a] as f32, 2.0 * snapped.round(), "level {k}'s lattice corner");
        }
    }
    let albedo = words(&f.ctx, &v.voxel_albedo);
    let occupied = |k: usize, c: [usize; 3]| albedo[((k * 16 + c[2]) * 16 + c[1]) * 16 + c[0]] >> 24 > 0;
    let mut filled = [0usize; 3];
    for k in 0..3 {
        for z in 0..16 {
            for y in 0..16 {
                for x in 0..16 {
                    if !occupied(k, [x, y, z]) {
                        continue;
                    }
                    filled[k] += 1;
                    if k == 2 {
                        continue;
                    }
                    // The voxel's centre in the next level's voxels.
                    let world: [f32; 3] =
                        std::array::from_fn(|a| clips[k][a] + ([x, y, z][a] as f32 + 0.5) * clips[k][3]);
                    let c: [usize; 3] =
                        std::array::from_fn(|a| ((world[a] - clips[k + 1][a]) / clips[k + 1][3]) as usize);
                    assert!(
                        occupied(k + 1, c),
                        "level {k} voxel {:?} lies in an empty voxel {c:?} of level {}",
                        [x, y, z],
                        k + 1
                    );
                }
            }
        }
    }
    eprintln!("voxels filled per level: {filled:?}");
    assert!(filled[0] > 0 && filled[1] > 0, "the finer levels hold none of the walls: {filled:?}");
    let r = wall_probes(&f, &v);
    eprintln!("clipmaps: empty {:?} white {:?} through black {:?}, wide {:?}", r[0], r[1], r[2], r[3]);
    assert_eq!(r[0], [0.0; 4], "a cone through empty space gathered something");
    assert!(r[1][3] > 0.99 && (r[1][0] - 0.8).abs() < 0.01, "the white wall: {:?}", r[1]);
    assert_eq!(r[2], [0.0, 0.0, 0.0, 1.0], "through the black wall: {:?}", r[2]);
}

/// The slabs a level enters when it scrolls are disjoint and are exactly the voxels whose previous
/// place (c + shift) lay outside the level.
#[test]
fn entered_slabs_are_exactly_the_new_voxels() {
    let n = 8;
    for shift in [[2, 0, 0], [-2, 0, 0], [0, 4, -2], [2, -2, 6], [-6, 2, -4], [7, 7, 7]] {
        let slabs = entered_slabs(n as u32, shift);
        assert_eq!(slabs.len(), shift.iter().filter(|&&d| d != 0).count());
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let c = [x, y, z];
                    let new = (0..3).any(|a| !(0..n).contains(&(c[a] + shift[a])));
                    let holders =
                        slabs.iter().filter(|[lo, hi]| (0..3).all(|a| lo[a] <= c[a] && c[a] < hi[a])).count();
                    assert_eq!(holders, usize::from(new), "voxel {c:?} of a level scrolled by {shift:?}");
                }
            }
        }
    }
}

/// Renders `settings` with the camera at `from`, then at `to` (only the volume's placement follows the
/// camera; the G-buffer stays the fixture's), and checks that the volume carried along (scrolled, or
/// rebuilt where it moved with scroll=false) holds, bit for bit, the voxel words, radiance (both
/// bounces with two) and mips of a volume built where the levels now stand. Returns the carried one.
fn assert_scrolling_equals_building(
    f: &Fixture,
    settings: &[(&str, &str)],
    from: glam::Vec3,
    to: glam::Vec3,
) -> Vxgi {
    let at = |position: glam::Vec3| {
        let mut fc = FrameContext::still(&f.ctx, &f.gpu_scene, &f.frame);
        fc.view.camera.position = position;
        fc
    };
    let mut profiler = Profiler::new(&f.ctx, TimingMode::Passes);
    let mut scrolled = vxgi_with(f, settings);
    scrolled.render_frame(&at(from), &mut profiler).expect("frame");
    scrolled.render_frame(&at(to), &mut profiler).expect("frame");
    let mut built = vxgi_with(f, settings);
    built.render_frame(&at(to), &mut profiler).expect("frame");
    assert_eq!(scrolled.volume.clips, built.volume.clips);
    let ctx = &f.ctx;
    let directional = |v: &Vxgi| words(ctx, v.directional.as_ref().expect("anisotropic"));
    for (what, a, b) in [
        ("albedo", words(ctx, &scrolled.voxel_albedo), words(ctx, &built.voxel_albedo)),
        ("normal", words(ctx, &scrolled.voxel_normal), words(ctx, &built.voxel_normal)),
        ("radiance", words(ctx, &scrolled.lit[0]), words(ctx, &built.lit[0])),
        ("second bounce", words(ctx, &scrolled.lit[1]), words(ctx, &built.lit[1])),
        ("directional mip 1", directional(&scrolled), directional(&built)),
    ] {
        if what == "second bounce" && scrolled.bounces < 2 {
            continue;
        }
        let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        let nonzero = b.iter().filter(|&&w| w != 0).count();
        eprintln!("{what}: {differing} of {} words differ ({nonzero} non-zero)", a.len());
        assert!(nonzero > 0, "{what}: the volume is empty");
        assert_eq!(differing, 0, "{what}: the scrolled volume differs from one built in place");
    }
    // Every level holding light has it in its directional mip 1 too (its block: a slab of z).
    let (radiance, mip) = (words(ctx, &scrolled.lit[0]), directional(&scrolled));
    let levels = scrolled.settings.clips as usize;
    for k in 0..levels {
        let lit = |w: &[u32]| w.chunks(w.len() / levels).nth(k).is_some_and(|b| b.iter().any(|&x| x != 0));
        assert_eq!(lit(&radiance), lit(&mip), "level {k}: light in level 0 and in mip 1 disagree");
    }
    scrolled
}

/// Scrolling: cornell seen through three clipmap levels of 16³ from the middle of the box, where the
/// light reaches the finer levels; the camera then moves diagonally, so that they scroll along every
/// axis (level 0 by 6, −2 and 4 of its voxels, level 1 by 2, −2, 2). Both must scroll, not be rebuilt,
/// and hold what levels built in place hold (voxelisation and injection depend on lattice indices
/// alone: seeding injection's random numbers by texel instead makes 1022 radiance words differ).
#[test]
fn a_scrolled_clipmap_equals_one_built_in_place() {
    let f = crate::techniques::fixture::fixture("cornell", 16, 16);
    let settings = [("resolution", "16"), ("clipmap_levels", "3"), ("inject_samples", "4")];
    let middle = f.gpu_scene.bounds().center();
    let voxel = place_volume(f.gpu_scene.bounds(), middle, 16, 3).clips[0][3];
    let moved = middle + glam::Vec3::new(6.0, -2.0, 4.0) * voxel;
    let v = assert_scrolling_equals_building(&f, &settings, middle, moved);
    eprintln!("shifts {:?}, scrolls {}, rebuilds {}", v.volume.shifts, v.scrolls, v.rebuilds);
    assert_eq!(&v.volume.shifts[0][..3], &[6, -2, 4], "level 0's scroll");
    assert_eq!((v.scrolls, v.rebuilds), (2, 3), "the two finer levels scroll, once");
}

/// Without scrolling, two bounces: levels rebuilt where they moved must equal levels built there (the
/// one directional texture holds the second bounce's mips between frames, so the first bounce's must
/// be filtered again for the levels that did not move too: filtering only the moved ones makes 4158
/// second-bounce words differ on lavapipe).
#[test]
fn rebuilt_levels_with_two_bounces_equal_levels_built_in_place() {
    let f = crate::techniques::fixture::fixture("cornell", 16, 16);
    let settings = [
        ("resolution", "16"),
        ("clipmap_levels", "3"),
        ("inject_samples", "4"),
        ("bounces", "2"),
        ("scroll", "false"),
    ];
    let middle = f.gpu_scene.bounds().center();
    let voxel = place_volume(f.gpu_scene.bounds(), middle, 16, 3).clips[0][3];
    let moved = middle + glam::Vec3::new(6.0, -2.0, 4.0) * voxel;
    let v = assert_scrolling_equals_building(&f, &settings, middle, moved);
    assert_eq!((v.scrolls, v.rebuilds), (0, 5), "the two finer levels are rebuilt");
}

/// A surface on the face of a slab a scroll enters: the box [0, 1]³ in two levels of 16³ (level 0's
/// voxel 1/28, the box's −x face on the plane between lattice voxels 1 and 2, belonging to voxel 2).
/// The camera moves by −2 voxels along x so that level 0 enters lattice voxels 2 and 3, the face on
/// the slab's own face: the slab's rays start a voxel before it, so meeting the box's face does not
/// depend on how its distance rounds against the slab's start (on lavapipe it rounds above it here, so
/// rays starting on the face would meet it too).
#[test]
fn a_scroll_keeps_surfaces_on_the_faces_of_its_slabs() {
    let mut b = crate::scene::builtin::shapes::MeshBuilder::new();
    b.aabb(glam::Vec3::ZERO, glam::Vec3::ONE, 1.0);
    let f = crate::techniques::fixture::fixture_of(scene_of(vec![b.build("box", 0)]), 16, 16);
    let settings = [("resolution", "16"), ("clipmap_levels", "2"), ("inject_samples", "4")];
    let origin = place_volume(f.gpu_scene.bounds(), glam::Vec3::ZERO, 16, 2).origin[0];
    // Level 0's corner is 2·floor((x − origin) / (2 voxels)) − 8 voxels: 4, then 2.
    let camera = |x: f32| glam::Vec3::new(origin + x / 28.0, 0.45, 0.45);
    let v = assert_scrolling_equals_building(&f, &settings, camera(13.0), camera(11.0));
    assert_eq!(&v.volume.shifts[0][..3], &[-2, 0, 0], "level 0's scroll");
    assert_eq!(v.volume.corners[0][0], 2, "level 0's corner: {:?}", v.volume.corners);
    let albedo = words(&f.ctx, &v.voxel_albedo);
    // Lattice voxel 2 is level 0's voxel 0: the box's −x face fills it where y and z are inside.
    let filled = (0..16).filter(|&y| albedo[(8 * 16 + y) * 16] >> 24 > 0).count();
    assert!(filled > 0, "the box's face is missing from the slab");
}

/// Two bounces: a scrolled level keeps the second bounce its voxels gathered before the move, so after
/// eight scrolls the image differs a little from one rendered through levels built in place, and no
/// more. Cornell, three levels of 16³ (the fixture's view; only the volume follows the camera);
/// measured on lavapipe: mean |difference| / mean value 0.00040.
#[test]
fn two_bounces_scroll_close_to_a_rebuild() {
    let f = crate::techniques::fixture::fixture("cornell", 16, 16);
    let settings = [("resolution", "16"), ("clipmap_levels", "3"), ("inject_samples", "4"), ("bounces", "2")];
    let at = |position: glam::Vec3| {
        let mut fc = FrameContext::still(&f.ctx, &f.gpu_scene, &f.frame);
        fc.view.camera.position = position;
        fc
    };
    let image = || -> Vec<f32> {
        bytemuck::cast_slice(&read_texture_level(&f.ctx, &f.output, 0).expect("readback")).to_vec()
    };
    let middle = f.gpu_scene.bounds().center();
    let voxel = place_volume(f.gpu_scene.bounds(), middle, 16, 3).clips[0][3];
    // Eight steps of 2 voxels along x and z: the finer levels take in new slabs on most of them.
    let start = middle - glam::Vec3::new(8.0, 0.0, 8.0) * voxel;
    let step = glam::Vec3::new(2.0, 0.0, 2.0) * voxel;
    let mut profiler = Profiler::new(&f.ctx, TimingMode::Passes);
    let mut scrolled = vxgi_with(&f, &settings);
    for k in 0..=8 {
        scrolled.render_frame(&at(start + k as f32 * step), &mut profiler).expect("frame");
    }
    let moved = start + 8.0 * step;
    eprintln!("scrolls {}, rebuilds {}", scrolled.scrolls, scrolled.rebuilds);
    assert!(scrolled.scrolls >= 8 && scrolled.rebuilds == 3, "the finer levels scroll");
    let a = image();
    vxgi_with(&f, &settings).render_frame(&at(moved), &mut profiler).expect("frame");
    let b = image();
    let difference: f32 = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).sum();
    let relative = difference / b.iter().map(|y| y.abs()).sum::<f32>();
    eprintln!("two bounces, scrolled against built: mean |difference| / mean value {relative:.5}");
    const MEASURED: f32 = 0.0004;
    assert!(relative < 2.0 * MEASURED, "scrolled two-bounce image off by {relative}");
}

/// A triangle's corners in a volume's voxel units, and its authored normal.
type GridTriangle = ([glam::DVec3; 3], glam::DVec3);

/// Whether triangle `t` overlaps the cube about `centre` with half-edge `h` (f64): the CPU twin of
/// conservative.wgsl's separating-axis test.
fn triangle_overlaps_cube(t: [glam::DVec3; 3], centre: glam::DVec3, h: f64) -> bool {
    let [a, b, c] = t.map(|p| p - centre);
    let separated = |axis: glam::DVec3| {
        let p = [axis.dot(a), axis.dot(b), axis.dot(c)];
        let r = h * axis.abs().element_sum();
        p.iter().all(|&x| x > r) || p.iter().all(|&x| x < -r)
    };
    let units = [glam::DVec3::X, glam::DVec3::Y, glam::DVec3::Z];
    let edges = [b - a, c - b, a - c];
    !(units.iter().any(|&u| separated(u))
        || separated((b - a).cross(c - a))
        || edges.iter().any(|&e| units.iter().any(|&u| separated(u.cross(e)))))
}

/// A hundred small triangles (two claim workgroups; 0.3 to 6 voxels across, at random places and slopes, their authored normals on a
/// random side) in a 32³ volume, voxelised with `voxelization`. Returns, per voxel, whether it is
/// occupied, and the voxel's normal word; and the triangles in the volume's voxel units.
fn voxelized_triangles(voxelization: &str) -> (Vec<bool>, Vec<u32>, Vec<GridTriangle>) {
    use crate::scene::builtin::shapes::hash_unit;
    let mut b = crate::scene::builtin::shapes::MeshBuilder::new();
    let random = |i: u32, k: u32| hash_unit(&[i, k]);
    let mut authored = Vec::new();
    for i in 0..100u32 {
        let centre = glam::Vec3::new(random(i, 0), random(i, 1), random(i, 2)) * 0.8 + 0.1;
        // Sizes spread over a factor of 20 (log-uniform), in units of the scene (a voxel is about 1/30).
        let size = 0.01 * 20f32.powf(random(i, 3));
        let corner = |k: u32| {
            centre
                + (glam::Vec3::new(random(i, 4 + 3 * k), random(i, 5 + 3 * k), random(i, 6 + 3 * k)) - 0.5)
                    * size
        };
        let p = [corner(0), corner(1), corner(2)];
        let side = if random(i, 13) < 0.5 { -1.0 } else { 1.0 };
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize() * side;
        let v = p.map(|q| b.vertex(q, n, glam::Vec2::ZERO));
        b.triangle(v[0], v[1], v[2]);
        authored.push((p, n));
    }
    let f = crate::techniques::fixture::fixture_of(scene_of(vec![b.build("triangles", 0)]), 16, 16);
    let v = voxelized(&f, &[("resolution", "32"), ("voxelization", voxelization)]);
    let [x, y, z, cell] = v.volume.clips[0].map(f64::from);
    let to_grid = |p: glam::Vec3| (p.as_dvec3() - glam::DVec3::new(x, y, z)) / cell;
    let triangles = authored.iter().map(|(p, n)| (p.map(to_grid), n.as_dvec3())).collect();
    let occupied = words(&f.ctx, &v.voxel_albedo).iter().map(|w| w >> 24 > 0).collect();
    (occupied, words(&f.ctx, &v.voxel_normal), triangles)
}

/// Conservative voxelisation fills every voxel a triangle's area overlaps, and no other: against the
/// CPU twin of its overlap test, with the voxel's cube shrunk (must be filled) or grown (may be) by
/// 0.002 voxels, which covers the GPU's moving each triangle behind itself by FACE_TIE (0.001), the
/// cube's shrinking by CLAIM_SHRINK and rounding. A voxel only one triangle comes near holds that
/// triangle's albedo and authored normal. The column rays alone fill few of the voxels (measured on
/// lavapipe: 92 of 540), which is why the conservative pass exists.
#[test]
fn conservative_voxelization_fills_exactly_the_voxels_triangles_overlap() {
    const MARGIN: f64 = 0.002;
    let (occupied, normals, triangles) = voxelized_triangles("conservative");
    let n = 32usize;
    let (mut must, mut missed, mut extra, mut checked_normals) = (0, Vec::new(), Vec::new(), 0);
    for i in 0..n * n * n {
        let c = glam::DVec3::new((i % n) as f64, ((i / n) % n) as f64, (i / (n * n)) as f64) + 0.5;
        let near: Vec<&GridTriangle> =
            triangles.iter().filter(|(t, _)| triangle_overlaps_cube(*t, c, 0.5 + MARGIN)).collect();
        let inside = triangles.iter().any(|(t, _)| triangle_overlaps_cube(*t, c, 0.5 - MARGIN));
        must += usize::from(inside);
        if inside && !occupied[i] {
            missed.push(i);
        }
        if occupied[i] && near.is_empty() {
            extra.push(i);
        }
        if occupied[i] && near.len() == 1 {
            let w = normals[i];
            let got = glam::DVec3::from_array(std::array::from_fn(|k| {
                f64::from((w >> (8 * k)) as u8 as i8) / 127.0
            }));
            let want = near[0].1;
            assert!((got - want).abs().max_element() < 0.02, "voxel {i}: normal {got} for {want}");
            checked_normals += 1;
        }
    }
    let filled = occupied.iter().filter(|&&o| o).count();
    eprintln!("{filled} voxels filled, {must} must be; {checked_normals} normals checked");
    assert!(missed.is_empty(), "{} voxels missed, e.g. {:?}", missed.len(), &missed[..missed.len().min(8)]);
    assert!(
        extra.is_empty(),
        "{} voxels no triangle overlaps, e.g. {:?}",
        extra.len(),
        &extra[..extra.len().min(8)]
    );
    assert!(checked_normals > must / 2, "too few voxels with one triangle: {checked_normals}");

    let (columns, _, _) = voxelized_triangles("columns");
    let by_columns = columns.iter().zip(&occupied).filter(|(c, o)| **c && **o).count();
    eprintln!("the column rays alone fill {by_columns} of them");
    assert!(
        columns.iter().zip(&occupied).all(|(c, o)| !c || *o),
        "a column voxel the conservative pass lacks"
    );
    assert!(by_columns < filled, "the column rays alone fill every voxel: the test proves nothing");
}
