#!/usr/bin/env python3
"""Prints docs/measurements/splat-lavapipe.md: sii's splat pass tiled in compute against raster-blended,
beside the rsm gather of the same light (issue 15, item 3).

    cargo build --release -p rtgi-cli && python3 scripts/measure-splat.py      # about 10 min on lavapipe
    python3 scripts/measure-splat.py --size 1920x1080 --doc splat-gpu           # a GPU

Runs `rtgi bench benches/splat.toml --images` (every built-in scene; 256 VPLs for sii, 256 samples at full
resolution for rsm) and prints, per scene, the GPU time per frame of sii's `splat` pass with
`splat=tiles-shared` and `splat=tiles-texel` (per-tile VPL sets and a per-texel loop in compute, each
tile's VPLs read into workgroup memory or per texel) and `splat=raster` (one additively blended quad per
VPL, the paper's way), of rsm's `rsm gather` pass, their ratios, and the FLIP between the tiled splats'
images and the raster splat's (`rtgi compare`). Options: --suite FILE, --size WxH, --doc NAME,
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
        "measured frames). `splat` is sii's pass that adds every VPL's light to the indirect buffer. The tiled "
        "splats build each VPL's atlas rectangle and a bit set of the VPLs meeting each 8×8 tile, then sum per "
        "texel over its tile's set in VPL order: `shared` reads each tile's VPLs once into workgroup memory "
        "(`splat=tiles-shared`, what `splat=tiles` picks on GPUs), `texel` reads them per texel from the VPL "
        "table (`splat=tiles-texel`, what it picks on CPU adapters). `raster` draws one additively blended "
        "quad per VPL. All three reach the same texels with the same additions in the same order (unit test "
        "`tiled_splatting_equals_raster_splatting`: equal atlases on lavapipe); the FLIP columns compare the "
        "techniques' final images with raster's. `rsm gather` is rsm's per-pixel gather of the same RSM at "
        "256 samples, full resolution. Scenes without analytic lights (cornell, furnace, spheres-env) give "
        "RSM techniques no VPL light, but every pass still runs.",
        "",
        "| scene | splat shared ms | splat texel ms | splat raster ms | rsm gather ms | shared / gather "
        "| texel / gather | raster / gather | FLIP shared vs raster | FLIP texel vs raster |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for scene in scenes:
        shared = cell(results, scene, "sii", vpls=256, splat="tiles-shared")
        texel = cell(results, scene, "sii", vpls=256, splat="tiles-texel")
        raster = cell(results, scene, "sii", vpls=256, splat="raster")
        gather = cell(results, scene, "rsm", downsample=1, samples=256)
        s, t, r = (m.pass_ms(c, "splat") for c in (shared, texel, raster))
        g = m.pass_ms(gather, "rsm gather")
        flips = [m.compare(rtgi, out / "images" / raster["image_file"], out / "images" / c["image_file"])["flip"]
                 for c in (shared, texel)]
        lines.append(f"| {scene} | {s:.3f} | {t:.3f} | {r:.3f} | {g:.3f} | {s / g:.2f}× | {t / g:.2f}× "
                     f"| {r / g:.2f}× | {flips[0]:.4f} | {flips[1]:.4f} |")
    path = m.ROOT / "docs/measurements" / f"{args.doc}.md"
    path.write_text("\n".join(lines) + "\n")
    print(path.read_text())


if __name__ == "__main__":
    main()
