#!/usr/bin/env python3
"""Prints docs/measurements/radiance-cache-temporal-lavapipe.md: temporal radiance caching against per-frame
recomputation on the animated Cornell boxes (issue 13 item 3).

    cargo build --release -p rtgi-cli && python3 scripts/measure-radiance-cache-temporal.py      # ~15 min on lavapipe
    python3 scripts/measure-radiance-cache-temporal.py --size 1920x1080 --doc radiance-cache-temporal-gpu

For each animation (a box flying through `cornell`; the spot of `cornell-spot` sweeping) renders FRAMES frames
at 30 fps with the one-bounce path-traced reference (`max_bounces=1`, the cache's one bounce, --spp samples per
frame) and with `radiance-cache` (a new cache every frame: the thesis's per-frame recomputation) and
`radiance-cache-temporal` (records kept where they are, each living a_t / its predicted change frames, at most
max_lifespan), then `rtgi compare`s each sequence with the reference frame by frame (the mean, and every
fifth frame as the thesis's Fig. 5.10 of accuracy over time). Flicker is the mean FLIP
between consecutive frames over the reference's (the motion alone; the reference's noise is in it too). GPU
time is the mean per frame after the first (the first builds the whole cache in both). Options: --size WxH,
--frames N, --spp N, --doc NAME, --allow-dirty.
"""
import argparse
import json
import re
import shutil
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

OUT = m.scratch("radiance-cache-temporal")
SCENES = [
    ("moving box", "cornell:animate=box"),
    ("moving light", "cornell-spot:animate=spot"),
]
# (label, technique, settings)
TECHNIQUES = [
    ("per-frame recomputation", "radiance-cache", {}),
    # The default 4 placement rounds leave a per-frame cache with about a third of the records a converged
    # one holds (by hand on cornell-spot 96²: 131 records and 82 missing tiles in the last round, against
    # 370 and none at 16 rounds); the temporal cache converges over the frames, so the fair baseline is this.
    ("per-frame recomputation, 16 rounds (converged)", "radiance-cache", {"iterations": 16}),
    ("temporal (a_t 0.05, δt_max 20)", "radiance-cache-temporal", {}),
    ("temporal, no temporal gradients", "radiance-cache-temporal", {"temporal_gradients": "false"}),
    ("temporal, δt_max 5", "radiance-cache-temporal", {"max_lifespan": 5}),
    ("temporal, δt_max 1 (records fixed, recomputed every frame)", "radiance-cache-temporal", {"max_lifespan": 1}),
]


def render(rtgi, scene, name, technique, settings, size, frames):
    """Renders the animation into OUT/name_%04d.exr; returns its stats."""
    return m.render_sequence(rtgi, OUT, scene, name, technique, settings, size, frames)


def main():
    args = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args.add_argument("--size", default="96x96")
    args.add_argument("--frames", type=int, default=40)
    args.add_argument("--spp", type=int, default=64, help="samples per pixel of each reference frame")
    args.add_argument("--doc", default="radiance-cache-temporal-lavapipe")
    args.add_argument("--allow-dirty", action="store_true")
    args = args.parse_args()
    if args.frames < 3:
        sys.exit("--frames: at least 3 (flicker needs consecutive pairs)")
    m.refuse_dirty_tree(args.allow_dirty, "measure-radiance-cache-temporal.py")
    rtgi = m.rtgi_binary()
    commit = m.describe()
    start_load = m.load_average()
    if OUT.exists():
        shutil.rmtree(OUT)
    OUT.mkdir(parents=True)

    tables = []
    adapter = None
    for scene_label, scene in SCENES:
        m.log("measure-radiance-cache-temporal.py", f"{scene}: reference, {args.spp} spp per frame")
        ref_name = re.sub(r"[^A-Za-z0-9]+", "-", scene)
        ref_stats = render(rtgi, scene, f"{ref_name}-reference", "path",
                           {"max_bounces": 1, "spp": args.spp}, args.size, args.frames)
        adapter = ref_stats["adapter"]
        reference = OUT / f"{ref_name}-reference_%04d.exr"
        rows = []
        for label, technique, settings in TECHNIQUES:
            m.log("measure-radiance-cache-temporal.py", f"{scene}: {label}")
            name = ref_name + "-" + re.sub(r"[^A-Za-z0-9]+", "-", label).strip("-")
            stats = render(rtgi, scene, name, technique, settings, args.size, args.frames)
            seq = json.loads(m.run([rtgi, "compare", reference, OUT / f"{name}_%04d.exr", "--json"]))
            rows.append((label, stats, seq))
            for f in OUT.glob(f"{name}_*.exr"):
                f.unlink()
        tables.append((scene_label, scene, rows))

    end_load = m.load_average()
    cpu = adapter.get("device_type") == "Cpu"
    command = m.command_line("measure-radiance-cache-temporal.py")
    width, height = args.size.split("x")
    lines = [
        f"# Temporal radiance caching against per-frame recomputation (issue 13 item 3), {width}×{height}", "",
        f"Printed by `{command}` at commit `{commit}` on {m.adapter_text(adapter)}"
        + (", 2 CPU cores" if cpu else "") + ". " + m.load_text(start_load, end_load), "",
        f"`rtgi render --scene S --technique T --size {args.size} --frames {args.frames} --fps 30`: the first "
        f"{args.frames / 30:.2f} s of each animation, against the one-bounce path-traced reference "
        f"(`--set max_bounces=1 --set spp={args.spp}` per frame). Columns: error against the reference frame by "
        "frame (mean FLIP and relMSE); flicker: the mean FLIP between consecutive frames, and its ratio to the "
        "reference's (the motion alone plus the reference's own noise); GPU ms per frame (mean over the frames "
        "after the first, which builds the whole cache in every variant) and the speedup over converged "
        "per-frame recomputation; records computed per frame (new and refreshed, over all frames); records alive at the "
        "end and their mean lifespan in frames.", "",
    ]
    for scene_label, scene, rows in tables:
        ref_flip = rows[0][2]["temporal"]["reference"]["flip"]
        base_ms = rows[1][1]["frame_gpu"]["mean_ms"]
        lines += [
            f"## {scene_label}: `{scene}`", "",
            f"The reference's frame-to-frame FLIP is {ref_flip:.4f}.", "",
            "| variant | FLIP vs reference | relMSE vs reference | frame-to-frame FLIP | ÷ reference's | "
            "GPU ms/frame | speedup | records computed per frame | records alive | mean lifespan |",
            "|---|---|---|---|---|---|---|---|---|---|",
        ]
        for label, stats, seq in rows:
            c = stats["counters"]
            t = seq["temporal"]["test"]["flip"]
            ms = stats["frame_gpu"]["mean_ms"]
            if "records_refreshed" in c:
                computed = f"{(c['records_created'] + c['records_refreshed']) / stats['frames']:.1f}"
                alive = f"{c['records_live']:.0f}"
                life = f"{c.get('mean_record_lifespan_frames', 0):.1f}"
            else:
                computed = alive = f"{c['records']:.0f}"
                life = "1"
            lines.append(f"| {label} | {seq['mean']['flip']:.4f} | {seq['mean']['rel_mse']:.4f} | {t:.4f} | "
                         f"{t / ref_flip:.2f} | {ms:.1f} | {base_ms / ms:.2f}× | {computed} | {alive} | {life} |")
        lines.append("")
        restarted = [(label, stats["counters"]["cache_restarts"]) for label, stats, _ in rows
                     if "records_refreshed" in stats["counters"] and stats["counters"].get("cache_restarts", 0)]
        lines += ["Temporal caches restarted (the pose was not the predicted one): "
                  + (", ".join(f"{label} {n:.0f}×" for label, n in restarted) if restarted else "none") + ".", ""]
        # The thesis's Fig. 5.10 (accuracy over time) as numbers: FLIP of every fifth frame and the last.
        picks = sorted(set(range(0, args.frames, 5)) | {args.frames - 1})
        lines += [
            "FLIP against the reference frame by frame (the thesis's Fig. 5.10, accuracy over time):", "",
            "| variant | " + " | ".join(f"frame {k}" for k in picks) + " |",
            "|---|" + "---|" * len(picks),
        ]
        for label, _, seq in rows:
            flips = {f["index"]: f["flip"] for f in seq["frames"]}
            by_order = [f["flip"] for f in seq["frames"]]
            # Sequence indices are the frame numbers of the files; fall back on their order.
            values = [flips.get(k, by_order[k] if k < len(by_order) else float("nan")) for k in picks]
            lines.append(f"| {label} | " + " | ".join(f"{v:.4f}" for v in values) + " |")
        lines.append("")
    m.write_doc("measure-radiance-cache-temporal.py", args.doc, lines)


if __name__ == "__main__":
    main()
