#!/usr/bin/env python3
"""Prints docs/measurements/glints-lavapipe.md: footprint-filtered glints (`glints`) against one normal per pixel (`direct`), supersampling, and the box-filtered path tracer at equal time.

    cargo build --release -p rtgi-cli && python3 scripts/measure-glints.py       # about 15 min on lavapipe
    python3 scripts/measure-glints.py --sizes 1920x1080 --doc glints-gpu         # a GPU

On `glints` (metallic flakes, 256² normal map tiled 6 times over the floor, two point lights): the reference is
`path` with `max_bounces=0 pixel_jitter=true` at 4096 samples per pixel, each spread over its pixel, i.e. the
direct light integrated over every pixel's footprint, which is what the glint filter computes in one frame.
Rows: `glints` over its histogram resolution (bins), `direct` (one normal per pixel, the G-buffer's mip-filtered
normal map), `direct` supersampled over 16 jittered frames, and the path tracer at 1-64 samples per pixel. Times:
GPU timestamps, mean of the steady frames (the last 2 of 3; the first includes compiling the pipelines). Then
temporal stability over an 8-frame camera pan (1 cm per frame): mean FLIP between consecutive frames, the
reference's own being the change the motion really makes. Report 003 §2.7 experiments 1, 3, 4 and 5 in the
form this implementation allows (see the document's notes).
Options: --sizes WxH[,WxH...], --doc NAME, --allow-dirty.
"""
import json
import math
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-glints.py"
OUT = m.scratch("glints")
SCENE = "glints"
BINS = ["9", "13", "17", "21"]
PATH_SPP = ["1", "4", "16", "64"]
REFERENCE = ["--set", "max_bounces=0", "--set", "pixel_jitter=true"]
CAMERA = (0.0, 1.2, 3.0, 0.0, 0.2, -0.8, 45.0)
PAN_STEP = 0.01
PAN_FRAMES = 8


def frame_ms(stats):
    f = stats.get("frame_gpu") or stats.get("frame_wall")
    return f["mean_ms"] if f else None


def main():
    def options(parser):
        parser.add_argument("--sizes", default="128x128,256x256")

    args, rtgi, commit, start_load = m.script_arguments(
        SCRIPT, __doc__.splitlines()[0], "glints-lavapipe", options)

    def render(size, name, technique, settings=(), frames="3", extra=()):
        out = OUT / f"{size}-{name}.exr"
        stats_path = OUT / f"{size}-{name}.json"
        m.log(SCRIPT, f"{size}: {name}")
        sets = [x for s in settings for x in ("--set", s)]
        m.run([rtgi, "render", "--scene", SCENE, "--technique", technique, "--size", size, "--frames", frames,
               *sets, *extra, "--out", out, "--stats", stats_path])
        return out, json.loads(stats_path.read_text())

    sections = []
    adapter = None
    temporal = None
    for size in args.sizes.split(","):
        ref, ref_stats = render(size, "reference", "path", ["max_bounces=0", "pixel_jitter=true", "spp=256"],
                                frames="16")
        adapter = ref_stats["adapter"]
        rows = []
        for bins in BINS:
            out, stats = render(size, f"glints-{bins}", "glints", [f"bins={bins}"])
            rows.append((f"glints, bins {bins}", m.compare(rtgi, ref, out), frame_ms(stats), 1, stats))
        out, stats = render(size, "direct", "direct")
        rows.append(("direct (one normal per pixel)", m.compare(rtgi, ref, out), frame_ms(stats), 1, stats))
        out, stats = render(size, "direct-16", "direct", frames="16", extra=["--jitter", "halton"])
        rows.append(("direct, 16 jittered frames", m.compare(rtgi, ref, out), frame_ms(stats), 16, stats))
        for spp in PATH_SPP:
            out, _ = render(size, f"path-{spp}", "path", ["max_bounces=0", "pixel_jitter=true", f"spp={spp}"],
                            frames="1")
            _, timing = render(size, f"path-{spp}-timing", "path",
                               ["max_bounces=0", "pixel_jitter=true", f"spp={spp}"])
            rows.append((f"path, {spp} spp", m.compare(rtgi, ref, out), frame_ms(timing), 1, timing))
        sections.append((size, ref_stats, rows))
        if temporal is None:
            temporal = (size, pan(rtgi, size))

    end_load = m.load_average()
    cpu = adapter.get("device_type") == "Cpu"
    lines = [
        "# Glints: footprint-filtered normal maps against one normal per pixel and the path tracer", "",
        f"Printed by `{m.command_line(SCRIPT)}` at commit `{commit}` on {m.adapter_text(adapter)}"
        + (", 2 CPU cores" if cpu else "") + ". " + m.load_text(start_load, end_load), "",
        "`glints` on the built-in `glints` scene (`crates/rtgi/src/techniques/glints/`): each pixel's footprint "
        "(the ray differentials' parallelogram as the axis-aligned box with its second moments, in texel space) gets its histogram of micronormals from the "
        "histogram SAT, and every light is reflected by Σ_b w_b f(n_b) (n_b·l)⁺ over the non-empty bins. "
        "Reference: `path` with `max_bounces=0 pixel_jitter=true` at 4096 samples per pixel spread over each "
        "pixel: the direct light integrated over the pixel, normals read bilinearly at full resolution, shadows "
        "traced. Errors over the whole image. \"ms per image\" is the GPU time of everything the image needs "
        "(G-buffer and shadow maps included): one frame, or 16 for the supersampled `direct`. On lavapipe "
        "compare the rows with each other, not with GPU figures.",
    ]
    fmt = lambda v, d=1: "–" if v is None else f"{v:.{d}f}"  # noqa: E731
    for size, ref_stats, rows in sections:
        w, h = (int(v) for v in size.split("x"))
        glint = next(s for label, _, _, _, s in rows if label == "glints, bins 17")
        c = glint["counters"]
        pixels = c["glints_pixels"]
        lines += ["", f"## {size.replace('x', '×')}", "",
                  f"{int(pixels)} of {w * h} pixels show a glint material. With bins = 17: "
                  f"{c['glints_active_bins'] / max(pixels, 1):.1f} occupied bins per glint pixel, histogram "
                  f"{c['glints_histogram_bytes'] / 2**20:.1f} MiB ({c['glints_histogram_bytes'] / (256 * 256):.0f} "
                  f"bytes per texel of the 256² map), built in {c['glints_histogram_build_ms']:.0f} ms on the CPU.",
                  "", "| setting | RMSE | relMSE | FLIP | ms per image | path's FLIP at that time |",
                  "|---|---:|---:|---:|---:|---:|"]
        paths = [(ms, e["flip"]) for label, e, ms, _, _ in rows if label.startswith("path") and ms]
        for label, error, ms, frames, _ in rows:
            total = None if ms is None else ms * frames
            at = "" if label.startswith("path") else fmt(m.log_log_interpolate(paths, total), 4)
            lines.append(f"| {label} | {error['rmse']:.4f} | {error['rel_mse']:.4f} | {error['flip']:.4f} | "
                         f"{fmt(total)} | {at} |")
    size, (pan_rows, step_px) = temporal
    lines += ["", f"## Temporal stability ({size.replace('x', '×')})", "",
              f"{PAN_FRAMES} stills with the camera and its target moved {PAN_STEP * 100:.1f} cm to the right "
              f"per frame (about {step_px:.2f} pixel at the floor's centre): mean FLIP and relMSE between "
              "consecutive frames. The reference's figure is the change the motion itself makes; what a "
              "technique shows above it is flicker.", "",
              "| sequence | FLIP between frames | relMSE between frames | FLIP against the reference's frames |",
              "|---|---:|---:|---:|"]
    for label, t, against in pan_rows:
        lines.append(f"| {label} | {t['flip']:.4f} | {t['rel_mse']:.4f} | "
                     + ("–" if against is None else f"{against:.4f}") + " |")
    lines += ["", "Not measured here: the scene has no environment. The thesis's SH basis-space integration of "
              "environment lighting and its ratio estimator for shadows (`env_order`) are measured by "
              "`scripts/measure-glints-environment.py` (report 003 §2.7 experiments 2, 4 and 7)."]
    m.write_doc(SCRIPT, args.doc, lines)


def pan(rtgi, size):
    """Renders the pan for glints, direct and the reference; returns their temporal figures and the pan's
    step in pixels at the floor's centre."""
    w, h = (int(v) for v in size.split("x"))
    x, y, z, tx, ty, tz, fov = CAMERA
    distance = math.dist((x, y, z), (tx, ty, tz))
    step_px = PAN_STEP / (2 * distance * math.tan(math.radians(fov) / 2)) * h
    cases = [("reference (path, 1024 spp)", "path", ["max_bounces=0", "pixel_jitter=true", "spp=256"], "4"),
             ("glints", "glints", [], "1"), ("direct", "direct", [], "1")]
    patterns = {}
    for label, technique, settings, frames in cases:
        name = technique
        for k in range(PAN_FRAMES):
            dx = k * PAN_STEP
            camera = f"{x + dx},{y},{z},{tx + dx},{ty},{tz},{fov}"
            m.log(SCRIPT, f"pan {label}: frame {k}")
            sets = [a for s in settings for a in ("--set", s)]
            m.run([rtgi, "render", "--scene", SCENE, "--technique", technique, "--size", size, "--frames", frames,
                   *sets, "--camera", camera, "--out", OUT / f"pan-{name}_{k:04d}.exr"])
        patterns[label] = OUT / f"pan-{name}_%04d.exr"
    # The reference's own noise: its first frame again with other random numbers.
    m.run([rtgi, "render", "--scene", SCENE, "--technique", "path", "--size", size, "--frames", "4",
           "--set", "max_bounces=0", "--set", "pixel_jitter=true", "--set", "spp=256", "--set", "seed=1",
           "--camera", ",".join(str(v) for v in CAMERA), "--out", OUT / "pan-noise.exr"])
    noise = m.compare(rtgi, OUT / "pan-path_0000.exr", OUT / "pan-noise.exr")
    rows = [("reference's noise (frame 0 against itself with other random numbers)", noise, None)]
    reference = patterns[cases[0][0]]
    for label, _, _, _ in cases:
        t = json.loads(m.run([rtgi, "compare", "--temporal", patterns[label], "--json"]))
        against = None
        if label != cases[0][0]:
            both = json.loads(m.run([rtgi, "compare", reference, patterns[label], "--json"]))
            against = both["mean"]["flip"]
        rows.append((label, t, against))
    return rows, step_px


if __name__ == "__main__":
    main()
