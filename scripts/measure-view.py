#!/usr/bin/env python3
"""Prints docs/measurements/view-lavapipe.md: what the `rtgi view` window costs over `rtgi render` (issue 16).

    cargo build --release -p rtgi-cli && python3 scripts/measure-view.py             # a few minutes on lavapipe
    python3 scripts/measure-view.py --doc view-gpu                                   # a GPU (needs Xvfb there too)

For each technique below on `cornell` at --size (default 1280x720), `rtgi view` renders under Xvfb at that
fixed render size (`--render-size`) and its script measures the wall time per rendered frame over --frames
frames after a warm-up (`measure N FILE`): the render thread's frames while the window tone-maps each one on
the GPU, composites it with the egui panel and presents it. `rtgi render` renders the same view for the same
number of frames (plus one: its first frame, which compiles pipelines, is left out of its wall time per
frame). The overhead is the viewer's time per frame over render's. Options: --size WxH, --frames N,
--doc NAME, --allow-dirty.
"""
import argparse
import json
import shutil
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-view.py"
OUT = m.scratch("view")
DOC = m.ROOT / "docs/measurements"
SCENE = "cornell"
TECHNIQUES = ["direct", "rsm", "ddgi"]
WARMUP = 4


def viewer_ms(rtgi, technique, size, frames):
    script = OUT / f"{technique}.txt"
    result = OUT / f"{technique}-view.json"
    script.write_text(f"frames {WARMUP}\nrun\nmeasure {frames} {result}\nquit\n")
    w, h = (int(v) for v in size.split("x"))
    screen = f"-screen 0 {w + 600}x{h + 200}x24"
    m.run(["xvfb-run", "-a", "-s", screen, rtgi, "view", "--scene", SCENE, "--technique", technique,
           "--render-size", size, "--size", f"{w + 400}x{h + 100}", "--script", script])
    return json.loads(result.read_text())


def render_ms(rtgi, technique, size, frames):
    stats = OUT / f"{technique}-render.json"
    m.run([rtgi, "render", "--scene", SCENE, "--technique", technique, "--size", size,
           "--frames", str(frames + 1), "--out", OUT / f"{technique}.exr", "--stats", stats])
    return json.loads(stats.read_text())


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="1280x720")
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--doc", default="view-lavapipe")
    parser.add_argument("--allow-dirty", action="store_true")
    args = parser.parse_args()
    m.refuse_dirty_tree(args.allow_dirty, SCRIPT)
    if shutil.which("xvfb-run") is None:
        sys.exit(f"{SCRIPT}: needs xvfb-run (Debian's xvfb; scripts/ensure-xvfb.sh installs it)")
    rtgi = m.rtgi_binary()
    rows = []
    adapter = None
    start_load = m.load_average()
    for technique in TECHNIQUES:
        m.log(SCRIPT, f"{technique}: viewer")
        view = viewer_ms(rtgi, technique, args.size, args.frames)
        m.log(SCRIPT, f"{technique}: render")
        stats = render_ms(rtgi, technique, args.size, args.frames)
        adapter = stats["adapter"]
        render = stats["frame_wall"]["mean_ms"]
        viewer = view["wall_ms_per_frame"]
        rows.append((technique, viewer, render, (viewer / render - 1.0) * 100.0))
    command = m.command_line(SCRIPT)
    lines = [
        f"# `rtgi view`: the window's cost per frame ({args.size}, {m.adapter_text(adapter)})",
        "",
        f"Printed by `{command}` at commit `{m.describe()}` on {m.adapter_text(adapter)}. "
        + m.load_text(start_load, m.load_average()),
        "",
        f"`{SCENE}` rendered at {args.size}. Viewer: wall time per rendered frame over {args.frames} frames "
        f"after {WARMUP} warm-up frames, measured by its `--script` (`measure`), the window under Xvfb "
        "showing each frame (GPU tone map, egui panel, present). Render: `rtgi render --frames "
        f"{args.frames + 1}` of the same view, wall time per frame after the first (`frame_wall` of its "
        "statistics). Overhead: viewer over render. On a CPU driver the window's own work (egui's "
        "tessellation and drawing, the present through Xvfb) runs on the same cores as the rendering.",
        "",
        "| technique | viewer ms/frame | render ms/frame | overhead |",
        "|---|---:|---:|---:|",
    ]
    for technique, viewer, render, overhead in rows:
        lines.append(f"| {technique} | {viewer:.1f} | {render:.1f} | {overhead:+.1f} % |")
    DOC.mkdir(parents=True, exist_ok=True)
    path = DOC / f"{args.doc}.md"
    path.write_text("\n".join(lines) + "\n")
    print(path.read_text())


if __name__ == "__main__":
    main()
