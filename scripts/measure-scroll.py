#!/usr/bin/env python3
"""Prints docs/measurements/vxgi-scroll-lavapipe-64.md: VXGI's clipmap levels scrolled or rebuilt as they follow the camera.

    cargo build --release -p rtgi-cli && python3 scripts/measure-scroll.py            # about 8 min on lavapipe
    python3 scripts/measure-scroll.py --size 1920x1080 --timing frame --doc vxgi-scroll-gpu   # a GPU

Renders the first FRAMES frames (default 30, 1 s at 30 fps) of `atrium:animate=camera` with `vxgi` and three
clipmap levels of 128³, once with `scroll=true` (a level that moves keeps the voxels it still holds and
voxelises and lights only the slabs it enters) and once with `scroll=false` (it is voxelised and lit again),
for one and for two bounces. Reports the time per frame and per volume pass (means over the frames after the
first; a pass that runs only on some frames is averaged over the frames it ran in, its first run left out,
and its total over them is given too), the levels scrolled and rebuilt, and the frame-by-frame difference of the images between
the two (`rtgi compare`): with one bounce a scrolled level holds what a rebuilt one holds, bit for bit (the
unit test `a_scrolled_clipmap_equals_one_built_in_place`), so the images must be equal; with two, the second
bounce of the voxels a level keeps is the one gathered before it moved. Options: --size WxH, --frames N,
--resolution N, --timing passes|frame, --doc NAME, --allow-dirty.

--timing passes (the default) times by wall clock, every pass submitted alone and waited for (exact on
lavapipe, where a submission runs synchronously; before the profiler's `write_start`, lavapipe's timestamps
around "vxgi mips" also missed its work). --timing frame takes GPU timestamps in one submission per frame
(for GPUs, where a pass's submission and wait would dwarf it).
"""
import argparse
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-scroll.py"
OUT = m.scratch("scroll")
SCENE = "atrium:animate=camera"
VOLUME_PASSES = ["vxgi scroll", "vxgi voxelization", "vxgi injection", "vxgi mips", "vxgi bounce",
                 "vxgi bounce mips"]


def main():
    args = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args.add_argument("--size", default="64x64")
    args.add_argument("--frames", type=int, default=30)
    args.add_argument("--resolution", type=int, default=128)
    args.add_argument("--timing", choices=["passes", "frame"], default="passes")
    args.add_argument("--doc", default="vxgi-scroll-lavapipe-64")
    args.add_argument("--allow-dirty", action="store_true")
    args = args.parse_args()
    if args.frames < 2:
        sys.exit("--frames: at least 2 (the first frame builds every level)")
    m.refuse_dirty_tree(args.allow_dirty, SCRIPT)
    rtgi = m.rtgi_binary()
    by_wall = args.timing == "passes"
    # Per pass and per frame: wall clock (passes) or GPU timestamps (frame).
    kind = "wall" if by_wall else "gpu"
    commit = m.describe()
    start_load = m.load_average()
    OUT.mkdir(parents=True, exist_ok=True)

    rows = []
    adapter = None
    for bounces in (1, 2):
        runs = {}
        for scroll in ("true", "false"):
            name = f"b{bounces}-{scroll}"
            m.log(SCRIPT, f"bounces {bounces}, scroll={scroll}")
            settings = {"clipmap_levels": 3, "resolution": args.resolution, "bounces": bounces, "scroll": scroll}
            runs[scroll] = m.render_sequence(rtgi, OUT, SCENE, name, "vxgi", settings, args.size, args.frames,
                                             extra=("--timing", args.timing))
            adapter = runs[scroll]["adapter"]
        diff = m.compare(rtgi, OUT / f"b{bounces}-true_%04d.exr", OUT / f"b{bounces}-false_%04d.exr")
        rows.append((bounces, runs, diff))
        for f in OUT.glob(f"b{bounces}-*.exr"):
            f.unlink()

    end_load = m.load_average()
    cpu = adapter.get("device_type") == "Cpu"
    width, height = args.size.split("x")
    lines = [
        f"# VXGI clipmap levels scrolled or rebuilt over atrium's camera flight, {width}×{height}", "",
        f"Printed by `{m.command_line(SCRIPT)}` at commit `{commit}` on {m.adapter_text(adapter)}"
        + (", 2 CPU cores" if cpu else "") + ". " + m.load_text(start_load, end_load), "",
        f"`rtgi render --scene {SCENE} --technique vxgi --set clipmap_levels=3 --set resolution={args.resolution} "
        f"--set bounces=B --set scroll=S --size {args.size} --frames {args.frames} --fps 30 --timing {args.timing}`: "
        f"the first {args.frames / 30:.1f} s of the flight. "
        + ("Times are wall clock, every pass submitted alone and waited for. " if by_wall else "Times are GPU timestamps, one submission per frame. ")
        + "ms per frame: mean over the frames after the first (the "
        "first builds every level). Per pass: the mean over the frames it ran in, its first run left out, and in "
        "brackets those frames and its total over them. Levels: the clipmap levels scrolled and rebuilt over "
        "the whole flight (the first frame builds all three). Image difference: `rtgi compare` of the "
        "scrolled sequence against the rebuilt one, mean over the frames.", "",
        "| bounces | scroll | ms / frame | " + " | ".join(VOLUME_PASSES)
        + " | levels scrolled / rebuilt | scratch MiB |",
        "|---|---|---:|" + "---:|" * len(VOLUME_PASSES) + "---|---:|",
    ]
    for bounces, runs, diff in rows:
        for scroll, stats in runs.items():
            passes = {p["name"]: p for p in stats["passes"]}
            cells = []
            for name in VOLUME_PASSES:
                t = (passes.get(name) or {}).get(kind) or {}
                if t.get("count"):
                    total = t["mean_ms"] * t["count"]
                    cells.append(f"{t['mean_ms']:.1f} ({t['count']}, {total:.0f})")
                else:
                    cells.append("–")
            c = stats["counters"]
            frame = stats[f"frame_{kind}"]["mean_ms"]
            lines.append(f"| {bounces} | {scroll} | {frame:.1f} | " + " | ".join(cells)
                         + f" | {c['vxgi_level_scrolls']:.0f} / {c['vxgi_level_rebuilds']:.0f} | "
                         f"{c['vxgi_scroll_scratch_bytes'] / 2**20:.1f} |")
    lines += ["", "| bounces | scrolled ÷ rebuilt, ms / frame | image difference: mean FLIP | mean relMSE |",
              "|---|---:|---:|---:|"]
    for bounces, runs, diff in rows:
        ratio = runs["true"][f"frame_{kind}"]["mean_ms"] / runs["false"][f"frame_{kind}"]["mean_ms"]
        lines.append(f"| {bounces} | {ratio:.2f}× | {diff['mean']['flip']:.5f} | {diff['mean']['rel_mse']:.2e} |")
    m.write_doc(SCRIPT, args.doc, lines)


if __name__ == "__main__":
    main()
