#!/usr/bin/env python3
"""Prints docs/measurements/prt-turning-lavapipe.md: precomputed radiance transfer under a turning environment
(issue 14), time per frame against direct.

    cargo build --release -p rtgi-cli && python3 scripts/measure-prt-turning.py   # a few minutes on lavapipe
    python3 scripts/measure-prt-turning.py --size 1920x1080 --doc prt-turning-gpu   # a GPU

Runs `rtgi bench benches/prt-turning.toml --images` and prints each cell's time per frame, its shading
pass, its environment rotation pass, the ratio of its frame time to direct's, and FLIP and relMSE against
the path-traced reference of the first measured frame's turn. Options: --suite FILE, --size WxH, --doc NAME,
--allow-dirty.
"""
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-prt-turning.py"
SHADING = {"prt": "prt shading", "env-harmonics": "environment shading"}
ROTATION = "environment rotation"
# Per-frame relighting of the vertices: glossy transfer's matrices times the turned SH; wavelet transfer's
# resampled, transformed and approximated lighting, then every vertex's sparse dot product.
RELIGHT = ["transferred radiance", "wavelet lighting", "wavelet vertex irradiance"]


def relight_ms(cell):
    """The cell's per-frame relighting passes' time in all (None when it has none)."""
    times = [t for t in (m.pass_ms(cell, name) for name in RELIGHT) if t is not None]
    return sum(times) if times else None


def main():
    run = m.run_documented_suite(SCRIPT, "prt-turning", "benches/prt-turning.toml", "prt-turning-lavapipe",
                                 __doc__.splitlines()[0])
    suite, cells, cpu, ref_spp = run.suite, run.cells, run.cpu, run.ref_spp
    direct = [c["frame_ms"] for c in cells if c["technique"] == "direct"]
    lines = [
        f"# Precomputed radiance transfer under a turning environment ({run.width}×{run.height})", "",
        run.header,
        "",
        f"Each cell: a fresh renderer of `spheres-env:animate=environment`, one warm-up frame (prt precomputes "
        f"its transfer there, prt and env-harmonics project the sky), then {suite.get('frames', 6)} timed "
        "frames, each at a new time, so the sky has turned and the projection is rotated every frame; "
        f"the first is compared with the path-traced full-GI reference at its time (spp: {ref_spp}). "
        "ms/frame: the whole frame's GPU time; rotation: the `environment rotation` pass (the SH band "
        "matrices are built on the CPU and are not in it); relight: glossy transfer's `transferred radiance` "
        "pass (every vertex's matrix times the turned sky's SH, again every frame), or wavelet transfer's "
        "`wavelet lighting` (the turned sky resampled onto the cube, transformed, its largest terms kept) "
        "and `wavelet vertex irradiance` (every vertex's sparse dot product) passes; × direct: ms/frame "
        "over direct's"
        + (". On lavapipe: compare cells with each other, not with GPU figures." if cpu else "."), "",
        "| cell | ms/frame | × direct | shading ms | rotation ms | relight ms | FLIP | relMSE |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for c in cells:
        shading = m.pass_ms(c, SHADING.get(c["technique"], ""))
        rotation = m.pass_ms(c, ROTATION)
        relight = relight_ms(c)
        ratio = c["frame_ms"] / direct[0] if direct else None
        lines.append(f"| {m.label(c)} | {c['frame_ms']:.2f} | {f'{ratio:.2f}' if ratio is not None else '–'} | "
                     f"{f'{shading:.2f}' if shading is not None else '–'} | "
                     f"{f'{rotation:.3f}' if rotation is not None else '–'} | "
                     f"{f'{relight:.2f}' if relight is not None else '–'} | {c['error']['flip']:.4f} | "
                     f"{c['error']['rel_mse']:.5f} |")
    m.write_doc(SCRIPT, run.args.doc, lines)


if __name__ == "__main__":
    main()
