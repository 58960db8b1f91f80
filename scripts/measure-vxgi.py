#!/usr/bin/env python3
"""Prints docs/measurements/vxgi-lavapipe-256.md (issue 11) from a run of benches/vxgi.toml.

    cargo build --release -p rtgi-cli && python3 scripts/measure-vxgi.py         # about 30 min on lavapipe
    python3 scripts/measure-vxgi.py --size 1920x1080 --doc vxgi-gpu                # the suite at 1080p, a GPU

Runs `rtgi bench benches/vxgi.toml --out $SCRATCH --images` (default target/measure/vxgi), copies its
report to docs/measurements/NAME-bench/, and adds what the bench does not compute: the GI passes' time per
frame against rsm's gather and lpv's volumes, what a rebuild costs (voxelisation, injection, mips, the
second bounce: once while nothing moves, every frame with update=every-frame), the volumes' memory,
the light on two-rooms' dark floor (the leak), and voxelisation time against atrium's triangle count
(detail 1-5). Options: --suite FILE, --size WxH, --doc NAME (default vxgi-lavapipe-256), --allow-dirty. Shared helpers: scripts/measure_common.py.
"""
import argparse
import json
import math
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

OUT = m.scratch("vxgi")
DOC = m.ROOT / "docs/measurements"
REBUILD = ("vxgi voxelization", "vxgi injection", "vxgi mips", "vxgi bounce", "vxgi bounce mips")
GI_PASSES = {
    "vxgi": REBUILD + ("vxgi cone tracing",),
    "lpv": ("lpv flux scale", "lpv injection", "lpv geometry injection", "lpv resolve", "lpv propagation",
            "lpv lookup"),
    "rsm": ("rsm gather", "upsample", "full-resolution fixup", "composite"),
}


def gi_ms(cell):
    names = GI_PASSES.get(cell["technique"], ())
    return sum(p["ms_per_frame"] for p in cell["passes"] if p["name"] in names)


def passes(cell):
    return {p["name"]: p["ms_per_frame"] for p in cell["passes"]}


def detail_section(rtgi):
    """Voxelisation time against triangle count: atrium at detail 1-5 (its tessellation; the same
    layout), voxelised and lit every frame at 128³. Voxelisation casts one ray per voxel column along
    each axis through the BVH, so its rays do not depend on the triangles; their traversal grows with
    the BVH's depth."""
    frames = 4
    lines = ["## Voxelisation against triangle count (atrium, detail 1-5)", "",
             f"`rtgi render --scene atrium:detail=D --technique vxgi --set update=every-frame --size 64x64 "
             f"--frames {frames}`: GPU time per frame (mean over the frames after the first) of the "
             "voxelisation (3 × 128² rays through the BVH) and, for scale, of the injection (a direct-light "
             "estimate per occupied voxel).", "",
             "| detail | triangles | BVH build ms (CPU) | voxelization ms | injection ms | voxelization ms per "
             "log2(triangles) |", "|---|---|---|---|---|---|"]
    for detail in range(1, 6):
        stats_file = OUT / f"detail-{detail}.json"
        m.run([rtgi, "render", "--scene", f"atrium:detail={detail}", "--technique", "vxgi", "--set",
               "update=every-frame", "--size", "64x64", "--frames", frames, "--out", OUT / "detail.exr",
               "--stats", stats_file])
        stats = json.loads(stats_file.read_text())
        gpu = {p["name"]: (p.get("gpu") or {}).get("mean_ms") for p in stats["passes"]}
        vox, inj = gpu.get("vxgi voxelization"), gpu.get("vxgi injection")
        tris = stats["triangles"]
        per_log = f"{vox / math.log2(tris):.3f}" if vox else "–"
        fmt = lambda v: f"{v:.2f}" if v is not None else "–"  # noqa: E731
        lines.append(f"| {detail} | {tris} | {stats['bvh_build_ms']:.0f} | {fmt(vox)} | {fmt(inj)} | {per_log} |")
    return lines + [""]


def main():
    args = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args.add_argument("--suite", default="benches/vxgi.toml")
    args.add_argument("--size", help="WxH: run the suite at this size instead of its own")
    args.add_argument("--doc", default="vxgi-lavapipe-256")
    args.add_argument("--allow-dirty", action="store_true")
    args = args.parse_args()
    m.refuse_dirty_tree(args.allow_dirty, "measure-vxgi.py")
    rtgi = m.rtgi_binary()
    suite, size, results, cells, adapter, cpu, spp = m.run_suite_into_doc(
        rtgi, OUT, DOC, args.suite, args.size, args.doc)
    width, height = (int(v) for v in size.split("x"))
    ref_spp = "; ".join(f"{k} {v}" for k, v in spp.items())
    command = "python3 scripts/measure-vxgi.py" + "".join(f" {a}" for a in sys.argv[1:] if a != "--allow-dirty")
    lines = [
        f"# VXGI (issue 11): measurements at {width}×{height}", "",
        f"Printed by `{command}` from `rtgi bench {args.suite}`" + (f" at {size}" if args.size else "")
        + f" at commit `{results['rtgi']['commit']}` on {m.adapter_text(adapter)}"
        + (", 2 CPU cores" if cpu else "") + f". The bench's own report (Pareto plots, every cell with "
        f"thumbnails and error maps) is in [`{args.doc}-bench/`]({args.doc}-bench/report.md).", "",
        f"Each cell: a fresh renderer, warmed up, {suite.get('frames', 8)} timed frames back to back, then "
        f"{suite.get('error_frames', 4)} compared with the path-traced full-GI reference (spp: {ref_spp}), "
        "each after a camera cut (docs/bench.md). ms/frame: the whole frame's GPU time (G-buffer "
        "included). GI ms: the technique's own passes without the G-buffer, the shadow maps, the RSM "
        "(rendered only when lights or geometry move) and the direct light: vxgi's cone tracing, plus "
        "its voxelisation, injection and mips in the 'every frame' cells (a static scene's volumes are "
        "built once, in the warm-up: see 'Rebuild' below); lpv's volumes and lookup; rsm's gather, "
        "upsampling and composite. rsm and lpv are one bounce of the analytic lights; vxgi's voxels take "
        "the analytic lights, emissive triangles and the environment, one bounce or two; the reference "
        "has every bounce" + (". On lavapipe: compare techniques with each other, not with GPU figures."
                              if cpu else "."), "",
    ]
    for scene in dict.fromkeys(c["scene"] for c in cells):
        sc = [c for c in cells if c["scene"] == scene]
        rsm = next((c for c in sc if c["technique"] == "rsm"), None)
        lines += [f"## {scene} ({width}×{height})", "",
                  "| cell | ms/frame | GI ms | GI ms / rsm's | FLIP | relMSE | path's FLIP at this time | on the "
                  "front |", "|---|---|---|---|---|---|---|---|"]
        for c in sc:
            at = m.path_flip_text(sc, c)
            gi = f"{gi_ms(c):.2f}" if c["technique"] in GI_PASSES else "–"
            ratio = (f"{gi_ms(c) / gi_ms(rsm):.2f}" if rsm and c["technique"] in ("vxgi", "lpv")
                     and gi_ms(rsm) > 0 else "–")
            lines.append(f"| {m.label(c)} | {c['frame_ms']:.1f} | {gi} | {ratio} | {c['error']['flip']:.4f} | "
                         f"{c['error']['rel_mse']:.5f} | {at} | {'yes' if m.on_front(sc, c) else 'no'} |")
        lines.append("")
        default = next((c for c in sc if c["series"] == "vxgi" and c["sweep"].get("resolution") == "128"), None)
        if default:
            split = ", ".join(f"{p['name']} {p['ms_per_frame']:.2f}" for p in default["passes"])
            lines += [f"{m.label(default)} per pass, ms/frame: {split}.", ""]

    dynamic = [c for c in cells if c["technique"] == "vxgi" and c["settings"].get("update") == "every-frame"]
    vx = [c for c in cells if c["technique"] == "vxgi"]
    if vx:
        lines += ["## Rebuild and memory", "",
                  "What a rebuild costs, from the cells that voxelise and light every frame (update=every-frame), "
                  "and the volumes' memory of every vxgi cell: voxels (albedo and normal words), radiance "
                  "(level 0 of each bounce, with the isotropic mips where those are used) and the six "
                  "directional volumes of levels 1 and up.", "",
                  "| cell | voxelization ms | injection ms | mips ms | cone tracing ms |",
                  "|---|---|---|---|---|"]
        for c in dynamic:
            p = passes(c)
            lines.append(f"| {c['scene']}: {m.label(c)} | {p.get('vxgi voxelization', 0):.2f} | "
                         f"{p.get('vxgi injection', 0):.2f} | {p.get('vxgi mips', 0):.2f} | "
                         f"{p.get('vxgi cone tracing', 0):.2f} |")
        # Memory does not depend on the scene: one row per setting, from the first scene that has it (the
        # clipmap cells run on atrium only). Voxel edge: the finest level's.
        lines += ["", "| cell | voxel edge | voxels MiB | radiance MiB | directional MiB |", "|---|---|---|---|---|"]
        seen = set()
        for c in vx:
            if m.label(c) in seen:
                continue
            seen.add(m.label(c))
            k = c["counters"]
            lines.append(f"| {m.label(c)} ({c['scene']}) | {k['vxgi_voxel_size']:.4f} | "
                         f"{k['vxgi_voxel_bytes'] / 2**20:.1f} | {k['vxgi_radiance_bytes'] / 2**20:.1f} | "
                         f"{k['vxgi_directional_bytes'] / 2**20:.1f} |")
        lines.append("")

    lines += m.leak_table(rtgi, OUT, cells, size, spp)
    lines += detail_section(rtgi)
    (DOC / f"{args.doc}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    sys.exit(main())
