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
noise alone adds. Options: --size WxH, --frames N, --spp N, --doc NAME, --allow-dirty, --reuse-reference
(keep the reference frames of an earlier run with the same size, frames and spp: the document names the
commit they were rendered at).
"""
import argparse
import json
import re
import shutil
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

OUT = m.scratch("flight")
DOC = m.ROOT / "docs/measurements"
SCENE = "atrium:animate=camera"
# The direct light's samples of the sky per pixel and frame in every technique but path: at the default
# 4 its noise dominated every technique's frame-to-frame change (a first run: all 1.7-2.4x the
# reference's), hiding what the GI adds; `direct` alone gives the floor this leaves.
DIRECT = {"env_samples": 64, "area_samples": 64}
# (label, technique, settings): the volume techniques of issue 11 with the settings whose motion
# behaviour differs (LPV's finer cascades follow the camera and snap to whole cells; its geometry volume
# takes the G-buffer's surfaces, which change as the camera moves; VXGI's one volume spans the scene,
# its clipmap levels follow the camera), and the other techniques for scale.
TECHNIQUES = [
    ("path spp=4", "path", {"spp": 4}),
    ("direct (no GI)", "direct", DIRECT),
    ("rsm", "rsm", {**DIRECT}),
    ("igi", "igi", {**DIRECT}),
    ("ddgi", "ddgi", {**DIRECT}),
    ("lpv 1 cascade", "lpv", {**DIRECT, "cascades": 1}),
    ("lpv 3 cascades", "lpv", {**DIRECT, "cascades": 3}),
    ("lpv 3 cascades, no geometry volume", "lpv", {**DIRECT, "cascades": 3, "geometry_volume": "false"}),
    ("vxgi", "vxgi", {**DIRECT}),
    ("vxgi 2 bounces", "vxgi", {**DIRECT, "bounces": 2}),
    ("vxgi 3 clipmap levels", "vxgi", {**DIRECT, "clipmap_levels": 3}),
]


def render(rtgi, name, technique, settings, size, frames, extra=()):
    """Renders the flight (or `extra`'s variant of it) into OUT/name_%04d.exr; returns its stats."""
    return m.render_sequence(rtgi, OUT, SCENE, name, technique, settings, size, frames, extra)


def main():
    args = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args.add_argument("--size", default="64x64")
    args.add_argument("--frames", type=int, default=60)
    args.add_argument("--spp", type=int, default=256, help="samples per pixel of each reference frame")
    args.add_argument("--doc", default="flight-lavapipe-64")
    args.add_argument("--allow-dirty", action="store_true")
    args.add_argument("--reuse-reference", action="store_true")
    args = args.parse_args()
    if args.frames < 3:
        sys.exit("--frames: at least 3 (stability needs consecutive pairs)")
    m.refuse_dirty_tree(args.allow_dirty, "measure-flight.py")
    rtgi = m.rtgi_binary()
    commit = m.describe()
    start_load = m.load_average()

    marker = OUT / "reference-run.json"
    wanted = {"size": args.size, "frames": args.frames, "spp": args.spp}
    earlier = json.loads(marker.read_text()) if marker.exists() else {}
    if args.reuse_reference and {k: earlier.get(k) for k in wanted} == wanted:
        m.log("measure-flight.py", f"reusing the reference frames rendered at {earlier['commit']}")
    else:
        if OUT.exists():
            shutil.rmtree(OUT)
        OUT.mkdir(parents=True)
        m.log("measure-flight.py", f"reference: {args.frames} frames at {args.spp} spp")
        render(rtgi, "reference", "path", {"spp": args.spp}, args.size, args.frames)
        # The reference's noise floor: its first frame twice (--hold: the same pose), different random
        # numbers.
        render(rtgi, "noise", "path", {"spp": args.spp}, args.size, 2, extra=("--hold",))
        earlier = {**wanted, "commit": commit}
        marker.write_text(json.dumps(earlier))
    ref_stats = json.loads((OUT / "reference.json").read_text())
    noise = m.compare(rtgi, OUT / "noise_0000.exr", OUT / "noise_0001.exr")
    reference = OUT / "reference_%04d.exr"

    rows = []
    for label, technique, settings in TECHNIQUES:
        m.log("measure-flight.py", label)
        name = re.sub(r"[^A-Za-z0-9]+", "-", label).strip("-")
        stats = render(rtgi, name, technique, settings, args.size, args.frames)
        seq = json.loads(m.run([rtgi, "compare", reference, OUT / f"{name}_%04d.exr", "--json"]))
        rows.append((label, stats, seq))
        for f in OUT.glob(f"{name}_*.exr"):
            f.unlink()

    ref_flip = rows[0][2]["temporal"]["reference"]["flip"]
    end_load = m.load_average()
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
        f"(full GI, {args.spp} spp per frame"
        + (f", rendered at commit `{earlier['commit']}`" if earlier["commit"] != commit else "")
        + "). Columns: frame-to-frame FLIP, the mean FLIP between consecutive frames of the sequence, and "
        "its ratio to the reference's (the camera's motion alone; above 1 is change the technique adds: "
        "flicker, a cascade snapping, noise); the error against the reference frame by frame (mean FLIP and "
        "relMSE over the flight); GPU time per frame (mean over the frames after the first). Every technique "
        f"but path samples the sky and emitters with {DIRECT['env_samples']} rays per pixel and frame in its "
        "direct light (`--set env_samples=64 --set area_samples=64`), so that the direct light's noise does not "
        "hide the GI's change; `direct` shows the floor that noise leaves.", "",
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
