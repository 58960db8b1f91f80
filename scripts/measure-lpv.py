#!/usr/bin/env python3
"""Prints docs/measurements/lpv-lavapipe-256.md (issue 11) from a run of benches/lpv.toml.

    cargo build --release -p rtgi-cli && python3 scripts/measure-lpv.py          # about 25 min on lavapipe
    python3 scripts/measure-lpv.py --size 1920x1080 --doc lpv-gpu                 # the suite at 1080p, a GPU

Runs `rtgi bench benches/lpv.toml --out $SCRATCH --images` (default target/measure/lpv), copies its report
to docs/measurements/NAME-bench/, and adds what the bench does not compute: the GI passes' time (the
volumes and the lookup, without the G-buffer, the direct light and the RSM, which renders only when
lights or geometry move) against rsm's gather, their growth with cells × iterations, the volumes'
memory, and the light on two-rooms' dark floor (the leak). Options: --suite FILE, --size WxH, --doc NAME
(default lpv-lavapipe-256), --allow-dirty. Shared helpers: scripts/measure_common.py.
"""
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

OUT = m.scratch("lpv")
DOC = m.ROOT / "docs/measurements"
def main():
    args, rtgi = m.suite_arguments("measure-lpv.py", "benches/lpv.toml", "lpv-lavapipe-256",
                                   __doc__.splitlines()[0])
    suite, size, results, cells, adapter, cpu, spp = m.run_suite_into_doc(
        rtgi, OUT, DOC, args.suite, args.size, args.doc)
    width, height = (int(v) for v in size.split("x"))
    ref_spp = "; ".join(f"{k} {v}" for k, v in spp.items())
    lines = [
        f"# LPV (issue 11): measurements at {width}×{height}", "",
        m.printed_by("measure-lpv.py", args, size, results, adapter, cpu), "",
        f"Each cell: a fresh renderer, {suite.get('frames', 8)} timed frames back to back, then "
        f"{suite.get('error_frames', 4)} compared with the path-traced full-GI reference (spp: {ref_spp}), "
        "each after a cut (docs/bench.md). ms/frame: the whole frame's GPU time (G-buffer included); GI ms: "
        "lpv's passes from the flux scale to the lookup, rsm's gather, upsampling and composite (both "
        "without the RSM, rendered only when lights or geometry move, the G-buffer and the direct light). "
        "LPV is one bounce of the analytic lights (as rsm); the reference has every bounce"
        + (". On lavapipe: compare techniques with each other, not with GPU figures." if cpu else "."), "",
    ]
    lines += m.gi_tables(cells, width, height, ("lpv",),
                         lambda c: c["series"] == "lpv" and c["sweep"].get("iterations") == "8")

    scale = [c for c in cells if c["technique"] == "lpv" and c["scene"] == cells[0]["scene"]
             and c["settings"].get("geometry_volume") != "false"]
    if scale:
        lines += ["## Scale and memory", "",
                  f"{cells[0]['scene']}: injection (flux scale + RSM texels + G-buffer blockers + resolve) and "
                  "propagation time per frame against cells × steps; memory of the volumes (light: ping, pong "
                  "and accumulated; injection: the fixed-point sums; geometry: the volume and its sums).", "",
                  "| cell | cells | steps | injection ms | propagation ms | propagation ns per cell-step | "
                  "light MiB | injection MiB | geometry MiB |", "|---|---|---|---|---|---|---|---|---|"]
        for c in scale:
            k = c["counters"]
            passes = {p["name"]: p["ms_per_frame"] for p in c["passes"]}
            inject = sum(passes.get(n, 0.0) for n in m.GI_PASSES["lpv"][:4])
            prop = passes.get("lpv propagation", 0.0)
            steps = k["lpv_iterations"]
            per = f"{prop * 1e6 / (k['lpv_cells'] * steps):.2f}" if steps else "–"
            lines.append(f"| {m.label(c)} | {k['lpv_cells']:.0f} | {steps:.0f} | {inject:.2f} | {prop:.2f} | {per} | "
                         f"{k['lpv_light_bytes'] / 2**20:.2f} | {k['lpv_injection_bytes'] / 2**20:.2f} | "
                         f"{k['lpv_geometry_bytes'] / 2**20:.2f} |")
        lines.append("")

    lines += m.leak_table(rtgi, OUT, cells, size, spp)
    (DOC / f"{args.doc}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    sys.exit(main())
