#!/usr/bin/env python3
"""Prints docs/measurements/prt-moving-lavapipe.md: precomputed radiance transfer with a moving mesh (issue
14), self-transfer against recomputing the transfer in every frame, time per frame against direct and path.

    cargo build --release -p rtgi-cli && python3 scripts/measure-prt-moving.py   # about 10 min on lavapipe
    python3 scripts/measure-prt-moving.py --size 1920x1080 --doc prt-moving-gpu   # a GPU

Runs `rtgi bench benches/prt-moving.toml --images` and prints each cell's time per frame, its ratio to
direct's, its shading pass, its per-frame precomputation (recompute) or turn of the sky into the knot's
space (self-transfer), and FLIP and relMSE against the path-traced full-GI reference of the first measured
frame's pose (per scene: the second entry's reference is the environment's direct light alone). Options: --suite FILE, --size WxH, --doc NAME, --allow-dirty.
"""
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-prt-moving.py"
SHADING = "prt shading"
PRECOMPUTE = "transfer precomputation"
TURN = "environment into moving meshes"
RELIGHT = "transferred radiance"


def optional(value, digits):
    return f"{value:.{digits}f}" if value is not None else "–"


def main():
    run = m.run_documented_suite(SCRIPT, "prt-moving", "benches/prt-moving.toml", "prt-moving-lavapipe",
                                 __doc__.splitlines()[0])
    suite, cells, cpu, ref_spp = run.suite, run.cells, run.cpu, run.ref_spp
    direct = [c["frame_ms"] for c in cells if c["technique"] == "direct"]
    lines = [
        f"# Precomputed radiance transfer with a moving mesh ({run.width}×{run.height})", "",
        run.header,
        "",
        "Each cell: a fresh renderer of `pillars:animate=knot` (the knot tumbles about a horizontal axis), "
        "one warm-up frame (prt precomputes its transfer there, and projects the sky), then "
        f"{suite.get('frames', 4)} timed frames at the scene times {suite['scenes'][0].get('times')} s: the "
        "first at the warm-up's pose, each of the others with the knot further turned. The first is "
        f"compared with the path-traced reference at its pose (spp: {ref_spp}). `prt self-transfer` "
        "(moving_transfer=self) keeps each rigid part's transfer of its own geometry in its own space and "
        "turns the sky's SH into the knot's space when it moves (turn: that pass; the band matrices are "
        "built on the CPU and are not in it); the knot then casts no shadow on the ground and the pillars "
        "none on it. `prt recompute` precomputes every vertex's transfer from the whole scene in every frame "
        "in which the knot moved (precomputation: that pass's time per frame, three of the four frames). "
        "The `glossy` cells do the same with glossy transfer matrices (`transfer=glossy`, shaded through the "
        "BRDF tables), whose transferred radiance is lit again whenever the knot turns or the matrices change "
        "(relight: that pass); with self-transfer it stays in the knot's space and the pixels' normal and "
        "view are turned into it. The `interreflected` cells add 2 bounces of light between the surfaces "
        "(`transfer=interreflected`, RGB vectors), with self-transfer between a part's own surfaces only, so "
        "they are measured against the full-GI reference alone. "
        "ms/frame: the whole frame's GPU time; × direct: over direct's"
        + (". On lavapipe: compare cells with each other, not with GPU figures." if cpu else "."), "",
    ]
    for scene in dict.fromkeys(c["scene"] for c in cells):
        lines += [f"## {scene}", ""]
        settings = m.scene_reference_settings(suite, scene)
        if settings:
            lines += [f"This scene's reference is the path tracer with {settings} (not full GI): the "
                      "environment's direct light, what shadowed transfer computes.", ""]
        lines += [
            "| cell | ms/frame | × direct | shading ms | precomputation ms/frame | turn ms | relight ms | FLIP | "
            "relMSE |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for c in (c for c in cells if c["scene"] == scene):
            ratio = c["frame_ms"] / direct[0] if direct else None
            lines.append(f"| {m.label(c)} | {c['frame_ms']:.2f} | {optional(ratio, 2)} | "
                         f"{optional(m.pass_ms(c, SHADING), 2)} | {optional(m.pass_ms(c, PRECOMPUTE), 1)} | "
                         f"{optional(m.pass_ms(c, TURN), 3)} | {optional(m.pass_ms(c, RELIGHT), 2)} | "
                         f"{c['error']['flip']:.4f} | "
                         f"{c['error']['rel_mse']:.5f} |")
        lines.append("")
    m.write_doc(SCRIPT, run.args.doc, lines)


if __name__ == "__main__":
    main()
