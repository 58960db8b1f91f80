#!/usr/bin/env python3
"""Prints docs/measurements/radiance-cache-lavapipe.md: radiance-cache against one-bounce path tracing
(issue 13, item 2); with `--suite benches/photon-irradiance-cache.toml` the photon-mapped cache against
full-GI path tracing (item 4).

    cargo build --release -p rtgi-cli && python3 scripts/measure-radiance-cache.py   # about 15 min on lavapipe
    python3 scripts/measure-radiance-cache.py --size 1920x1080 --doc radiance-cache-gpu   # a GPU

Runs `rtgi bench benches/radiance-cache.toml --images` and prints, per scene, each cell's time per frame
(a static view with a complete cache: the warm-up frame fills it), its FLIP and relMSE against the
one-bounce reference, the path tracer's FLIP at the same time, the time path needs for the cell's FLIP
(interpolated in log time between its spp cells) and the speedup that gives, the records and the
per-pass split. Options: --suite FILE, --size WxH, --doc NAME, --allow-dirty.
"""
import math
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-radiance-cache.py"
BUILD_PASSES = ("photon tracing", "photon grid", "photon placement")
CACHE_PASSES = ("photon tracing", "photon grid", "cache splat", "cache miss detection", "record computation",
                "cache shading")


def path_ms_at_flip(cells, flip):
    """The time at which path reaches `flip`, interpolated in log time between its cells; None when
    `flip` is outside their FLIPs."""
    path = sorted((c["frame_ms"], c["error"]["flip"]) for c in cells if c["technique"] == "path")
    for (t0, f0), (t1, f1) in zip(path, path[1:]):
        if min(f0, f1) <= flip <= max(f0, f1) and f0 != f1:
            w = (flip - f0) / (f1 - f0)
            return math.exp(math.log(t0) + w * (math.log(t1) - math.log(t0)))
    return None


def main():
    run = m.run_documented_suite(SCRIPT, "radiance-cache", "benches/radiance-cache.toml",
                                 "radiance-cache-lavapipe", __doc__.splitlines()[0])
    suite, cells, cpu, ref_spp = run.suite, run.cells, run.cpu, run.ref_spp
    one_bounce = suite.get("reference", {}).get("set", {}).get("max_bounces") == 1
    reference = "the one-bounce (`max_bounces=1`)" if one_bounce else "the full-GI (all bounces)"
    caches = sorted({c["technique"] for c in cells if c["technique"] != "path"})
    lines = [
        f"# {m.join_and(caches)} against {'one-bounce' if one_bounce else 'full-GI'} path tracing "
        f"({run.width}×{run.height})", "",
        run.header,
        "",
        f"Each cell: a fresh renderer, one warm-up frame (which fills the cache: 4 rounds of miss detection, "
        f"up to 4096 new records), {suite.get('frames', 8)} timed frames of the same view, then "
        f"{suite.get('error_frames', 4)} compared with {reference} path-traced "
        f"reference (spp: {ref_spp}). Photon cells: the photon map is built in the warm-up frame with the "
        "cache, so the timed frames do not include it; its cost is the last table of each scene. ms/frame: the whole frame's GPU time, so for the cache the cost of a "
        "static view with a complete cache (the G-buffer, direct light, a full splat, the rounds that find "
        "no miss, shading). \"path ms at this FLIP\": the time per frame path needs for the cell's FLIP, "
        "interpolated in log time between its spp cells; the speedup is that over the cell's time (the "
        "thesis's 29.7-47.1× were against the Radiance software on a CPU; this is against rtgi's own "
        "path tracer on the same device)"
        + (". On lavapipe: compare techniques with each other, not with GPU figures." if cpu else "."), "",
    ]
    for scene in dict.fromkeys(c["scene"] for c in cells):
        sc = [c for c in cells if c["scene"] == scene]
        lines += [f"## {scene}", "",
                  "| cell | ms/frame | FLIP | relMSE | path's FLIP at this time | path ms at this FLIP | speedup "
                  "| records | photons | on the front |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
        for c in sc:
            records = c["counters"].get("records")
            photons = c["counters"].get("photons")
            if c["technique"] == "path":
                at, speedup = "–", "–"
            else:
                t = path_ms_at_flip(sc, c["error"]["flip"])
                at = f"{t:.0f}" if t else "outside path's FLIPs"
                speedup = f"{t / c['frame_ms']:.1f}×" if t else "–"
            lines.append(f"| {m.label(c)} | {c['frame_ms']:.1f} | {c['error']['flip']:.4f} | "
                         f"{c['error']['rel_mse']:.5f} | {m.path_flip_text(sc, c)} | {at} | {speedup} | "
                         f"{f'{records:.0f}' if records is not None else '–'} | "
                         f"{f'{photons:.0f}' if photons is not None else '–'} | "
                         f"{'yes' if m.on_front(sc, c) else 'no'} |")
        lines += ["", "Passes of the cache cells (ms per frame, timed frames):", "",
                  "| cell | " + " | ".join(CACHE_PASSES) + " | other passes |",
                  "|---|" + "---:|" * (len(CACHE_PASSES) + 1)]
        for c in sc:
            if c["technique"] == "path":
                continue
            own = [m.pass_ms(c, name) or 0.0 for name in CACHE_PASSES]
            rest = ", ".join(f"{p['name']} {p['ms_per_frame']:.2f}" for p in c["passes"]
                             if p["name"] not in CACHE_PASSES)
            lines.append(f"| {m.label(c)} | " + " | ".join(f"{v:.2f}" for v in own) + f" | {rest} |")
        built = [c for c in sc if any(p["name"] in BUILD_PASSES for p in c.get("warmup_passes", []))]
        if built:
            lines += ["", "The photon map's build and the placement at photons (the warm-up frame's passes, ms; photon records are computed in its record computation; `photons`: stored photons):", "",
                      "| cell | " + " | ".join(BUILD_PASSES) + " | total | photons | records at photons |",
                      "|---|" + "---:|" * (len(BUILD_PASSES) + 3)]
            for c in built:
                own = [sum(p["ms_per_frame"] for p in c["warmup_passes"] if p["name"] == name)
                       if any(p["name"] == name for p in c["warmup_passes"]) else None for name in BUILD_PASSES]
                lines.append(f"| {m.label(c)} | " + " | ".join("–" if v is None else f"{v:.1f}" for v in own)
                             + f" | {sum(v or 0.0 for v in own):.1f} | {c['counters'].get('photons', 0):.0f} | "
                             + (f"{placed:.0f} |" if (placed := c['counters'].get('records_placed_at_photons')) is not None
                                else "– |"))
        lines.append("")
    m.write_doc(SCRIPT, run.args.doc, lines)


if __name__ == "__main__":
    sys.exit(main())
