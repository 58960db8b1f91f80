#!/usr/bin/env python3
"""Prints docs/measurements/glints-environment-lavapipe.md: `glints` under an environment, its light sampled (`env_order=0`) against basis-space integration (SH over the half vector, shadows by the ratio estimator) over SH orders and frames.

    cargo build --release -p rtgi-cli && python3 scripts/measure-glints-environment.py   # about 25 min on lavapipe
    python3 scripts/measure-glints-environment.py --size 1920x1080 --doc glints-environment-gpu   # a GPU

On `glints:sky=sky` (metallic flakes on a floor and a sphere under the procedural sky and two point lights). Two
references: the same model converged (`glints env_order=0` with 16 environment samples per pixel and frame over
REFERENCE_FRAMES frames: the G×D estimator the SH integration approximates, so its error is the integration's
own), and the path tracer (`path max_bounces=0 pixel_jitter=true`, 1024 samples per pixel spread over each pixel:
the ground truth, which also shows the glint filter's own error). Rows: the sampled estimator (4 environment
samples per frame) after 1 to 64 frames and SH orders 4-16 after 1, 4 and 16 (the ratio estimator accumulates its sums
over frames). Times: GPU timestamps; "ms per frame" is the mean of the steady frames of the 16-frame run (the first
frame of a run also compiles the pipelines on lavapipe), "ms for the image" that times the frames, the tables
(computed once per environment) apart; at that time the sampled estimator's relMSE, interpolated in log-log
between its runs of 1 to 64 frames. Report 003 §2.7 experiments 2 (truncation), 4 and 7 in the form
this implementation allows.
Options: --size WxH, --doc NAME, --allow-dirty.
"""
import json
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-glints-environment.py"
OUT = m.scratch("glints-environment")
SCENE = "glints:sky=sky"
REFERENCE_FRAMES = 128
FRAMES = [1, 4, 16]
SAMPLED_FRAMES = [1, 4, 16, 64]
ORDERS = [4, 8, 12]
# The highest order costs most (its tables alone take about a minute on lavapipe): one frame count.
HIGH_ORDER = (16, 4)
TABLE_PASSES = ("glints lobe and basis tables", "glints environment table")
# Inside the floor's lit part and inside the sphere, as fractions (x, y, w, h) of the image.
PATCHES = {"floor": (0.0, 0.7, 1.0, 0.3), "sphere": (0.42, 0.26, 0.16, 0.2)}


def main():
    def options(parser):
        parser.add_argument("--size", default="128x128")

    args, rtgi, commit, start_load = m.script_arguments(
        SCRIPT, __doc__.splitlines()[0], "glints-environment-lavapipe", options)
    width, height = (int(v) for v in args.size.split("x"))

    def render(name, technique, settings, frames):
        out = OUT / f"{args.size}-{name}.exr"
        stats_path = OUT / f"{args.size}-{name}.json"
        m.log(SCRIPT, f"{args.size}: {name}")
        sets = [x for k, v in settings.items() for x in ("--set", f"{k}={v}")]
        m.run([rtgi, "render", "--scene", SCENE, "--technique", technique, "--size", args.size,
               "--frames", frames, *sets, "--out", out, "--stats", stats_path])
        return out, json.loads(stats_path.read_text())

    def region(name):
        x, y, w, h = PATCHES[name]
        return f"{round(x * width)},{round(y * height)},{round(w * width)},{round(h * height)}"

    model, model_stats = render("model", "glints", {"env_samples": 16, "seed": 7}, REFERENCE_FRAMES)
    truth, _ = render("path", "path", {"max_bounces": 0, "pixel_jitter": "true", "spp": 64, "seed": 7}, 16)
    adapter = model_stats["adapter"]
    model_vs_truth = m.compare(rtgi, truth, model)
    cases = [("sampled (env_order 0)", "sampled", {}, frames) for frames in SAMPLED_FRAMES]
    for order in ORDERS:
        cases += [(f"SH order {order}", f"sh{order}", {"env_order": order}, frames) for frames in FRAMES]
    cases.append((f"SH order {HIGH_ORDER[0]}", f"sh{HIGH_ORDER[0]}", {"env_order": HIGH_ORDER[0]}, HIGH_ORDER[1]))
    rows = []
    steady = {}
    for label, name, settings, frames in sorted(cases, key=lambda c: -c[3]):
        out, stats = render(f"{name}-{frames}", "glints", settings, frames)
        if stats.get("frame_gpu"):
            steady.setdefault(label, stats["frame_gpu"]["mean_ms"])
        tables = sum(p["gpu_ms"] or 0.0 for p in stats["passes"] if p["name"] in TABLE_PASSES)
        patches = {k: m.compare(rtgi, model, out, region=region(k)) for k in PATCHES}
        rows.append((label, frames, m.compare(rtgi, model, out), m.compare(rtgi, truth, out), patches,
                     steady.get(label), tables, stats["counters"]))
    rows.sort(key=lambda r: (cases.index(next(c for c in cases if c[0] == r[0])), r[1]))
    sampled = [(r[5] * r[1], r[2]["rel_mse"]) for r in rows if r[0].startswith("sampled") and r[5]]

    end_load = m.load_average()
    cpu = adapter.get("device_type") == "Cpu"
    sh_counters = next(r[7] for r in rows if r[0] == f"SH order {ORDERS[1]}")
    lines = [
        "# Glints under an environment: light samples against basis-space (SH) integration", "",
        f"Printed by `{m.command_line(SCRIPT)}` at commit `{commit}` on {m.adapter_text(adapter)}"
        + (", 2 CPU cores" if cpu else "") + ". " + m.load_text(start_load, end_load), "",
        f"`{SCENE}` at {args.size.replace('x', '×')}. `glints` with `env_order=N` integrates the environment's "
        "specular light in basis space (seed 003, article 2, part b): the footprint's micronormal histogram as SH "
        "of order N over the half vector (each bin's GGX lobe a zonal harmonic turned to the bin's normal, "
        "weighted by its F·G at the mirror direction), dotted with the view's half-vector-space lighting from a "
        "table of (env_views + 1) × 2 env_views views (24 here) computed once per environment on the GPU; "
        "shadows by the ratio estimator over the frame's 4 environment samples, whose sums accumulate over "
        "frames. `env_order=0` reflects the same samples by the filtered BRDF instead (unbiased, noisy). "
        f"References: the model, `glints env_order=0 env_samples=16` over {REFERENCE_FRAMES} frames (what the SH "
        "integration approximates); the truth, `path max_bounces=0 pixel_jitter=true` at 1024 samples per pixel "
        f"(the model itself is at FLIP {model_vs_truth['flip']:.4f}, relMSE {model_vs_truth['rel_mse']:.4f} from "
        "it: the glint filter's own error). Patches: mean luminance against the model's, floor and sphere.", "",
        f"Order {ORDERS[1]}: {sh_counters['glints_env_table_bytes'] / 2**20:.1f} MiB of lighting table; "
        f"{sh_counters['glints_active_bins'] / max(sh_counters['glints_pixels'], 1):.1f} occupied bins per glint "
        "pixel (the SH work per pixel is bins × order²).", "",
        "| estimator | frames | FLIP vs model | relMSE vs model | FLIP vs path | relMSE vs path | floor | sphere "
        "| ms per frame | ms for the image | tables, ms | sampled relMSE at that time |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    fmt = lambda v, d=1: "–" if v is None else f"{v:.{d}f}"  # noqa: E731
    for label, frames, model_error, truth_error, patches, per_frame, tables, _ in rows:
        ratios = " | ".join(f"{patches[k]['region']['test_luminance'] / patches[k]['region']['reference_luminance']:.3f}"
                            for k in PATCHES)
        total = None if per_frame is None else per_frame * frames
        at = "" if label.startswith("sampled") else fmt(m.log_log_interpolate(sampled, total), 4)
        lines.append(f"| {label} | {frames} | {model_error['flip']:.4f} | {model_error['rel_mse']:.4f} | "
                     f"{truth_error['flip']:.4f} | {truth_error['rel_mse']:.4f} | {ratios} | {fmt(per_frame)} | "
                     f"{fmt(total)} | {tables:.1f} | {at} |")
    wins = [r for r in rows if r[0].startswith("SH") and r[5]
            and (m.log_log_interpolate(sampled, r[5] * r[1]) or 0.0) > r[2]["rel_mse"]]
    lines += ["", f"{len(wins)} of {sum(1 for r in rows if r[0].startswith('SH'))} SH rows have a lower relMSE against "
              "the model than the sampled estimator at the same GPU time (tables apart)"
              + (": " + m.join_and([f"{r[0]} after {r[1]} frame(s)" for r in wins]) if wins else "") + "."]
    m.write_doc(SCRIPT, args.doc, lines)


if __name__ == "__main__":
    main()
