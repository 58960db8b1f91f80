#!/usr/bin/env python3
"""Prints docs/measurements/ism-lavapipe.md: what imperfect shadow maps (`visibility=ism`) cost and lose
against shadow rays for the same VPLs (issue 15, item 4's trade-off).

    cargo build --release -p rtgi-cli && python3 scripts/measure-ism.py      # about 4 min on lavapipe
    python3 scripts/measure-ism.py --size 1920x1080 --doc ism-gpu            # a GPU

Per scene, `igi` renders the same VPLs (same seed and frames) once with shadow rays and once with the maps
at several map sizes and point counts; the shadow-ray image is the reference of the comparison, so FLIP
and relMSE measure only what the maps get wrong about visibility. On `two-rooms` it also prints the light
on the dark room's floor against the shadow rays' (the leak through the wall). Times are the mean GPU
time per frame over the frames after the first. Options: --size WxH, --vpls N, --frames N, --doc NAME,
--allow-dirty.
"""
import argparse
import json
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-ism.py"
SCENES = ("cornell", "cornell-spot", "two-rooms", "atrium", "bumpy-glossy")
# (map size, points per map): the default first.
MAPS = ((32, 8192), (64, 8192), (32, 32768))
VISIBILITY_PASSES = ("visibility + accumulation", "ism points", "ism splat", "ism pull-push")


def frame_ms(stats, names=None):
    """Mean GPU ms per frame of the passes `names` (all passes when None)."""
    return sum(p["gpu"]["mean_ms"] for p in stats["passes"]
               if p.get("gpu") and (names is None or p["name"] in names))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="256x256")
    parser.add_argument("--vpls", default="1024")
    parser.add_argument("--frames", default="3")
    parser.add_argument("--doc", default="ism-lavapipe")
    parser.add_argument("--allow-dirty", action="store_true")
    args = parser.parse_args()
    m.refuse_dirty_tree(args.allow_dirty, SCRIPT)
    rtgi = m.rtgi_binary()
    out = m.scratch("ism")
    width, height = (int(v) for v in args.size.split("x"))
    load_start = m.load_average()

    def render(scene, name, sets):
        exr, stats = out / f"{scene}-{name}.exr", out / f"{scene}-{name}.json"
        flags = [x for k, v in {"vpls": args.vpls, **sets}.items() for x in ("--set", f"{k}={v}")]
        m.run([rtgi, "render", "--scene", scene, "--technique", "igi", "--size", args.size,
               "--frames", args.frames, *flags, "--out", exr, "--stats", stats])
        return exr, json.loads(stats.read_text())

    rows, leak, adapter = [], [], None
    for scene in SCENES:
        m.log(SCRIPT, f"{scene} ...")
        rays_exr, rays = render(scene, "rays", {"visibility": "rays"})
        adapter = rays["adapter"]
        rows.append((scene, "shadow rays", frame_ms(rays), frame_ms(rays, VISIBILITY_PASSES), None))
        for size, points in MAPS:
            exr, stats = render(scene, f"ism-{size}-{points}",
                                {"visibility": "ism", "ism_size": size, "ism_points": points})
            region = m.dark_floor(width, height) if scene == "two-rooms" else None
            c = m.compare(rtgi, rays_exr, exr, region=region)
            label = f"ism {size}², {points} points"
            rows.append((scene, label, frame_ms(stats), frame_ms(stats, VISIBILITY_PASSES), c))
            if region:
                r = c["region"]
                leak.append((label, r["test_luminance"] / r["reference_luminance"], region))

    lines = [
        f"# Imperfect shadow maps against shadow rays for the same VPLs ({width}×{height})", "",
        f"Printed by `{m.command_line(SCRIPT)}` at commit `{m.describe()}` on {m.adapter_text(adapter)}"
        + (", 2 CPU cores" if adapter.get("device_type") == "Cpu" else "") + ". "
        + m.load_text(load_start, m.load_average()), "",
        f"`igi` with {args.vpls} VPLs and its defaults, {args.frames} frames accumulated, the same VPLs in "
        "every row of a scene. The error columns compare each map setting with the shadow-ray image of the "
        "same scene, so they measure only the maps' visibility errors (not the VPLs' own error against a "
        "path-traced reference: for that see vpl-equal-time-lavapipe.md). Visibility ms: the gather "
        "(`visibility + accumulation`) plus the `ism` passes.", "",
        "| scene | visibility | ms/frame | visibility ms | FLIP against rays | relMSE against rays |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for scene, label, total, vis, c in rows:
        error = f"{c['flip']:.4f} | {c['rel_mse']:.5f}" if c else "– | –"
        lines.append(f"| {scene} | {label} | {total:.1f} | {vis:.1f} | {error} |")
    if leak:
        lines += ["", "## Leaks on two-rooms", "",
                  f"Mean luminance of the dark room's floor (pixels {leak[0][2]}: x, y, w, h), which only "
                  "light through the doorway reaches, against the shadow rays' with the same VPLs:", "",
                  "| visibility | floor / shadow rays |", "|---|---:|"]
        lines += [f"| {label} | {ratio:.3f} |" for label, ratio, _ in leak]
    m.write_doc(SCRIPT, args.doc, lines)


if __name__ == "__main__":
    main()
