#!/usr/bin/env python3
"""Prints docs/measurements/motion-blur-lavapipe.md: the non-linear motion blur post-process against the brute-force shutter reference.

    cargo build --release -p rtgi-cli && python3 scripts/measure-motion-blur.py            # about 5 min on lavapipe
    python3 scripts/measure-motion-blur.py --size 1920x1080 --doc motion-blur-gpu          # a GPU

Per case (an animated built-in scene at one time, one shutter), with `direct` and N frames (default 32):
the brute-force reference (`rtgi render --shutter S --shutter-reference N`: the mean of N fresh frames at
times stratified over the shutter), the sharp frame (N frames accumulated at t, so its noise is the
reference's) and the blurred one (the same, with `--shutter S`) at the paper's defaults and with other
background weights and segment counts, with rtgi's coverage weights (each curve's fragments share one unit
of weight), and the linear baseline (`method=linear`, McGuire et al. 2012).
Reports FLIP and relative MSE against the reference, the ratio of the blurred frame's relative MSE to the
sharp frame's, and the post-process's GPU time per frame (curves: listing the moving pixels + drawing the
curves + the resolve; linear: velocities + tile maxima + the gather) next to `direct`'s whole frame.
Options: --size WxH, --frames N, --doc NAME, --allow-dirty.
"""
import json
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-motion-blur.py"
OUT = m.scratch("motion-blur")
# (scene, time s, shutter s, what moves)
CASES = [
    ("cornell:animate=box", 0.5, 0.25, "a box flying a loop and turning (its shadow moves too)"),
    ("pillars:animate=knot", 1.0, 1.0, "a knot tumbling 45° about a horizontal axis: curved motion"),
    ("atrium:animate=camera", 2.0, 0.2, "the camera flight: everything moves"),
]
# (label, --motion-blur-set values)
VARIANTS = [
    ("w_b 5, Δ 10 (paper)", []),
    ("w_b 1", ["background_weight=1"]),
    ("w_b 20", ["background_weight=20"]),
    ("Δ 4", ["segments=4"]),
    ("Δ 20", ["segments=20"]),
    ("coverage weights, w_b 1", ["weights=coverage", "background_weight=1"]),
    ("linear, K 20, S 15", ["method=linear"]),
    ("linear, K 40", ["method=linear", "max_radius=40"]),
]
PASSES = {
    "curves": ["motion blur moving pixels", "motion blur curves", "motion blur resolve"],
    "linear": ["motion blur velocity", "motion blur tiles", "motion blur gather"],
}


def pass_mean_ms(stats, name):
    p = next((p for p in stats["passes"] if p["name"] == name), None)
    if not p or p.get("gpu_ms") is None:
        return None
    return p["gpu_ms"] / p["calls"]


def main():
    def options(parser):
        parser.add_argument("--size", default="256x256")
        parser.add_argument("--frames", type=int, default=32)

    args, rtgi, commit, start_load = m.script_arguments(
        SCRIPT, __doc__.splitlines()[0], "motion-blur-lavapipe", options)
    n = str(args.frames)

    rows = []
    adapter = None
    for k, (scene, t, shutter, _) in enumerate(CASES):
        base = [rtgi, "render", "--scene", scene, "--technique", "direct", "--size", args.size, "--time", str(t)]
        m.log(SCRIPT, f"{scene}: reference")
        ref = OUT / f"c{k}-reference.exr"
        m.run(base + ["--shutter", str(shutter), "--shutter-reference", n, "--out", ref])
        m.log(SCRIPT, f"{scene}: sharp")
        sharp = OUT / f"c{k}-sharp.exr"
        m.run(base + ["--frames", n, "--out", sharp, "--stats", OUT / "sharp.json"])
        sharp_stats = json.loads((OUT / "sharp.json").read_text())
        adapter = sharp_stats["adapter"]
        sharp_error = m.compare(rtgi, ref, sharp)
        results = []
        for v, (label, settings) in enumerate(VARIANTS):
            m.log(SCRIPT, f"{scene}: {label}")
            out = OUT / f"c{k}-v{v}.exr"
            extra = [a for s in settings for a in ("--motion-blur-set", s)]
            m.run(base + ["--frames", n, "--shutter", str(shutter), "--out", out, "--stats", OUT / "blur.json"]
                  + extra)
            stats = json.loads((OUT / "blur.json").read_text())
            method = "linear" if "method=linear" in settings else "curves"
            times = [pass_mean_ms(stats, p) for p in PASSES[method]]
            results.append((label, m.compare(rtgi, ref, out), times, stats["frame_gpu"]))
        rows.append((k, sharp_error, sharp_stats["frame_gpu"], results))
        linear = next(v for v, (label, _) in enumerate(VARIANTS) if label.startswith("linear"))
        m.run([rtgi, "montage", sharp, OUT / f"c{k}-v0.exr", OUT / f"c{k}-v{linear}.exr", ref,
               "--label", "sharp", "--label", "curves (paper)", "--label", "linear", "--label", "reference",
               "--out", m.ROOT / "docs" / "measurements" / f"{args.doc}-{k + 1}.png"])

    end_load = m.load_average()
    cpu = adapter.get("device_type") == "Cpu"
    width, height = args.size.split("x")
    lines = [
        f"# Non-linear motion blur against the brute-force shutter reference, {width}×{height}", "",
        f"Printed by `{m.command_line(SCRIPT)}` at commit `{commit}` on {m.adapter_text(adapter)}"
        + (", 2 CPU cores" if cpu else "") + ". " + m.load_text(start_load, end_load), "",
        "The post-process (`rtgi render --shutter S`, `crates/rtgi/src/post/motion_blur/`): every moving pixel's "
        "quadratic Bézier through its screen positions at the shutter's opening, the frame's time and the "
        "closing, cut into Δ lines and drawn with additive blending (Gaussian weight of the curve parameter, "
        "σ = 2), depth-tested against the frame; the resolve keeps each pixel's own radiance with weight w_b. "
        "Coverage weights (`weights=coverage`, not the paper's): each fragment's weight is also divided by its "
        "curve's fragment count, so a curve adds one unit of weight in all, the fraction of the shutter its "
        "surface spends over each pixel. "
        "Linear: the baseline the paper compares with (McGuire et al. 2012), a gather of S taps along the "
        "largest half-shutter velocity of the pixel's K×K tile and its neighbours, weighted by depth, cones "
        "and cylinders. "
        f"Reference: `--shutter S --shutter-reference {n}`, the mean of {n} frames at stratified times over "
        f"the shutter. Sharp and blurred frames accumulate {n} frames of `direct` at t, so their noise is "
        "the reference's. ratio: the blurred frame's relMSE over the sharp frame's (below 1: nearer the "
        "reference). Times: GPU timestamps, mean per frame; `direct` ms is the sharp run's whole frame "
        "(G-buffer, shadow maps, lighting)"
        + (". On lavapipe compare the cells with each other, not with GPU figures." if cpu else "."), "",
        "| case | scene | t s | shutter s | what moves |",
        "|---|---|---:|---:|---|",
    ]
    for k, (scene, t, shutter, what) in enumerate(CASES):
        lines.append(f"| {k + 1} | `{scene}` | {t} | {shutter} | {what} |")
    lines += ["", "Each case's sharp frame, curves at the paper's defaults, the linear baseline and the reference: "
              + ", ".join(f"[case {k + 1}]({args.doc}-{k + 1}.png)" for k in range(len(CASES))) + "."]
    lines += ["", "| case | image | FLIP | relMSE | ratio | passes ms | blur ms | blur ÷ direct |",
              "|---|---|---:|---:|---:|---|---:|---:|"]
    fmt = lambda v, d=2: "–" if v is None else f"{v:.{d}f}"  # noqa: E731
    for k, sharp_error, sharp_frame, results in rows:
        direct_ms = (sharp_frame or {}).get("mean_ms")
        lines.append(f"| {k + 1} | sharp | {sharp_error['flip']:.4f} | {sharp_error['rel_mse']:.5f} | 1 | – | – | "
                     f"direct {fmt(direct_ms, 1)} ms |")
        for label, error, times, _ in results:
            ratio = error["rel_mse"] / sharp_error["rel_mse"]
            total = sum(t for t in times if t is not None) if all(t is not None for t in times) else None
            over = total / direct_ms if total is not None and direct_ms else None
            lines.append(f"| {k + 1} | {label} | {error['flip']:.4f} | {error['rel_mse']:.5f} | {ratio:.3f} | "
                         + " + ".join(fmt(t) for t in times) + f" | {fmt(total)} | {fmt(over)} |")
    m.write_doc(SCRIPT, args.doc, lines)


if __name__ == "__main__":
    main()
