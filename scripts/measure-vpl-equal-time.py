#!/usr/bin/env python3
"""Prints docs/measurements/vpl-equal-time-lavapipe.md: igi and igi-sh against the path tracer at equal GPU
time per frame (issue 15, item 4).

    cargo build --release -p rtgi-cli && python3 scripts/measure-vpl-equal-time.py   # about 15 min on lavapipe
    python3 scripts/measure-vpl-equal-time.py --size 1920x1080 --doc vpl-equal-time-gpu   # a GPU

Runs `rtgi bench benches/vpl-equal-time.toml --images` (cornell: area light; cornell-spot: spot light; every
frame rendered afresh) and prints, per scene, each cell's time per frame, its FLIP and relMSE against the
full-GI reference, the path tracer's FLIP at the same time (interpolated in log time between its spp
cells), their ratio and whether the cell is on the error-vs-time front; then the pass split of the VPL
cells (what the shadow rays cost) and the answer to the issue's question per scene. Options: --suite
FILE, --size WxH, --doc NAME, --allow-dirty.
"""
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-vpl-equal-time.py"
VPL_TECHNIQUES = ("igi", "igi-sh")
VISIBILITY = "visibility + accumulation"


def main():
    run = m.run_documented_suite(SCRIPT, "vpl-equal-time", "benches/vpl-equal-time.toml",
                                 "vpl-equal-time-lavapipe", __doc__.splitlines()[0])
    suite, cells, cpu, ref_spp = run.suite, run.cells, run.cpu, run.ref_spp
    lines = [
        f"# VPL gathering against path tracing at equal time ({run.width}×{run.height})", "",
        run.header,
        "",
        f"Each cell: a fresh renderer, {suite.get('frames', 8)} timed frames back to back, each rendered "
        f"afresh (no accumulation over frames), then {suite.get('error_frames', 4)} compared with the "
        f"path-traced full-GI reference (spp: {ref_spp}); FLIP and relMSE are their means. ms/frame: the "
        "whole frame's GPU time. \"path's FLIP at this time\" interpolates the path tracer's FLIP in log time "
        "between its spp cells (– outside their times); a cell faster than path's cheapest is held against "
        "that cell's FLIP (path has no cheaper frame), its \"path's FLIP at this time\" shows –. A ratio below 1 means "
        "the cell beats path at equal time. igi and igi-sh take their direct light from the `direct` pass (`direct=raster`, the default) "
        "unless the label says `direct=vpl`"
        + (". On lavapipe: compare techniques with each other, not with GPU figures." if cpu else "."), "",
    ]
    verdicts = []
    for scene in dict.fromkeys(c["scene"] for c in cells):
        sc = [c for c in cells if c["scene"] == scene]
        lines += [f"## {scene}", "",
                  "| cell | ms/frame | FLIP | relMSE | path's FLIP at this time | FLIP / path's | on the front |",
                  "|---|---:|---:|---:|---:|---:|---|"]
        wins = []
        cheapest_path = min((c for c in sc if c["technique"] == "path"), key=lambda c: c["frame_ms"])
        for c in sc:
            p = m.path_flip_at(sc, c["frame_ms"]) if c["technique"] != "path" else None
            if p is None and c["technique"] != "path" and c["frame_ms"] < cheapest_path["frame_ms"]:
                # Faster than path's cheapest cell (1 spp: path has no cheaper frame at this size): the
                # cell beats path at equal time when it is below that cell's FLIP.
                p = cheapest_path["error"]["flip"]
            ratio = c["error"]["flip"] / p if p else None
            if ratio is not None and ratio < 1 and c["technique"] in VPL_TECHNIQUES:
                wins.append((ratio, c))
            lines.append(f"| {m.label(c)} | {c['frame_ms']:.1f} | {c['error']['flip']:.4f} | "
                         f"{c['error']['rel_mse']:.5f} | {m.path_flip_text(sc, c)} | "
                         f"{f'{ratio:.2f}' if ratio is not None else '–'} | "
                         f"{'yes' if m.on_front(sc, c) else 'no'} |")
        lines += ["", "Pass split of the VPL cells (ms/frame; the visibility pass casts one shadow ray per "
                  "pixel and VPL of its interleaving set, or with `visibility=ism` looks the VPL up in its "
                  "imperfect shadow map, which the `ism` passes draw):", "",
                  "| cell | passes | visibility share |", "|---|---|---:|"]
        for c in sc:
            if c["technique"] not in VPL_TECHNIQUES:
                continue
            split = ", ".join(f"{p['name']} {p['ms_per_frame']:.2f}" for p in c["passes"])
            vis = m.pass_ms(c, VISIBILITY)
            share = f"{vis / c['frame_ms']:.0%}" if vis is not None and c["frame_ms"] > 0 else "–"
            lines.append(f"| {m.label(c)} | {split} | {share} |")
        lines.append("")
        if wins:
            best_ratio, best = min(wins, key=lambda w: w[0])
            verdicts.append(f"{scene}: yes — {len(wins)} VPL cell(s) below path's FLIP at equal time; best "
                            f"{m.label(best)} at {best['frame_ms']:.0f} ms, FLIP {best['error']['flip']:.4f}, "
                            f"{best_ratio:.2f}× path's")
        else:
            verdicts.append(f"{scene}: no VPL cell below path's FLIP at equal time within path's times")
    lines += ["## Answer", "", "Does igi or igi-sh beat path at equal GPU time per frame?", ""]
    lines += [f"- {v}." for v in verdicts]
    m.write_doc(SCRIPT, run.args.doc, lines)


if __name__ == "__main__":
    sys.exit(main())
