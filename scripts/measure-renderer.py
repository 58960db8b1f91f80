#!/usr/bin/env python3
"""Measures the persistent renderer ("Moving worlds", issue 9) and writes docs/measurements/renderer.md.

- per-frame wall time with one command encoder per frame (`--timing frame`) against one submission per
  pass (`--timing passes`, the submit-and-wait-per-pass profiler of before), at 64x64 and 256x256;
- 300-frame animations at 256x256 (a camera flight through atrium, a box moving through cornell):
  setup work after the first frame (scene uploads, BVH builds, in-place geometry updates, shader
  compilations);
- a 10 000-frame run at 64x64: process RSS and GPU bytes after 100 and after 10 000 frames;
- every registered technique on every animated built-in variant (errors, setup work per frame).

Python 3 standard library only; renders with target/release/rtgi (built first).

    python3 scripts/measure-renderer.py          # everything (about 15 min on 2 CPU cores with lavapipe)
    QUICK=1 python3 scripts/measure-renderer.py  # fewer frames, for a check of the script
"""
import json
import os
import subprocess
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
os.chdir(ROOT)
os.environ["NODEVICE_SELECT"] = "1"
RTGI = Path(os.environ.get("RTGI", ROOT / "target/release/rtgi"))
OUT = Path(os.environ.get("OUT", "target/measure/renderer"))
DOC = Path(os.environ.get("DOC", ROOT / "docs/measurements/renderer.md"))
QUICK = os.environ.get("QUICK") == "1"

TIMING_TECHNIQUES = [
    ("direct", []),
    ("path", ["spp=1"]),
    ("igi-sh", ["vpls=256"]),
    ("rsm", ["samples=64"]),
    ("sii", ["vpls=256"]),
]
ANIMATED = [
    "cornell:animate=box",
    "cornell-spot:animate=box",
    "cornell-spot:animate=spot",
    "two-rooms:animate=spot",
    "atrium:animate=camera",
    "atrium:animate=sun",
]


def sh(*args):
    return subprocess.run([str(a) for a in args], check=True, capture_output=True, text=True).stdout


def render(name, scene, technique, settings, size, frames, *extra):
    stats = OUT / f"{name}.json"
    sets = [x for s in settings for x in ("--set", s)]
    sh(RTGI, "render", "--scene", scene, "--technique", technique, "--size", size, "--frames", frames,
       *sets, *extra, "--out", OUT / f"{name}.exr", "--stats", stats)
    return json.loads(stats.read_text())


def ms(summary):
    return f"{summary['mean_ms']:.2f} / {summary['p95_ms']:.2f}" if summary else "–"


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    sh("cargo", "build", "--release", "-p", "rtgi-cli")
    commit = sh("git", "rev-parse", "--short", "HEAD").strip()
    if sh("git", "status", "--porcelain", "--untracked-files=no").strip():
        commit += " (with uncommitted changes)"
    lines = ["# Persistent renderer: frame overhead, steady state, memory, animated scenes", "",
             "Printed by `python3 scripts/measure-renderer.py`" + (" (QUICK=1)" if QUICK else "")
             + f" at commit {commit}.", ""]

    # 1. One encoder per frame against one submission per pass.
    rows, adapter = [], None
    for size, frames in [("64x64", 12 if QUICK else 60), ("256x256", 4 if QUICK else 16)]:
        for technique, settings in TIMING_TECHNIQUES:
            cells = []
            for timing in ["frame", "passes"]:
                s = render(f"timing-{technique}-{size}-{timing}", "cornell-spot", technique, settings, size,
                           frames, "--timing", timing)
                adapter = s["adapter"]["name"]
                cells.append(s["frame_wall"])
            gain = cells[1]["mean_ms"] / cells[0]["mean_ms"] if cells[0] and cells[1] else float("nan")
            rows.append(f"| {technique} {' '.join(settings)} | {size} | {frames} | {ms(cells[0])} | {ms(cells[1])} "
                        f"| {gain:.2f}x |")
    lines += [f"Adapter: {adapter}.", "",
              "## Per-frame wall time: one command encoder per frame vs one submission per pass", "",
              "Scene `cornell-spot`; wall time per frame from submission to completion, mean / 95th percentile"
              " over the frames after the first (ms). `passes` is the profiler of before this issue (every pass"
              " submitted and waited for).", "",
              "| technique | size | frames | frame (mean / p95) | passes (mean / p95) | passes ÷ frame |",
              "|---|---|---|---|---|---|", *rows, ""]

    # 2. Animations: nothing is rebuilt after the first frame; a moving box is an instance of the
    #    two-level BVH (its top level rebuilt each frame it moves, no bottom-level BVH build).
    flight_frames = 30 if QUICK else 300
    lines += ["## Animations at 256x256", "",
              f"`rtgi render --scene SCENE --frames {flight_frames} --fps 30 --out 'f_%04d.exr'`:"
              " setup work over the whole run (the first frame's included). Geometry updates: frames in which"
              " moving meshes were moved in place (vertices rewritten, BVH top level rebuilt).", "",
              "| scene | technique | frames | scene uploads | BVH builds | geometry updates | technique builds |"
              " shader compilations | frame wall mean / p95 (ms) | process wall (s) |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for scene, technique, settings in [("atrium:animate=camera", "direct", []),
                                       ("atrium:animate=camera", "rsm", ["samples=64"]),
                                       ("cornell:animate=box", "direct", []),
                                       ("cornell:animate=box", "path", ["spp=1"])]:
        name = f"anim-{scene.replace(':', '-').replace('=', '-')}-{technique}"
        stats = OUT / f"{name}.json"
        sets = [x for s in settings for x in ("--set", s)]
        start = time.monotonic()
        sh(RTGI, "render", "--scene", scene, "--technique", technique, "--size", "256x256",
           "--frames", flight_frames, "--fps", "30", *sets, "--out", OUT / f"{name}-%04d.exr",
           "--stats", stats)
        seconds = time.monotonic() - start
        s = json.loads(stats.read_text())
        r = s["renderer"]
        lines.append(f"| {scene} | {technique} {' '.join(settings)} | {s['frames']} | {r['scene_uploads']} | "
                     f"{r['bvh_builds']} | {r['geometry_updates']} | {r['technique_builds']} | "
                     f"{r['shader_compilations']} | {ms(s['frame_wall'])} | {seconds:.1f} |")
    lines.append("")

    # 3. Memory over a long run.
    long_frames = 1000 if QUICK else 10000
    s = render("long", "cornell-spot", "direct", [], "64x64", long_frames)
    by_frames = {m["frames"]: m for m in s["memory"]}
    warm, end = by_frames[100], by_frames[long_frames]
    lines += [f"## {long_frames} frames of `direct` on cornell-spot at 64x64", "",
              "| after frame | RSS (MiB) | GPU buffers | GPU buffer bytes | GPU texture bytes |", "|---|---|---|---|---|"]
    for m in s["memory"]:
        lines.append(f"| {m['frames']} | {m['rss_bytes'] / 2**20:.2f} | {m['gpu_buffers']} | {m['gpu_buffer_bytes']} "
                     f"| {m['gpu_texture_bytes']} |")
    growth = (end["rss_bytes"] - warm["rss_bytes"]) / warm["rss_bytes"] * 100
    gpu_growth = ((end["gpu_buffer_bytes"] + end["gpu_texture_bytes"])
                  - (warm["gpu_buffer_bytes"] + warm["gpu_texture_bytes"]))
    lines += ["", f"RSS from frame 100 to {long_frames}: {growth:+.2f} %; GPU bytes: {gpu_growth:+d}.", ""]

    # 4. Every technique on every animated variant.
    lines += ["## Every technique on every animated variant (64x64, 4 frames at 2 fps)", "",
              "Setup work per run: scene uploads / technique builds / geometry updates (1 / 1 / n: nothing was"
              " rebuilt; n frames moved meshes in place).", "",
              "| scene | " + " | ".join(t for t, _ in TIMING_TECHNIQUES + [("igi", ["vpls=256"]),
                                                                       ("rsm-interleaved", [])]) + " |",
              "|---|" + "---|" * (len(TIMING_TECHNIQUES) + 2)]
    for scene in ANIMATED:
        cells = []
        for technique, settings in TIMING_TECHNIQUES + [("igi", ["vpls=256"]), ("rsm-interleaved", [])]:
            try:
                stats = OUT / "variant.json"
                sets = [x for s in settings for x in ("--set", s)]
                sh(RTGI, "render", "--scene", scene, "--technique", technique, "--size", "64x64", "--frames", 4,
                   "--fps", 2, *sets, "--out", OUT / "variant-%02d.exr", "--stats", stats)
                r = json.loads(stats.read_text())["renderer"]
                cells.append(f"ok {r['scene_uploads']} / {r['technique_builds']} / {r['geometry_updates']}")
            except subprocess.CalledProcessError as e:
                cells.append("**error**: " + e.stderr.strip().splitlines()[-1])
        lines.append(f"| {scene} | " + " | ".join(cells) + " |")
    lines.append("")
    DOC.parent.mkdir(parents=True, exist_ok=True)
    DOC.write_text("\n".join(lines) + "\n")
    print(DOC.read_text())


if __name__ == "__main__":
    main()
