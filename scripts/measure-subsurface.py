#!/usr/bin/env python3
"""Prints docs/measurements/subsurface-lavapipe.md: the hierarchical dipole (`subsurface`), single tree against dual hierarchy, against the brute-force sum.

    cargo build --release -p rtgi-cli && python3 scripts/measure-subsurface.py      # about 15 min on lavapipe
    python3 scripts/measure-subsurface.py --sizes 1920x1080 --doc subsurface-gpu    # a GPU

The thesis's experiments 4, 5 and 7 (report 003 §3.7) on `translucent` (a skin sphere and a marble slab, lit
from the front and from behind): for each image size, the reference is `subsurface` with ε = 0 and ρ = 0 (every
illumination sample summed at every pixel: the exact value of the same samples and model); then the single
tree (Jensen & Buhler: ρ = 0, every pixel its own traversal) and the dual hierarchy (pixel clusters of up to
ρ / max s_p pixels, ρ = 0.75 as the paper) over ε, and a ρ sweep at ε = 0.1. Reports RMSE, relative MSE and
FLIP against the reference, the jobs (traversals), BSSRDF evaluations and node visits per frame, and the GPU
time of the cluster and traversal passes (the mean of frames 2–4; the samples' irradiance and the trees' aggregation
are the same for every setting and listed once).
Options: --sizes WxH[,WxH...], --samples N, --doc NAME, --allow-dirty.
"""
import json
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-subsurface.py"
OUT = m.scratch("subsurface")
EPSILONS = ["0.4", "0.2", "0.1", "0.05", "0.025"]
RHOS = ["1.5", "3"]
PASSES = ["subsurface clusters", "subsurface traversal"]
SHARED = ["subsurface irradiance", "subsurface tree", "subsurface shade"]


def steady_ms(stats, name):
    p = next((p for p in stats["passes"] if p["name"] == name), None)
    if not p or not p.get("gpu"):
        return None
    return p["gpu"]["mean_ms"]


def first_ms(stats, name):
    p = next((p for p in stats["passes"] if p["name"] == name), None)
    return p.get("gpu_ms") if p else None


def main():
    def options(parser):
        parser.add_argument("--sizes", default="256x256,512x512,1024x1024")
        parser.add_argument("--samples", default="16384")

    args, rtgi, commit, start_load = m.script_arguments(
        SCRIPT, __doc__.splitlines()[0], "subsurface-lavapipe", options)

    def render(size, name, epsilon, rho, frames="4"):
        out = OUT / f"{size}-{name}.exr"
        stats_path = OUT / f"{size}-{name}.json"
        m.log(SCRIPT, f"{size}: {name}")
        m.run([rtgi, "render", "--scene", "translucent", "--technique", "subsurface", "--size", size,
               "--frames", frames, "--set", f"samples={args.samples}", "--set", f"epsilon={epsilon}",
               "--set", f"rho={rho}", "--out", out, "--stats", stats_path])
        return out, json.loads(stats_path.read_text())

    sections = []
    adapter = None
    for size in args.sizes.split(","):
        # One frame: only analytic lights, so every frame is the same image.
        ref, ref_stats = render(size, "reference", "0", "0", frames="1")
        adapter = ref_stats["adapter"]
        truncated = ref_stats["counters"].get("subsurface_truncated_walks", 0)
        rows = []
        cases = [(f"single, ε {e}", e, "0") for e in EPSILONS]
        cases += [(f"dual ρ 0.75, ε {e}", e, "0.75") for e in EPSILONS]
        cases += [(f"dual ρ {r}, ε 0.1", "0.1", r) for r in RHOS]
        for k, (label, epsilon, rho) in enumerate(cases):
            out, stats = render(size, f"c{k}", epsilon, rho)
            error = m.compare(rtgi, ref, out)
            rows.append((label, error, stats))
        sections.append((size, ref_stats, truncated, rows))

    end_load = m.load_average()
    cpu = adapter.get("device_type") == "Cpu"
    lines = [
        "# Subsurface scattering: single tree against dual hierarchy, against the brute-force sum", "",
        f"Printed by `{m.command_line(SCRIPT)}` at commit `{commit}` on {m.adapter_text(adapter)}"
        + (", 2 CPU cores" if cpu else "") + ". " + m.load_text(start_load, end_load), "",
        "`subsurface` on `translucent` (`crates/rtgi/src/techniques/subsurface/`): the dipole BSSRDF (Jensen et "
        f"al. 2001) over {args.samples} illumination samples, each mesh's kd-tree cut where a node's solid "
        "angle A/d² is below ε (Jensen & Buhler 2002), and pixel clusters (the dual hierarchy of Belcour et al. "
        "2019, here the quadtree of each 8×8 tile) shading a square of up to P = ρ / max s_p pixels with one "
        "traversal, s_p from the frequency analysis. ρ = 0 is the single tree. Reference: ε = 0 and ρ = 0, every "
        "sample at every pixel, i.e. the exact sum these settings approximate (the dipole's own error and the "
        "samples' quadrature error are not in these figures). Errors over the whole image (the pixels that "
        "show no translucent object are identical in all images). Times: GPU timestamps, mean of the steady "
        "frames (the last 3 of 4; the first includes compiling the pipelines)" + (". On lavapipe compare the rows with each other, not with GPU figures." if cpu else "."),
    ]
    fmt = lambda v, d=2: "–" if v is None else f"{v:.{d}f}"  # noqa: E731
    for size, ref_stats, truncated, rows in sections:
        c = ref_stats["counters"]
        pixels = c["subsurface_pixels"]
        shared = " + ".join(f"{p.split(' ', 1)[1]} {fmt(steady_ms(rows[0][2], p))}" for p in SHARED)
        lines += ["", f"## {size.replace('x', '×')}", "",
                  f"{int(pixels)} translucent pixels; {int(c['subsurface_samples'])} samples, "
                  f"{int(c['subsurface_tree_nodes'])} tree nodes, depth {int(c['subsurface_tree_depth'])}; "
                  f"{int(c['subsurface_bytes'])} bytes of buffers. Passes common to every row (ms): {shared}. "
                  f"Reference: {int(c['subsurface_evaluations'])} evaluations per frame, traversal "
                  f"{fmt(first_ms(ref_stats, 'subsurface traversal'), 1)} ms (one frame)"
                  + (f" ({int(truncated)} walks cut short by the driver's loop limit)" if truncated else "") + ".",
                  "", "| setting | RMSE | relMSE | FLIP | jobs | evaluations per pixel | visits per pixel | "
                  "clusters ms | traversal ms | total ms |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for label, error, stats in rows:
            k = stats["counters"]
            times = [steady_ms(stats, p) for p in PASSES]
            total = sum(times) if all(t is not None for t in times) else None
            lines.append(f"| {label} | {error['rmse']:.5f} | {error['rel_mse']:.6f} | {error['flip']:.4f} | "
                         f"{int(k['subsurface_clusters'])} | {k['subsurface_evaluations'] / pixels:.1f} | "
                         f"{k['subsurface_node_visits'] / pixels:.1f} | " + " | ".join(fmt(t) for t in times)
                         + f" | {fmt(total)} |")
    m.write_doc(SCRIPT, args.doc, lines)


if __name__ == "__main__":
    main()
