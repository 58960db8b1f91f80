use std::mem::offset_of;

use super::*;
use crate::gpu::scene::LIGHT_SPOT;
use crate::shaders::layout::assert_layout;
use crate::shaders::validate;

#[test]
fn generation_validates_and_matches_its_host_layouts() {
    let m = validate("vpl generation", &format!("{VPL_WGSL}\n{GENERATE_WGSL}"), &Defines::new());
    crate::shaders::layout::assert_u32_constants(
        &m,
        &[
            ("ENTRY_LIGHT", ENTRY_LIGHT),
            ("ENTRY_EMISSIVE", ENTRY_EMISSIVE),
            ("ENTRY_ENVIRONMENT", ENTRY_ENVIRONMENT),
        ],
    );
    assert_layout(
        &m,
        "Vpl",
        size_of::<GpuVpl>(),
        &[
            ("position", offset_of!(GpuVpl, position)),
            ("kind", offset_of!(GpuVpl, kind)),
            ("normal", offset_of!(GpuVpl, normal)),
            ("light", offset_of!(GpuVpl, light)),
            ("flux", offset_of!(GpuVpl, flux)),
            ("roughness", offset_of!(GpuVpl, roughness)),
            ("incoming", offset_of!(GpuVpl, incoming)),
            ("metallic", offset_of!(GpuVpl, metallic)),
            ("base_color", offset_of!(GpuVpl, base_color)),
            ("specular", offset_of!(GpuVpl, specular)),
        ],
    );
    assert_layout(
        &m,
        "LightEntry",
        size_of::<LightEntry>(),
        &[
            ("cdf", offset_of!(LightEntry, cdf)),
            ("probability", offset_of!(LightEntry, probability)),
            ("kind", offset_of!(LightEntry, kind)),
            ("index", offset_of!(LightEntry, index)),
        ],
    );
    assert_layout(
        &m,
        "VplGeneration",
        size_of::<VplGeneration>(),
        &[
            ("sets", offset_of!(VplGeneration, sets)),
            ("paths", offset_of!(VplGeneration, paths)),
            ("slots_per_set", offset_of!(VplGeneration, slots_per_set)),
            ("max_depth", offset_of!(VplGeneration, max_depth)),
            ("entry_count", offset_of!(VplGeneration, entry_count)),
            ("fixed_lights", offset_of!(VplGeneration, fixed_lights)),
            ("sphere", offset_of!(VplGeneration, sphere)),
        ],
    );
}

#[test]
fn set_layout_fills_the_slots_with_geometrically_fewer_paths_per_vertex() {
    let l = set_layout(64, 0.5, 8, 0, true).expect("fits");
    assert!(l.used <= 64);
    // round(N·0.5^j), never more than N, stored from vertex 0.
    for (j, &n) in l.alive.iter().enumerate() {
        assert_eq!(n, (f64::from(l.paths) * 0.5f64.powi(j as i32)).round() as u32);
    }
    assert_eq!(l.offset[0], Some(0));
    assert_eq!(l.offset[1], Some(l.alive[0]));
    // One more path would not fit.
    let sum =
        |paths: u32| -> u32 { (0..=8).map(|j| (f64::from(paths) * 0.5f64.powi(j)).round() as u32).sum() };
    assert_eq!(sum(l.paths), l.used);
    assert!(sum(l.paths + 1) > 64);
    // Without VPLs on the lights, vertex 0 takes no slots.
    let r = set_layout(64, 0.5, 8, 0, false).expect("fits");
    assert_eq!(r.offset[0], None);
    assert_eq!(r.offset[1], Some(0));
    assert!(r.paths > l.paths);
    // Analytic lights take the first slots.
    let f = set_layout(64, 0.5, 8, 3, true).expect("fits");
    assert_eq!((f.fixed, f.offset[0]), (3, Some(3)));
    assert!(f.used <= 64 && f.paths < l.paths);
    // Lights only; then not even that.
    let only = set_layout(3, 0.5, 8, 3, false).expect("the lights fit");
    assert_eq!((only.paths, only.used), (0, 3));
    assert_eq!(set_layout(2, 0.5, 8, 3, false), None);
    assert_eq!(set_layout(0, 0.5, 8, 0, true), None);
}

#[test]
fn light_entries_are_chosen_by_power() {
    let light = |kind: u32, intensity: f32| crate::gpu::scene::GpuLight {
        position: [0.0; 3],
        kind,
        direction: [0.0, -1.0, 0.0],
        shadow_layer: -1,
        intensity: [intensity; 3],
        cos_outer: 0.5,
        cos_inner: 0.9,
        _pad: [0.0; 3],
    };
    let lights = [light(0, 1.0), light(LIGHT_SPOT, 2.0)];
    let e = light_entries(&lights, 3.0, 0.0, 1.0);
    assert_eq!(e.len(), 3, "point, spot, emissive; no environment");
    let pi = std::f32::consts::PI;
    let powers = [4.0 * pi, 2.0 * 2.0 * pi * 0.5, 6.0];
    let total: f32 = powers.iter().sum();
    for (entry, power) in e.iter().zip(powers) {
        assert!((entry.probability - power / total).abs() < 1e-6);
    }
    assert_eq!(e[2].kind, ENTRY_EMISSIVE);
    assert_eq!(e.last().map(|x| x.cdf), Some(1.0));
}
