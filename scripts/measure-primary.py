#!/usr/bin/env python3
"""Prints docs/measurements/primary-lavapipe.md: the G-buffer pass rasterised and ray-cast through the BVH
(`primary=raster|trace`) at each size of the suite, and the image difference between them (issue 15, item 2).

    python3 scripts/measure-primary.py                    # about 10 min on lavapipe (2 cores)
    python3 scripts/measure-primary.py --doc primary-gpu --size 1920x1080   # a GPU (adds that size)

Runs `rtgi bench benches/primary.toml` (`direct` with its ray-traced light samples off, every pass submitted
alone and waited for) --rounds times (default 2) and keeps each cell's fastest G-buffer pass. Options:
--suite FILE, --size WxH (replaces the suite's sizes), --rounds N, --doc NAME, --allow-dirty.
"""
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
    suite = m.suite_at_size(args.suite, args.size, out)
    start = m.load_average()
    benches = [m.Bench(rtgi, suite, out / f"round-{k}", images=True) for k in range(args.rounds)]
    commit, adapter = m.same_run(benches)
    cpu = adapter.get("device_type") == "Cpu"
    last = benches[-1]
    cells = last.results["cells"]
    command = m.command_line(SCRIPT)
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
        "of the wall time, as lavapipe's were before the profiler's `write_start`). FLIP: `direct` with "
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
        def of(results, primary):
            (c,) = [c for c in results["cells"] if (c["scene"], c["width"], c["height"]) == (scene, w, h)
                    and c["settings"]["primary"] == primary]
            return c

        def wall(primary):
            return min(gbuffer_pass(of(b.results, primary))["wall_ms_per_frame"] for b in benches)

        def timestamps(primary):
            timed = [of(b.results, primary) for b in benches]
            timed = [gbuffer_pass(c)["ms_per_frame"] for c in timed if c["timestamps"] == "reliable"]
            return f"{min(timed):.2f}" if timed else "unreliable"

        raster, trace = wall("raster"), wall("trace")
        between = m.compare(rtgi, last.image(of(last.results, "raster")), last.image(of(last.results, "trace")))
        lines.append(
            f"| {scene} | {w}×{h} | {raster:.1f} | {trace:.1f} | {trace / raster:.2f} "
            f"| {timestamps('raster')} | {timestamps('trace')} | {between['flip']:.4f} |")
    m.write_doc(SCRIPT, args.doc, lines)


if __name__ == "__main__":
    main()
