use super::*;
use crate::shaders::layout::assert_u32_constants;
use crate::shaders::validate;

#[test]
fn shaders_validate() {
    let ism = ism::IsmSettings { size: 32, points_per_vpl: 1024, bias: 0.03 };
    for (variant, ism) in [(Variant::Classic, None), (Variant::Sh, None), (Variant::Classic, Some(&ism))] {
        let module = validate(
            "igi gather",
            &gather_source(),
            &ism::lookup_defines(
                gather_defines(variant, 4, 4, 64, 10.0)
                    .u32("TILE", 8)
                    .bool("COMPENSATE", true)
                    .bool("DIRECT_RASTER", false),
                ism,
            ),
        );
        assert_u32_constants(&module, &[("VPL_TABLE_TEXELS", VPL_TABLE_TEXELS as u32)]);
        for raster in [false, true] {
            validate("igi shade", include_str!("shade.wgsl"), &shade_defines(variant, raster).u32("TILE", 8));
        }
    }
}

/// Combinations that leave interleaving sets without VPLs are refused when the parameters are resolved,
/// before any scene upload or device work (the CLI reports them without touching the GPU).
#[test]
fn parameters_leaving_sets_without_vpls_are_refused_by_resolve() {
    let settings = |pairs: &[(&str, &str)]| -> Vec<(String, String)> {
        pairs.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect()
    };
    for name in ["igi", "igi-sh"] {
        let e = crate::techniques::resolve(name, &settings(&[("vpls", "8"), ("interleave", "4x4")]))
            .err()
            .expect("8 VPLs over 16 sets");
        assert!(e.starts_with(&format!("{name}: vpls=8")) && e.contains("16 interleaving sets (4x4)"), "{e}");
        crate::techniques::resolve(name, &settings(&[("vpls", "16"), ("interleave", "4x4")]))
            .expect("one VPL per set");
        let e = crate::techniques::resolve(name, &settings(&[("depth", "0"), ("direct", "raster")]))
            .err()
            .expect("depth 0 with raster direct light");
        assert!(e.contains("depth=0 with direct=raster leaves no VPLs"), "{e}");
        crate::techniques::resolve(name, &settings(&[("depth", "0"), ("direct", "vpl")]))
            .expect("VPLs on the lights");
    }
}
