#!/usr/bin/env python3
"""Prints docs/measurements/splat-lavapipe.md: sii's splat pass tiled in compute against raster-blended,
beside the rsm gather of the same light (issue 15, item 3).

    cargo build --release -p rtgi-cli && python3 scripts/measure-splat.py      # about 10 min on lavapipe
    python3 scripts/measure-splat.py --size 1920x1080 --doc splat-gpu           # a GPU

Runs `rtgi bench benches/splat.toml --images` (every built-in scene; 256 VPLs for sii, 256 samples at full
resolution for rsm) and prints, per scene, the GPU time per frame of sii's `splat` pass with
`splat=tiles` (per-tile VPL sets and a per-texel loop in compute, the default) and `splat=raster` (one
additively blended quad per VPL, the paper's way), of rsm's `rsm gather` pass, their ratios, and the FLIP
between the two splats' images (`rtgi compare`). Options: --suite FILE, --size WxH, --doc NAME,
--allow-dirty.
"""
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-splat.py"


def cell(results, scene, technique, **settings):
    """The cell of `technique` on `scene` whose suite settings are exactly `settings`."""
    found = [c for c in results["cells"] if c["scene"] == scene and c["technique"] == technique
             and {k: str(v) for k, v in c["settings"].items()} == {k: str(v) for k, v in settings.items()}]
    if len(found) != 1:
        sys.exit(f"{SCRIPT}: {len(found)} cells of {technique} {settings} on {scene}, expected one")
    return found[0]


def main():
    args, rtgi = m.suite_arguments(SCRIPT, "benches/splat.toml", "splat-lavapipe", __doc__.splitlines()[0])
    out = m.scratch("splat") / "bench"
    start = m.load_average()
    _, size, results, _, adapter, cpu, _ = m.run_suite_into_doc(
        rtgi, out, m.ROOT / "docs/measurements", args.suite, args.size, args.doc)
    scenes = list(dict.fromkeys(c["scene"] for c in results["cells"]))
    lines = [
        f"# sii splatting: tiled compute against raster blending, beside the rsm gather ({size})",
        "",
        m.printed_by(SCRIPT, args, size, results, adapter, cpu) + " " + m.load_text(start, m.load_average()),
        "",
        "Per-pass time per frame (GPU timestamps where reliable, else wall times; mean of the suite's "
        "measured frames). `splat` is sii's pass that adds every VPL's light to the indirect buffer: `tiles` "
        "builds each VPL's atlas rectangle, a bit set of the VPLs meeting each 8×8 tile, then sums per texel "
        "over its tile's set in VPL order; `raster` draws one additively blended quad per VPL. Both reach "
        "the same texels with the same additions in the same order (unit test "
        "`tiled_splatting_equals_raster_splatting`: bit-equal atlases on lavapipe); the FLIP column compares "
        "the two techniques' final images. `rsm gather` is rsm's per-pixel gather of the same RSM at 256 "
        "samples, full resolution. Scenes without analytic lights (cornell, furnace, spheres-env) give RSM "
        "techniques no VPL light, but every pass still runs.",
        "",
        "| scene | splat tiles ms | splat raster ms | rsm gather ms | tiles / gather | raster / gather "
        "| tiles / raster | FLIP tiles vs raster |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for scene in scenes:
        tiles = cell(results, scene, "sii", vpls=256, splat="tiles")
        raster = cell(results, scene, "sii", vpls=256, splat="raster")
        gather = cell(results, scene, "rsm", downsample=1, samples=256)
        t, r, g = m.pass_ms(tiles, "splat"), m.pass_ms(raster, "splat"), m.pass_ms(gather, "rsm gather")
        flip = m.compare(rtgi, out / "images" / raster["image_file"], out / "images" / tiles["image_file"])["flip"]
        lines.append(f"| {scene} | {t:.3f} | {r:.3f} | {g:.3f} | {t / g:.2f}× | {r / g:.2f}× | {t / r:.2f}× "
                     f"| {flip:.4f} |")
    path = m.ROOT / "docs/measurements" / f"{args.doc}.md"
    path.write_text("\n".join(lines) + "\n")
    print(path.read_text())


if __name__ == "__main__":
    main()
