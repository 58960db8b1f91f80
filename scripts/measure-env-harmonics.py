#!/usr/bin/env python3
"""Prints docs/measurements/env-harmonics-lavapipe.md: environment lighting of spheres-env by an HSH BRDF ×
SH environment and by an SH BRDF × SH environment at equal order, against the path tracer (issue 13, item 1).

    cargo build --release -p rtgi-cli && python3 scripts/measure-env-harmonics.py   # about 10 min on lavapipe
    python3 scripts/measure-env-harmonics.py --size 1920x1080 --doc env-harmonics-gpu   # a GPU

Runs `rtgi bench benches/env-harmonics.toml --images` and prints each cell's time per frame (and its
"environment shading" pass), FLIP and relMSE against the full-GI path-traced reference and the path
tracer's FLIP at the same time; then, per order, HSH against SH: FLIP and the relative frame cost of the
shading pass (the thesis's Table 3.1: HSH at 86-99 % of SH's frame rate), and every harmonic cell
against the sampled unshadowed integral (1024 samples), with HSH BRDFs meeting a 10-band environment
beside them. Options: --suite FILE,
--size WxH, --doc NAME, --allow-dirty.
"""
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-env-harmonics.py"
SHADING = "environment shading"


def main():
    run = m.run_documented_suite(SCRIPT, "env-harmonics", "benches/env-harmonics.toml",
                                 "env-harmonics-lavapipe", __doc__.splitlines()[0])
    suite, cells, cpu, ref_spp = run.suite, run.cells, run.cpu, run.ref_spp
    lines = [
        f"# Environment lighting with HSH and SH BRDFs ({run.width}×{run.height})", "",
        run.header,
        "",
        f"Each cell: a fresh renderer, one warm-up frame (env-harmonics builds its BRDF tables and projects "
        f"the environment there), then {suite.get('frames', 3)} timed frames, {suite.get('error_frames', 2)} "
        f"of them compared with the path-traced full-GI reference (spp: {ref_spp}). env-harmonics has no "
        "visibility (as in the thesis), so part of its error against the reference is the missing "
        "shadowing of the sky by the spheres and the ground; the `sampled` cell estimates the same "
        "unshadowed integral by BRDF sampling, the floor the harmonic bases approach as the order grows. "
        "ms/frame: the whole frame's GPU time; shading: the `environment shading` pass"
        + (". On lavapipe: compare cells with each other, not with GPU figures." if cpu else "."), "",
        "| cell | ms/frame | shading ms | FLIP | relMSE | path's FLIP at this time | FLIP / path's |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for c in cells:
        p = m.path_flip_at(cells, c["frame_ms"]) if c["technique"] != "path" else None
        ratio = c["error"]["flip"] / p if p else None
        shading = m.pass_ms(c, SHADING)
        lines.append(f"| {m.label(c)} | {c['frame_ms']:.2f} | "
                     f"{f'{shading:.2f}' if shading is not None else '–'} | {c['error']['flip']:.4f} | "
                     f"{c['error']['rel_mse']:.5f} | {m.path_flip_text(cells, c)} | "
                     f"{f'{ratio:.2f}' if ratio is not None else '–'} |")
    lines += ["", "## The bases against the unshadowed integral", "",
              "Each harmonic cell's image against the `sampled reference_samples=1024` cell's (the same "
              "unshadowed integral by BRDF sampling, so the missing visibility drops out): FLIP and relMSE. "
              "`× 10 bands`: the HSH BRDF of the order meets an environment of 10 bands "
              "(`environment_order=10`), which an SH BRDF of that order cannot use; it shades at the cost of "
              "10² coefficients. Relative cost: SH's shading time over HSH's at equal order (the thesis's "
              "HSH frame rate as a fraction of SH's: 86–99 %).", "",
              "| order | SH FLIP | SH relMSE | HSH FLIP | HSH relMSE | HSH × 10 bands FLIP | "
              "HSH × 10 bands relMSE | shading ms SH / HSH / HSH × 10 | relative cost |",
              "|---:|---:|---:|---:|---:|---:|---:|---|---:|"]
    rtgi = m.rtgi_binary()
    images = m.scratch("env-harmonics") / "bench" / "images"

    def series(c):
        s = c["settings"]
        if c["technique"] != "env-harmonics" or s.get("basis") not in ("hsh", "sh"):
            return None
        return s["basis"] + (" × 10" if int(s.get("environment_order", 0)) == 10 else "")

    (integral,) = [c for c in run.results["cells"] if c["technique"] == "env-harmonics"
                   and c["settings"].get("basis") == "sampled"
                   and int(c["settings"].get("reference_samples", 0)) == 1024]
    by = {}
    for c in cells:
        if series(c):
            by.setdefault(int(c["settings"]["order"]), {})[series(c)] = c
    for order in sorted(by):
        row, times = [], []
        for name in ("sh", "hsh", "hsh × 10"):
            c = by[order].get(name)
            if c is None:
                row += ["–", "–"]
                times.append("–")
                continue
            e = m.compare(rtgi, images / integral["image_file"], images / c["image_file"])
            row += [f"{e['flip']:.4f}", f"{e['rel_mse']:.5f}"]
            times.append(f"{m.pass_ms(c, SHADING):.2f}")
        h, s = by[order].get("hsh"), by[order].get("sh")
        rel = "–"
        if h and s:
            hm, sm = m.pass_ms(h, SHADING), m.pass_ms(s, SHADING)
            rel = f"{sm / hm:.0%}" if hm and sm else "–"
        lines.append(f"| {order} | {' | '.join(row)} | {' / '.join(times)} | {rel} |")
    m.write_doc(SCRIPT, run.args.doc, lines)


if __name__ == "__main__":
    main()
