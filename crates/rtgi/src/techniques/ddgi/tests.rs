use std::mem::offset_of;

use super::*;
use crate::gpu::TimingMode;
use crate::gpu::readback::read_texture;
use crate::params::ParamValues;
use crate::shaders::{layout::assert_layout, validate};
use crate::techniques::fixture::fixture_with;

fn test_defines() -> Defines {
    flag_defines(Defines::new())
        .vec3u("PROBE_COUNTS", [4, 2, 3])
        .vec3f("FIRST_PROBE", [0.0; 3])
        .vec3f("PROBE_SPACING", [1.0; 3])
        .u32("ATLAS_COLUMNS", 5)
        .bool("ATLAS_STOCHASTIC", true)
        .f32("ATLAS_RELATIVE_STEP", 2f32.powi(-10))
        .f32("ATLAS_ABSOLUTE_STEP", 2f32.powi(-24))
        .f32("ATLAS_MIN_NORMAL", 2f32.powi(-14))
        .u32("IRRADIANCE_TEXELS", 8)
        .u32("DISTANCE_TEXELS", 16)
        .u32("RAYS", 64)
        .f32("MAX_DISTANCE", 2.5)
        .f32("DISTANCE_EXPONENT", 50.0)
        .f32("NORMAL_BIAS", 0.05)
        .f32("VIEW_BIAS", 0.2)
        .bool("BACKFACE_WEIGHT", true)
        .bool("CHEBYSHEV", true)
        .bool("LOW_WEIGHT_CRUSH", true)
        .bool("EMITTERS_IN_PROBES", false)
        .u32("SURFEL_AREA_SAMPLES", 1)
        .u32("SURFEL_ENV_SAMPLES", 1)
        .u32("TILE", 8)
        .u32("CLASSIFY_RAYS", CLASSIFY_RAYS)
        .f32("BACKFACE_THRESHOLD", BACKFACE_THRESHOLD)
        .f32("MIN_SURFACE_DISTANCE", 0.1)
        .f32("RELOCATION_LIMIT", 0.45)
        .bool("RELOCATION", true)
        .bool("CLASSIFICATION", true)
        .bool("REFLECTION_RAY", true)
        .f32("REFLECTION_ROUGHNESS", 0.6)
}

#[test]
fn shaders_validate_and_the_frame_uniform_matches() {
    let update = format!("{VOLUME_WGSL}\n{}", include_str!("update.wgsl"));
    for format in ["rgba16float", "rg16float"] {
        validate("probe update", &update.replace("ATLAS_FORMAT", format), &test_defines());
    }
    validate("probe state", &format!("{VOLUME_WGSL}\n{}", include_str!("state.wgsl")), &test_defines());
    validate(
        "probe trace",
        &format!("{VOLUME_WGSL}\n{QUERY_WGSL}\n{}", include_str!("trace.wgsl")),
        &test_defines(),
    );
    let m = validate(
        "probe sampling",
        &format!("{VOLUME_WGSL}\n{QUERY_WGSL}\n{}", include_str!("shade.wgsl")),
        &test_defines(),
    );
    assert_layout(
        &m,
        "ProbeFrame",
        size_of::<ProbeFrame>(),
        &[
            ("rotation", offset_of!(ProbeFrame, rotation)),
            ("scroll", offset_of!(ProbeFrame, scroll)),
            ("hysteresis", offset_of!(ProbeFrame, hysteresis)),
            ("previous_scroll", offset_of!(ProbeFrame, previous_scroll)),
            ("update_start", offset_of!(ProbeFrame, update_start)),
            ("update_count", offset_of!(ProbeFrame, update_count)),
            ("classify", offset_of!(ProbeFrame, classify)),
        ],
    );
    assert_layout(
        &m,
        "ProbeState",
        size_of::<ProbeState>(),
        &[("offset", offset_of!(ProbeState, offset)), ("flags", offset_of!(ProbeState, flags))],
    );
}

#[test]
fn octahedral_texels_round_trip_through_their_directions() {
    for interior in [2, 6, 8, 16] {
        for y in 0..interior {
            for x in 0..interior {
                let d = texel_direction([x, y], interior);
                assert!((d.length() - 1.0).abs() < 1e-5);
                assert_eq!(direction_texel(d, interior), [x, y], "interior {interior}");
                let e = oct_encode(d);
                assert!((oct_decode(e) - d).length() < 1e-5, "{d}");
            }
        }
    }
}

/// Folds a point of the octahedral square's plane that lies beyond an edge back inside: across the
/// edge x = ±1 the map continues mirrored in y, and likewise for y (the octahedron's lower faces
/// meet along the square's edges). Derived from the geometry, independently of `gutter_source`.
fn fold(mut e: Vec2) -> Vec2 {
    if e.x.abs() > 1.0 {
        e = Vec2::new(e.x.signum() * (2.0 - e.x.abs()), -e.y);
    }
    if e.y.abs() > 1.0 {
        e = Vec2::new(-e.x, e.y.signum() * (2.0 - e.y.abs()));
    }
    e
}

#[test]
fn every_gutter_texel_holds_its_octahedral_neighbour() {
    for interior in [2, 6, 8, 16] {
        for y in 0..interior + 2 {
            for x in 0..interior + 2 {
                // The gutter texel's centre continues the interior grid one texel beyond the edge.
                let e = Vec2::from([x, y].map(|c| (c as f32 - 0.5) / interior as f32 * 2.0 - 1.0));
                let expected = direction_texel(oct_decode(fold(e)), interior);
                assert_eq!(gutter_source([x, y], interior), expected, "texel ({x}, {y}) of {interior}");
            }
        }
    }
}

#[test]
fn the_grid_puts_probes_on_both_sides_of_the_two_rooms_wall() {
    use crate::scene::builtin::two_rooms::{ROOM_HEIGHT, room_x_ranges};
    let scene = crate::scene::builtin::build("two-rooms", &[]).expect("scene");
    let grid = ProbeGrid::fit(scene.bounds(), 8);
    assert_eq!(grid.counts[0], 8, "{grid:?}");
    // Every room holds a full cage: at least two probe planes inside it along every axis.
    for (lo, hi) in room_x_ranges() {
        let inside = (0..grid.counts[0]).filter(|&i| (lo..hi).contains(&grid.position([i, 0, 0]).x)).count();
        assert!(inside >= 2, "{inside} probe planes in x ∈ [{lo}, {hi}]: {grid:?}");
    }
    let heights = (0..grid.counts[1]).filter(|&j| (0.0..ROOM_HEIGHT).contains(&grid.position([0, j, 0]).y));
    assert!(heights.count() >= 2, "{grid:?}");
}

/// `probe_count=XxYxZ` lays exactly those counts over the bounds, each probe centred in its cell (the
/// paper's 32×8×32 on atrium, whose longest-axis fit would give 32×9×16).
#[test]
fn exact_probe_counts_cover_the_bounds_cell_by_cell() {
    let scene = crate::scene::builtin::build("atrium", &[]).expect("scene");
    let bounds = scene.bounds();
    let p = params(&[("probe_count", "32x8x32")]);
    let GridCounts::Exact(counts) = p.grid_counts("probe_count") else { panic!("not exact counts") };
    let grid = ProbeGrid::with_counts(bounds, counts);
    assert_eq!(grid.counts, [32, 8, 32]);
    assert_eq!(grid.probes(), 8192);
    let (first, last) = (grid.position([0, 0, 0]), grid.position([31, 7, 31]));
    let extent = bounds.max - bounds.min;
    assert!(((first - bounds.min) - grid.spacing * 0.5).abs().max_element() < 1e-4 * extent.max_element());
    assert!(((bounds.max - last) - grid.spacing * 0.5).abs().max_element() < 1e-4 * extent.max_element());
    assert_ne!(ProbeGrid::fit(bounds, 32).counts, [32, 8, 32]);
}

fn params(settings: &[(&str, &str)]) -> ParamValues {
    let settings: Vec<(String, String)> =
        settings.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
    ParamValues::from_settings("ddgi", &DDGI_PARAMS, &settings).expect("params")
}

/// Reads an atlas as RGBA f32 texels (formats rgba32float and rgba16float).
fn read_atlas(ctx: &GpuContext, atlas: &Atlas, which: usize) -> Vec<[f32; 4]> {
    let bytes =
        read_texture(ctx, &atlas.textures[which], texel_bytes(atlas.format) as u32).expect("readback");
    match atlas.format {
        wgpu::TextureFormat::Rgba32Float => bytemuck::cast_slice::<u8, [f32; 4]>(&bytes).to_vec(),
        wgpu::TextureFormat::Rgba16Float => bytemuck::cast_slice::<u8, [u16; 4]>(&bytes)
            .iter()
            .map(|t| t.map(|h| half::f16::from_bits(h).to_f32()))
            .collect(),
        wgpu::TextureFormat::Rg16Float => bytemuck::cast_slice::<u8, [u16; 2]>(&bytes)
            .iter()
            .map(|t| [half::f16::from_bits(t[0]).to_f32(), half::f16::from_bits(t[1]).to_f32(), 0.0, 1.0])
            .collect(),
        other => panic!("no reader for {other:?}"),
    }
}

/// The texels of the atlas's probe tiles (the atlas's last row may have unused tiles).
fn tile_texels(atlas: &Atlas, probes: u32) -> Vec<(u32, [u32; 2], usize)> {
    let edge = atlas.layout.interior + 2;
    let (w, _) = atlas.layout.size();
    let mut out = Vec::new();
    for probe in 0..probes {
        for y in 0..edge {
            for x in 0..edge {
                let ax = (probe % atlas.layout.columns) * edge + x;
                let ay = (probe / atlas.layout.columns) * edge + y;
                out.push((probe, [x, y], (ay * w + ax) as usize));
            }
        }
    }
    out
}

/// The fixture's view at frame `frame`.
fn frame_context(f: &crate::techniques::fixture::Fixture, frame: u32) -> FrameContext<'_> {
    let mut view = f.frame.view;
    view.frame_counter = frame;
    view.sample_index = frame;
    FrameContext {
        ctx: &f.ctx,
        gpu_scene: &f.gpu_scene,
        frame: &f.frame,
        view,
        next: None,
        prediction_held: true,
    }
}

/// Fills the probe rays with radiance `l` (all hits at distance 1) and runs one update.
fn update_with_uniform_rays(ddgi: &mut Ddgi, f: &crate::techniques::fixture::Fixture, l: f32, frame: u32) {
    let mut profiler = Profiler::new(&f.ctx, TimingMode::Passes);
    ddgi.begin_frame(&frame_context(f, frame), &mut profiler).expect("probe state");
    let rays = vec![[l, l, l, 1.0f32]; (ddgi.grid.probes() * ddgi.rays_per_probe) as usize];
    f.ctx.queue.write_buffer(&ddgi.ray_data, 0, bytemuck::cast_slice(&rays));
    ddgi.update_probes(&f.ctx, &mut profiler).expect("update");
}

/// Uniform incoming radiance L gives irradiance πL in every texel on the first update, and after a step
/// to L' the residual decays as α^k: E_k = πL' + π(L − L')α^k (45 updates to 10 % at α = 0.95).
/// Gutters hold exactly their interior twins throughout.
#[test]
fn uniform_radiance_gives_pi_l_and_a_step_decays_as_the_hysteresis_power() {
    let f = fixture_with("furnace", &[], 8, 8);
    // Classification off: it would switch off the probes with no wall within a cell.
    let p = params(&[
        ("format", "rgba32float"),
        ("hysteresis", "0.95"),
        ("probe_count", "3"),
        ("classification", "false"),
    ]);
    let mut ddgi = Ddgi::new(&f.setup(&p)).expect("ddgi");
    let probes = ddgi.grid.probes();
    let pi = std::f32::consts::PI;
    update_with_uniform_rays(&mut ddgi, &f, 0.5, 0);
    let texels = read_atlas(&f.ctx, &ddgi.irradiance, ddgi.current());
    for (probe, t, i) in tile_texels(&ddgi.irradiance, probes) {
        for c in 0..3 {
            assert!((texels[i][c] - 0.5 * pi).abs() < 1e-5, "probe {probe} texel {t:?}: {:?}", texels[i]);
        }
    }
    let (from, to) = (0.5f32, 2.0f32);
    let mut residual_at = Vec::new();
    for k in 1..=46u32 {
        update_with_uniform_rays(&mut ddgi, &f, to, k);
        let texels = read_atlas(&f.ctx, &ddgi.irradiance, ddgi.current());
        let expected = pi * to + pi * (from - to) * 0.95f32.powi(k as i32);
        let layout = ddgi.irradiance.layout;
        for (probe, t, i) in tile_texels(&ddgi.irradiance, probes) {
            assert!((texels[i][0] - expected).abs() < 1e-4 * expected, "update {k}, probe {probe}, {t:?}");
            let s = gutter_source(t, layout.interior);
            let [sx, sy] = layout.texel(probe, s);
            assert_eq!(
                texels[i],
                texels[(sy * layout.size().0 + sx) as usize],
                "gutter {t:?} of probe {probe}"
            );
        }
        residual_at.push((texels[tile_texels(&ddgi.irradiance, 1)[11].2][0] - pi * to) / (pi * (from - to)));
    }
    // 0.95^44 = 0.105, 0.95^45 = 0.0994: the 45th update is the first below 10 %.
    assert!(residual_at[43] > 0.1 && residual_at[44] < 0.1, "{:?}", &residual_at[42..46]);
}

/// A half-float atlas follows the exact blend on average at α = 0.98, although its increments fall below
/// an f16 step long before the target (1 − α of the gap), where a plain blend stalls up to
/// step / (1 − α) short (measured before blend_stored: 2.5 % of the converged image's luminance on
/// cornell-spot at α = 0.98, against rgba32float's; within 0.04 % of it at α = 0.85). From πL = 1.57 to
/// πL' = 4.08 (f16 step 2^-8 there), a plain blend stalls 0.096 low (measured).
#[test]
fn a_half_float_atlas_converges_within_its_storage_step() {
    let f = fixture_with("furnace", &[], 8, 8);
    let p = params(&[
        ("format", "rgba16float"),
        ("hysteresis", "0.98"),
        ("probe_count", "3"),
        ("classification", "false"),
    ]);
    let mut ddgi = Ddgi::new(&f.setup(&p)).expect("ddgi");
    let probes = ddgi.grid.probes();
    let target = std::f32::consts::PI * 1.3;
    update_with_uniform_rays(&mut ddgi, &f, 0.5, 0);
    // 0.98^400 = 3e-4 of the 2.5 gap: the plain blend's own residual is far below a step.
    for k in 1..=400u32 {
        update_with_uniform_rays(&mut ddgi, &f, 1.3, k);
    }
    let texels = read_atlas(&f.ctx, &ddgi.irradiance, ddgi.current());
    let step = 2f32.powi(-8);
    let values: Vec<f32> = tile_texels(&ddgi.irradiance, probes)
        .into_iter()
        .flat_map(|(_, _, i)| texels[i][..3].to_vec())
        .collect();
    let mean = values.iter().map(|&v| f64::from(v)).sum::<f64>() / values.len() as f64;
    // The blend's own residual after 400 updates: 0.98^400 of the 2.5 gap, 0.2 steps.
    let expected = target + (std::f32::consts::PI * 0.5 - target) * 0.98f32.powi(400);
    let bias = (mean as f32 - expected) / step;
    let largest = values.iter().map(|v| (v - target).abs() / step).fold(0.0, f32::max);
    eprintln!("{} texels: mean {bias:+.3} steps from the blend's, farthest {largest:.1} steps", values.len());
    // Measured: mean -0.000 steps from the exact blend's value, farthest 3.5 (stochastic rounding
    // leaves each texel a random walk of about a step around it, unbiased; the mean of 8100 texels
    // scatters by ~0.02); a plain blend stalls 24.5 steps low on every texel.
    assert!(bias.abs() < 0.05, "mean {bias} steps from {expected}");
    assert!(largest <= 5.0, "a texel {largest} steps from {target}");
}

/// The white furnace (every wall emits L_e and reflects ρ): the radiance everywhere is L_e / (1 − ρ).
/// With emitters=probes the probes carry all of it, so every probe's irradiance must converge to
/// π·L_e / (1 − ρ) in every direction — all bounces, added one per frame through the previous frame's
/// probes — and every pixel to L_e / (1 − ρ). With emitters=direct, pixels and probe hits sample the
/// walls' emission with shadow rays and the probes carry the reflected part, π·(L_e / (1 − ρ) − L_e).
#[test]
fn the_furnace_converges_to_its_exact_radiance_through_the_probes() {
    let mut f = fixture_with("furnace", &[("albedo", "0.5"), ("emission", "0.5")], 32, 32);
    let (emission, exact) = (0.5, 0.5 / (1.0 - 0.5));
    let pi = std::f32::consts::PI;
    for emitters in ["probes", "direct"] {
        // α = 0.5: each frame multiplies the remaining error by α + (1 − α)ρ = 0.75; 0.75^60 ≈ 3e-8.
        let p = params(&[
            ("emitters", emitters),
            ("hysteresis", "0.5"),
            ("probe_count", "4"),
            ("rays", "128"),
            ("classification", "false"),
        ]);
        let mut ddgi = Ddgi::new(&f.setup(&p)).expect("ddgi");
        f.render_frames(&mut ddgi, 60);
        let atlas = read_atlas(&f.ctx, &ddgi.irradiance, ddgi.current());
        let expected = pi * if emitters == "probes" { exact } else { exact - emission };
        let texels: Vec<f32> = tile_texels(&ddgi.irradiance, ddgi.grid.probes())
            .iter()
            .map(|&(_, _, i)| atlas[i][0] / expected)
            .collect();
        let image = read_texture(&f.ctx, &f.output, 16).expect("image");
        let pixels: Vec<f32> =
            bytemuck::cast_slice::<u8, [f32; 4]>(&image).iter().map(|p| p[0] / exact).collect();
        let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len() as f32;
        let worst = |v: &[f32]| v.iter().map(|x| (x - 1.0).abs()).fold(0.0, f32::max);
        let (texel_mean, pixel_mean) = (mean(&texels), mean(&pixels));
        let (texel_worst, pixel_worst) = (worst(&texels), worst(&pixels));
        eprintln!(
            "emitters={emitters}: texels {texel_mean:.4} (worst {texel_worst:.2e}), pixels {pixel_mean:.4} (worst {pixel_worst:.2e})"
        );
        if emitters == "probes" {
            // Noise-free (every ray sees the same radiance): measured on lavapipe worst texel 2.2e-3 and
            // pixel 1.1e-3, the rounding of the rgba16float atlas.
            assert!(texel_worst < 5e-3 && pixel_worst < 3e-3, "{texel_worst} {pixel_worst}");
        } else {
            // Light sampling of the walls is noisy and heavy-tailed near the box's edges (the `direct`
            // pass alone is 0.4 % low over the image, up to 7 % near edges, at 800 samples per pixel).
            // Measured on lavapipe: texels 2.5 % low on average, pixels 1.0 % low.
            assert!((texel_mean - 1.0).abs() < 0.05, "texels {texel_mean}");
            assert!((pixel_mean - 1.0).abs() < 0.02, "pixels {pixel_mean}");
        }
    }
}

/// Cornell's two blocks hold some of an 8×8×8 grid's probes (without relocation 6.7 % of all probe
/// rays hit back faces, measured). Relocation moves the probes near a block's faces out, so at least
/// a third of those rays go (measured: 3.0 % remain, from the probes deeper inside than the 0.45-cell
/// limit lets them leave), every offset within the limit; probes away from surfaces stay on their
/// lattice points.
#[test]
fn relocation_moves_probes_out_of_the_blocks_within_the_limit() {
    let mut f = fixture_with("cornell", &[], 16, 16);
    let mut fraction = Vec::new();
    for relocation in ["false", "true"] {
        let p = params(&[("relocation", relocation), ("classification", "false")]);
        let mut ddgi = Ddgi::new(&f.setup(&p)).expect("ddgi");
        f.render_frames(&mut ddgi, 2);
        let (back, traced) = ddgi.ray_counts(&f.ctx).expect("ray stats");
        fraction.push(f64::from(back) / f64::from(traced));
        let states = ddgi.read_states(&f.ctx).expect("states");
        let spacing = ddgi.grid.spacing;
        let moved: Vec<f32> =
            states.iter().map(|s| (Vec3::from(s.offset) / spacing).abs().max_element()).collect();
        let relocated = moved.iter().filter(|&&m| m > 0.0).count();
        eprintln!(
            "relocation={relocation}: back-face rays {:.4}, {relocated} probes moved",
            fraction.last().unwrap()
        );
        assert!(moved.iter().all(|&m| m <= 0.45 + 1e-5), "{moved:?}");
        if relocation == "true" {
            // Measured: 33 of 512 moved.
            assert!((10..100).contains(&relocated), "{relocated}");
        } else {
            assert_eq!(relocated, 0);
        }
    }
    assert!(fraction[0] > 0.03 && fraction[1] < 0.67 * fraction[0], "{fraction:?}");
}

/// In the furnace (a closed box lit from its walls) a 4×4×4 grid's outer shell of probes stands half a
/// spacing from the walls and the inner 2×2×2 one and a half: classification keeps exactly the shell
/// (the only probes with a surface within one spacing), and an inactive probe is neither traced nor
/// updated: its atlas tile stays as created.
#[test]
fn classification_keeps_exactly_the_probes_with_a_surface_within_a_cell() {
    let mut f = fixture_with("furnace", &[], 16, 16);
    let p = params(&[("probe_count", "4"), ("relocation", "false"), ("format", "rgba32float")]);
    let mut ddgi = Ddgi::new(&f.setup(&p)).expect("ddgi");
    f.render_frames(&mut ddgi, 3);
    let states = ddgi.read_states(&f.ctx).expect("states");
    assert_eq!(ddgi.grid.counts, [4, 4, 4]);
    for (slot, s) in states.iter().enumerate() {
        let g = [slot % 4, slot / 4 % 4, slot / 16].map(|c| c as u32);
        let shell = g.iter().any(|&c| c == 0 || c == 3);
        assert_eq!(s.flags & PROBE_ACTIVE != 0, shell, "probe {g:?}: {s:?}");
        assert_eq!(s.flags & PROBE_VALID != 0, shell, "probe {g:?}: {s:?}");
    }
    let (_, traced) = ddgi.ray_counts(&f.ctx).expect("ray stats");
    assert_eq!(traced, 3 * 56 * ddgi.rays_per_probe);
    let atlas = read_atlas(&f.ctx, &ddgi.irradiance, ddgi.current());
    for (probe, t, i) in tile_texels(&ddgi.irradiance, 64) {
        let shell = states[probe as usize].flags & PROBE_ACTIVE != 0;
        assert_eq!(atlas[i][0] > 0.0, shell, "probe {probe} texel {t:?}: {:?}", atlas[i]);
    }
}

/// With probes_per_frame = k, frame n traces and updates the k probes from slot n·k on (wrapping):
/// after each frame exactly the probes updated so far are valid, each blends only from its second
/// update on, and the others' atlas tiles are untouched.
#[test]
fn an_update_budget_walks_through_the_probes_in_turn() {
    let mut f = fixture_with("furnace", &[("emission", "1")], 16, 16);
    let p = params(&[
        ("probe_count", "3"),
        ("probes_per_frame", "10"),
        ("relocation", "false"),
        ("classification", "false"),
        ("format", "rgba32float"),
    ]);
    let mut ddgi = Ddgi::new(&f.setup(&p)).expect("ddgi");
    let probes = ddgi.grid.probes() as usize;
    assert_eq!(probes, 27);
    for frame in 1..=4usize {
        f.render_frames(&mut ddgi, 1);
        let states = ddgi.read_states(&f.ctx).expect("states");
        let updated = (frame * 10).min(probes);
        let atlas = read_atlas(&f.ctx, &ddgi.irradiance, ddgi.current());
        for (slot, s) in states.iter().enumerate() {
            assert_eq!(s.flags & PROBE_VALID != 0, slot < updated, "frame {frame}, probe {slot}: {s:?}");
            // Blending from the frame after the first update: slots updated before this frame.
            let blended = slot < (frame - 1) * 10;
            assert_eq!(s.flags & PROBE_BLEND != 0, blended, "frame {frame}, probe {slot}: {s:?}");
        }
        for (probe, t, i) in tile_texels(&ddgi.irradiance, probes as u32) {
            assert_eq!(atlas[i][0] > 0.0, (probe as usize) < updated, "frame {frame} probe {probe} {t:?}");
        }
        assert_eq!(
            ddgi.ray_counts(&f.ctx).expect("ray stats").1 as usize,
            (frame * 10) * ddgi.rays_per_probe as usize
        );
    }
}

/// A camera-centred volume scrolls in whole cells: moving the camera by less than half a cell keeps
/// every probe, by one cell along x reuses only the slots of the plane left behind (fresh: not valid,
/// offset cleared) for the plane entered, and the query's lattice follows.
#[test]
fn a_camera_volume_scrolls_by_whole_cells_and_refreshes_only_the_entered_plane() {
    let mut f = fixture_with("furnace", &[], 16, 16);
    let p = params(&[("volume", "camera"), ("probe_count", "4"), ("classification", "false")]);
    let mut ddgi = Ddgi::new(&f.setup(&p)).expect("ddgi");
    let grid = ddgi.grid;
    // Where the volume starts exactly at cell 1 (rounding far from its half-way points).
    let camera = grid.first + grid.spacing * 2.5;
    let start = grid.scroll_for(camera);
    assert_eq!(start, [1, 1, 1]);
    assert_eq!(grid.scroll_for(camera + grid.spacing * 0.3), start);
    let mut moved = start;
    moved[0] += 1;
    assert_eq!(grid.scroll_for(camera + Vec3::X * grid.spacing.x), moved);
    let run = |f: &mut crate::techniques::fixture::Fixture, ddgi: &mut Ddgi, position: Vec3| {
        let mut view = f.frame.view;
        view.camera.position = position;
        f.frame.set_view(&f.ctx, &view, 0);
        f.render_frames(ddgi, 1);
        ddgi.read_states(&f.ctx).expect("states")
    };
    run(&mut f, &mut ddgi, camera);
    let before = run(&mut f, &mut ddgi, camera + grid.spacing * 0.3);
    assert!(before.iter().all(|s| s.flags & PROBE_BLEND != 0), "{before:?}");
    let after = run(&mut f, &mut ddgi, camera + Vec3::X * grid.spacing.x);
    assert_eq!(ddgi.scroll, Some(moved));
    // Slot x ≡ the entered plane's cell (moved.x + 3) mod 4 is the one that was left (start.x).
    let entered = (moved[0] + 3).rem_euclid(4) as usize;
    assert_eq!(entered, start[0].rem_euclid(4) as usize);
    for (slot, s) in after.iter().enumerate() {
        let fresh = slot % 4 == entered;
        // A fresh probe is updated this frame (valid) but replaces its texels instead of blending.
        assert_eq!(s.flags & PROBE_BLEND == 0, fresh, "slot {slot}: {s:?}");
        assert!(s.flags & PROBE_VALID != 0, "slot {slot}: {s:?}");
    }
}

/// Relocation and classification settle within `SETTLE_FRAMES` and then change nothing, so skipping
/// them afterwards loses nothing: with the state pass forced to classify on every frame, no probe's
/// offset or flags change after the settling frames (cornell: its blocks make probes move out of
/// geometry and away from surfaces; atrium: pillars, floors and open sky). Measured: the changes per
/// frame fall to 0 by the 10th frame on both (cornell 194, 26, 8, 8, 6, 6, 5, 5, 3, 0, ...; atrium
/// 159, 60, 7, 5, 3, 3, 3, 3, 1, 0, ...); before the dead band in the relocation, 31 cornell probes
/// oscillated for ever.
#[test]
fn probe_states_settle_within_the_settling_frames() {
    for (scene, probes) in [("cornell", "8"), ("atrium", "16")] {
        let mut f = fixture_with(scene, &[], 16, 16);
        let p = params(&[("probe_count", probes)]);
        let mut ddgi = Ddgi::new(&f.setup(&p)).expect("ddgi");
        let mut previous = ddgi.read_states(&f.ctx).expect("states");
        let mut changes = Vec::new();
        for _ in 0..2 * SETTLE_FRAMES {
            f.render_frames(&mut ddgi, 1);
            ddgi.settle_frames_left = 1;
            let states = ddgi.read_states(&f.ctx).expect("states");
            let changed = |a: &ProbeState, b: &ProbeState| {
                let keep = !(PROBE_VALID | PROBE_BLEND);
                a.offset != b.offset || a.flags & keep != b.flags & keep
            };
            changes.push(states.iter().zip(&previous).filter(|(a, b)| changed(a, b)).count());
            previous = states;
        }
        eprintln!("{scene}: probes whose state changed, frame by frame: {changes:?}");
        assert!(changes[0] > 0, "{scene}: nothing relocated or classified: {changes:?}");
        assert!(changes[SETTLE_FRAMES as usize - 1..].iter().all(|&c| c == 0), "{scene}: {changes:?}");
    }
}
