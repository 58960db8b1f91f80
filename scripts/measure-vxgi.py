#!/usr/bin/env python3
"""Prints docs/measurements/vxgi-lavapipe-256.md (issue 11) from a run of benches/vxgi.toml.

    cargo build --release -p rtgi-cli && python3 scripts/measure-vxgi.py         # about 30 min on lavapipe
    python3 scripts/measure-vxgi.py --size 1920x1080 --doc vxgi-gpu                # the suite at 1080p, a GPU

Runs `rtgi bench benches/vxgi.toml --out $SCRATCH --images` (default target/measure/vxgi), copies its
report to docs/measurements/NAME-bench/, and adds what the bench does not compute: the GI passes' time per
frame against rsm's gather and lpv's volumes, what a rebuild costs (voxelisation, injection, mips, the
second bounce: once while nothing moves, every frame with update=every-frame), the volumes' memory,
the light on two-rooms' dark floor (the leak), and voxelisation time against atrium's triangle count
(detail 1-5). Options: --suite FILE, --size WxH, --doc NAME (default vxgi-lavapipe-256), --allow-dirty.
Shared helpers: scripts/measure_common.py.
"""
import json
import math
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

OUT = m.scratch("vxgi")
DOC = m.ROOT / "docs/measurements"
def passes(cell):
    return {p["name"]: p["ms_per_frame"] for p in cell["passes"]}


def detail_section(rtgi):
    """Voxelisation time against triangle count: atrium at detail 1-5 (its tessellation; the same
    layout), voxelised and lit every frame at 128³, with the column rays alone and conservative. The
    column rays (one per voxel column along each axis through the BVH) do not depend on the triangles;
    their traversal grows with the BVH's depth. The conservative pass visits every triangle."""
    frames = 4
    lines = ["## Voxelisation against triangle count (atrium, detail 1-5)", "",
             f"`rtgi render --scene atrium:detail=D --technique vxgi --set update=every-frame --set "
             f"voxelization=V --size 64x64 --frames {frames}`: GPU time per frame (mean over the frames "
             "after the first) of the voxelisation (3 × 128² rays through the BVH; conservative: then the "
             "claims of every triangle and a resolve per claimed brick of 4³ voxels) and, for scale, of the injection (a direct-light "
             "estimate per occupied voxel).", "",
             "| detail | triangles | BVH build ms (CPU) | columns: voxelization ms | conservative: "
             "voxelization ms | conservative − columns, ns per triangle | injection ms (conservative) |",
             "|---|---|---|---|---|---|---|"]
    for detail in range(1, 6):
        stats = {}
        for voxelization in ("columns", "conservative"):
            stats_file = OUT / f"detail-{detail}-{voxelization}.json"
            m.run([rtgi, "render", "--scene", f"atrium:detail={detail}", "--technique", "vxgi", "--set",
                   "update=every-frame", "--set", f"voxelization={voxelization}", "--size", "64x64",
                   "--frames", frames, "--out", OUT / "detail.exr", "--stats", stats_file])
            stats[voxelization] = json.loads(stats_file.read_text())
        gpu = {v: {p["name"]: (p.get("gpu") or {}).get("mean_ms") for p in s["passes"]} for v, s in stats.items()}
        columns, conservative = (gpu[v].get("vxgi voxelization") for v in ("columns", "conservative"))
        tris = stats["conservative"]["triangles"]
        fmt = lambda v: f"{v:.2f}" if v is not None else "–"  # noqa: E731
        per_triangle = f"{(conservative - columns) * 1e6 / tris:.0f}" if columns and conservative else "–"
        lines.append(f"| {detail} | {tris} | {stats['conservative']['bvh_build_ms']:.0f} | {fmt(columns)} | "
                     f"{fmt(conservative)} | {per_triangle} | {fmt(gpu['conservative'].get('vxgi injection'))} |")
    return lines + [""]


def main():
    args, rtgi = m.suite_arguments("measure-vxgi.py", "benches/vxgi.toml", "vxgi-lavapipe-256",
                                   __doc__.splitlines()[0])
    suite, size, results, cells, adapter, cpu, spp = m.run_suite_into_doc(
        rtgi, OUT, DOC, args.suite, args.size, args.doc)
    width, height = (int(v) for v in size.split("x"))
    ref_spp = "; ".join(f"{k} {v}" for k, v in spp.items())
    lines = [
        f"# VXGI (issue 11): measurements at {width}×{height}", "",
        m.printed_by("measure-vxgi.py", args, size, results, adapter, cpu), "",
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
    lines += m.gi_tables(cells, width, height, ("vxgi", "lpv"),
                         lambda c: c["series"] == "vxgi" and c["sweep"].get("resolution") == "128")

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
