#!/usr/bin/env python3
"""Prints docs/measurements/flight-lavapipe-64.md: temporal stability over atrium's camera flight (issue 11).

    cargo build --release -p rtgi-cli && python3 scripts/measure-flight.py            # about 25 min on lavapipe
    python3 scripts/measure-flight.py --size 1920x1080 --spp 1024 --doc flight-gpu     # a GPU

Renders the first FRAMES frames (default 60, 2 s at 30 fps) of `atrium:animate=camera` with the path-traced
reference (full GI, --spp samples per frame) and with each technique below, then `rtgi compare`s each
sequence with the reference's frame by frame. Stability is the mean FLIP between consecutive frames of one
sequence: the camera's motion alone changes the reference's, so a technique's figure over the reference's
is the change it adds (flicker, popping when a cascade snaps, noise). The reference's own noise sets the
floor of that ratio: two renders of its first frame with different random numbers give the FLIP that
noise alone adds. Options: --size WxH, --frames N, --spp N, --doc NAME, --allow-dirty.
"""
import argparse
import json
import shutil
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

OUT = m.scratch("flight")
DOC = m.ROOT / "docs/measurements"
SCENE = "atrium:animate=camera"
# (label, technique, settings): the volume techniques of issue 11 with the settings whose motion
# behaviour differs (LPV's finer cascades follow the camera and snap to whole cells; its geometry volume
# takes the G-buffer's surfaces, which change as the camera moves; VXGI's one volume spans the scene),
# and the other techniques for scale.
TECHNIQUES = [
    ("path spp=4", "path", {"spp": 4}),
    ("rsm", "rsm", {}),
    ("igi", "igi", {}),
    ("ddgi", "ddgi", {}),
    ("lpv 1 cascade", "lpv", {"cascades": 1}),
    ("lpv 3 cascades", "lpv", {"cascades": 3}),
    ("lpv 3 cascades, no geometry volume", "lpv", {"cascades": 3, "geometry_volume": "false"}),
    ("vxgi", "vxgi", {}),
    ("vxgi 2 bounces", "vxgi", {"bounces": 2}),
]


def render(rtgi, name, technique, settings, size, frames, extra=()):
    """Renders the flight (or `extra`'s variant of it) into OUT/name_%04d.exr; returns its stats."""
    stats = OUT / f"{name}.json"
    sets = [x for k, v in settings.items() for x in ("--set", f"{k}={v}")]
    m.run([rtgi, "render", "--scene", SCENE, "--technique", technique, "--size", size, "--frames", frames,
           "--fps", 30, *sets, *extra, "--out", OUT / f"{name}_%04d.exr", "--stats", stats])
    return json.loads(stats.read_text())


def main():
    args = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args.add_argument("--size", default="64x64")
    args.add_argument("--frames", type=int, default=60)
    args.add_argument("--spp", type=int, default=256, help="samples per pixel of each reference frame")
    args.add_argument("--doc", default="flight-lavapipe-64")
    args.add_argument("--allow-dirty", action="store_true")
    args = args.parse_args()
    if args.frames < 3:
        sys.exit("--frames: at least 3 (stability needs consecutive pairs)")
    m.refuse_dirty_tree(args.allow_dirty, "measure-flight.py")
    rtgi = m.rtgi_binary()
    if OUT.exists():
        shutil.rmtree(OUT)
    OUT.mkdir(parents=True)
    start_load = m.load_average()

    m.log("measure-flight.py", f"reference: {args.frames} frames at {args.spp} spp")
    ref_stats = render(rtgi, "reference", "path", {"spp": args.spp}, args.size, args.frames)
    # The reference's noise floor: its first frame twice (--hold: the same pose), different random numbers.
    render(rtgi, "noise", "path", {"spp": args.spp}, args.size, 2, extra=("--hold",))
    noise = m.compare(rtgi, OUT / "noise_0000.exr", OUT / "noise_0001.exr")
    reference = OUT / "reference_%04d.exr"

    rows = []
    for label, technique, settings in TECHNIQUES:
        m.log("measure-flight.py", label)
        name = label.replace(" ", "-").replace(",", "").replace("=", "")
        stats = render(rtgi, name, technique, settings, args.size, args.frames)
        seq = json.loads(m.run([rtgi, "compare", reference, OUT / f"{name}_%04d.exr", "--json"]))
        rows.append((label, stats, seq))
        for f in OUT.glob(f"{name}_*.exr"):
            f.unlink()

    ref_flip = rows[0][2]["temporal"]["reference"]["flip"]
    end_load = m.load_average()
    commit = m.run(["git", "describe", "--always", "--dirty", "--abbrev=12"]).strip() \
        if (m.ROOT / ".git").exists() else "unknown"
    commit = m.os.environ.get("RTGI_COMMIT", commit)
    adapter = ref_stats["adapter"]
    cpu = adapter.get("device_type") == "Cpu"
    command = "python3 scripts/measure-flight.py" + "".join(f" {a}" for a in sys.argv[1:] if a != "--allow-dirty")
    width, height = args.size.split("x")
    lines = [
        f"# Temporal stability over atrium's camera flight (issue 11), {width}×{height}", "",
        f"Printed by `{command}` at commit `{commit}` on {m.adapter_text(adapter)}"
        + (", 2 CPU cores" if cpu else "") + ". " + m.load_text(start_load, end_load), "",
        f"`rtgi render --scene {SCENE} --technique T --size {args.size} --frames {args.frames} --fps 30`: the "
        f"first {args.frames / 30:.1f} s of the flight, one image per frame, against the path-traced reference "
        f"(full GI, {args.spp} spp per frame). Columns: frame-to-frame FLIP, the mean FLIP between consecutive "
        "frames of the sequence, and its ratio to the reference's (the camera's motion alone; above 1 is change "
        "the technique adds: flicker, a cascade snapping, noise); the error against the reference frame by "
        "frame (mean FLIP and relMSE over the flight); GPU time per frame (mean over the frames after the "
        "first).", "",
        f"The reference's frame-to-frame FLIP is {ref_flip:.4f}. Its own noise is part of that figure: two "
        f"renders of its first frame with different random numbers differ by {noise['flip']:.4f} "
        f"({100 * noise['flip'] / ref_flip:.0f} % of it), so a noise-free technique that follows the motion "
        "exactly can score below 1.", "",
        "| technique | frame-to-frame FLIP | ÷ reference's | FLIP vs reference | relMSE vs reference | "
        "GPU ms/frame |", "|---|---|---|---|---|---|",
    ]
    for label, stats, seq in rows:
        t = seq["temporal"]["test"]["flip"]
        gpu = stats.get("frame_gpu") or {}
        ms = f"{gpu['mean_ms']:.1f}" if gpu.get("mean_ms") is not None else "–"
        lines.append(f"| {label} | {t:.4f} | {t / ref_flip:.2f} | {seq['mean']['flip']:.4f} | "
                     f"{seq['mean']['rel_mse']:.4f} | {ms} |")
    lines.append("")
    doc = DOC / f"{args.doc}.md"
    doc.write_text("\n".join(lines) + "\n")
    print(doc.read_text())


if __name__ == "__main__":
    main()
