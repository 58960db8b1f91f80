#!/usr/bin/env python3
"""Prints docs/measurements/primary-lavapipe.md: the G-buffer pass rasterised and ray-cast through the BVH
(`primary=raster|trace`) at each size of the suite, and the image difference between them (issue 15, item 2).

    python3 scripts/measure-primary.py                    # about 10 min on lavapipe (2 cores)
    python3 scripts/measure-primary.py --doc primary-gpu --size 1920x1080   # a GPU (adds that size)

Runs `rtgi bench benches/primary.toml` (`direct` with its ray-traced light samples off, every pass submitted
alone and waited for) --rounds times (default 2) and keeps each cell's fastest G-buffer pass. Options:
--suite FILE, --size WxH (replaces the suite's sizes), --rounds N, --doc NAME, --allow-dirty.
"""
import re
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-primary.py"


def gbuffer_pass(cell):
    (p,) = [p for p in cell["passes"] if p["name"] == "gbuffer"]
    return p


def main():
    def extra(parser):
        parser.add_argument("--rounds", type=int, default=2)

    args, rtgi = m.suite_arguments(SCRIPT, "benches/primary.toml", "primary-lavapipe", __doc__.splitlines()[0],
                                   extra)
    out = m.scratch("primary")
    suite = m.ROOT / args.suite
    if args.size:
        suite = out / f"primary-{args.size}.toml"
        suite.write_text(re.sub(r"(?m)^sizes = .*$", f'sizes = ["{args.size}"]', (m.ROOT / args.suite).read_text()))
    start = m.load_average()
    benches = [m.Bench(rtgi, suite, out / f"round-{k}", images=True) for k in range(args.rounds)]
    commit, adapter = m.same_run(benches)
    cpu = adapter.get("device_type") == "Cpu"
    last = benches[-1]
    cells = last.results["cells"]
    command = f"python3 scripts/{SCRIPT}" + "".join(f" {a}" for a in sys.argv[1:] if a != "--allow-dirty")
    lines = [
        "# Primary visibility: rasterised against ray-cast G-buffer",
        "",
        f"Printed by `{command}` from `rtgi bench {args.suite}` at commit `{commit}` on {m.adapter_text(adapter)}"
        + (", 2 CPU cores" if cpu else "") + f", {args.rounds} rounds, each cell's fastest. "
        + m.load_text(start, m.load_average()),
        "",
        "Both passes write the same seven targets (`common/gbuffer.wgsl`). Raster: one draw per mesh into "
        "seven render targets and a depth buffer. Trace: one compute thread per pixel casts the primary ray "
        "through the shared BVH (`common/bvh.wgsl`, closest hit) and stores the targets; texture levels come "
        "from the ray differentials. Times are per frame, every pass submitted alone and waited for "
        "(`timing = \"passes\"`): the wall time of the G-buffer pass's submission, and what the GPU "
        "timestamps around it say (\"unreliable\" where the profiler found them summing to under a quarter "
        "of the wall time: lavapipe's timestamps leave the ray-cast pass's work out). FLIP: `direct` with "
        "raster against with trace (the same image up to silhouette pixels and texture-level choices; "
        "`direct` runs with its ray-traced light samples off, so its error against the full-GI reference "
        "says nothing here and is left out).",
        "",
        "| scene | size | raster ms | trace ms | trace / raster | raster timestamps ms | trace timestamps ms "
        "| FLIP raster vs trace |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    keys = list(dict.fromkeys((c["scene"], c["width"], c["height"]) for c in cells))
    for scene, w, h in keys:
        def best(primary, field):
            values = [gbuffer_pass(c)[field] for b in benches for c in b.results["cells"]
                      if (c["scene"], c["width"], c["height"]) == (scene, w, h)
                      and c["settings"]["primary"] == primary
                      and (field == "wall_ms_per_frame" or c["timestamps"] == "reliable")]
            return f"{min(values):.2f}" if field == "ms_per_frame" and values else (min(values) if values else
                                                                                    "unreliable")
        cell = {p: next(c for c in cells if (c["scene"], c["width"], c["height"]) == (scene, w, h)
                        and c["settings"]["primary"] == p) for p in ("raster", "trace")}
        raster, trace = best("raster", "wall_ms_per_frame"), best("trace", "wall_ms_per_frame")
        between = m.compare(rtgi, last.image(cell["raster"]), last.image(cell["trace"]))["flip"]
        lines.append(
            f"| {scene} | {w}×{h} | {raster:.1f} | {trace:.1f} | {trace / raster:.2f} "
            f"| {best('raster', 'ms_per_frame')} | {best('trace', 'ms_per_frame')} | {between:.4f} |")
    m.write_doc(SCRIPT, args.doc, lines)


if __name__ == "__main__":
    main()
