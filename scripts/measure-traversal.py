#!/usr/bin/env python3
"""Prints docs/measurements/traversal-lavapipe.md: the path tracer's ray throughput with this commit's BVH
against a build of an earlier commit, in one run (issue 15, item 1).

    python3 scripts/measure-traversal.py                  # about 20 min on lavapipe (2 cores)
    python3 scripts/measure-traversal.py --size 1920x1080 --doc traversal-gpu   # a GPU; RTGI_BASE=binary
                                                          # gives the earlier build where cargo is absent

Builds the commit given by --base (default 2ffd778, the last with the binary BVH) in a worktree under
target/traversal-base/, then runs `rtgi bench benches/traversal.toml` (path, 1 spp per frame, on cornell,
atrium and atrium:detail=5) with that binary and with this commit's, the latter twice, with the BVH's
tables in textures and in storage buffers (`--bvh-tables`), alternating, --rounds times (default 2), and
keeps each cell's best. Rays/s = rays per sample (the path tracer's own counters, every frame) ×
samples per frame / GPU time per steady frame; computed here the same way for both binaries (the earlier
build's `rays_per_second` counter also divided by its first frame, which includes pipeline compilation on
lavapipe). Options: --base REV, --suite FILE, --size WxH, --rounds N, --doc NAME, --allow-dirty.
"""
import os
import subprocess
import sys
from pathlib import Path

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-traversal.py"
DEFAULT_BASE = "2ffd778"


def base_binary(rev):
    """$RTGI_BASE, else a release build of `rev` in a worktree (reused when it is already at `rev`)."""
    if os.environ.get("RTGI_BASE"):
        return Path(os.environ["RTGI_BASE"]), os.environ.get("RTGI_BASE_COMMIT", rev)
    full = m.run(["git", "rev-parse", "--verify", f"{rev}^{{commit}}"]).strip()
    root = m.ROOT / "target" / "traversal-base"
    tree = root / "src"
    if tree.exists() and m.run(["git", "-C", tree, "rev-parse", "HEAD"]).strip() != full:
        m.run(["git", "worktree", "remove", "--force", tree])
    if not tree.exists():
        root.mkdir(parents=True, exist_ok=True)
        m.run(["git", "worktree", "add", "--detach", tree, full])
    m.log(SCRIPT, f"building {rev} in {tree} ...")
    env = dict(os.environ, CARGO_TARGET_DIR=str(root / "target"))
    r = subprocess.run(["cargo", "build", "--release", "-p", "rtgi-cli"], cwd=tree, env=env,
                       capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{SCRIPT}: building {rev} failed:\n{r.stderr}")
    return root / "target" / "release" / "rtgi", full[:12]


def rays_per_second(cell):
    """Rays per sample (all frames) × samples per frame / steady GPU seconds per frame."""
    k = cell["counters"]
    spp = float(cell["settings"]["spp"])
    samples_per_frame = cell["width"] * cell["height"] * spp
    return k["rays"] / k["samples"] * samples_per_frame / (cell["frame_ms"] / 1e3), k["rays"] / k["samples"]


def main():
    def extra(parser):
        parser.add_argument("--base", default=DEFAULT_BASE)
        parser.add_argument("--rounds", type=int, default=2)

    args, rtgi = m.suite_arguments(SCRIPT, "benches/traversal.toml", "traversal-lavapipe",
                                   __doc__.splitlines()[0], extra)
    base, base_commit = base_binary(args.base)
    out = m.scratch("traversal")
    suite = m.suite_at_size(args.suite, args.size, out)
    start = m.load_average()
    best = {}
    runs = {}
    for round_ in range(args.rounds):
        for label, binary, options in (("before", base, []),
                                       ("textures", rtgi, ["--bvh-tables", "textures"]),
                                       ("buffers", rtgi, ["--bvh-tables", "buffers"])):
            m.log(SCRIPT, f"round {round_ + 1}/{args.rounds}: {label} ({binary})")
            bench = m.Bench(binary, suite, out / f"{label}-{round_}", images=False, options=options)
            runs[label] = bench
            for cell in bench.results["cells"]:
                rate, per_sample = rays_per_second(cell)
                key = (cell["scene"], label)
                if key not in best or rate > best[key][0]:
                    best[key] = (rate, per_sample, cell["frame_ms"], cell["gpu_scene_bytes"])
    after = runs["textures"]
    adapter = after.adapter
    cpu = adapter.get("device_type") == "Cpu"
    first = after.results["cells"][0]
    size = args.size or f"{first['width']}x{first['height']}"
    command = m.command_line(SCRIPT)
    lines = [
        f"# Ray traversal: path tracer throughput before and after ({size})",
        "",
        f"Printed by `{command}` from `rtgi bench {args.suite}`: commit `{after.commit}` against a build of "
        f"`{base_commit}`, both on {m.adapter_text(adapter)}" + (", 2 CPU cores" if cpu else "")
        + f", {args.rounds} alternating rounds, each cell's best. " + m.load_text(start, m.load_average()),
        "",
        "Rays/s = rays per sample (the path tracer's counters over every frame) × samples per frame / GPU "
        "time per steady frame (timestamps, the first frame left out). Every ray goes through the shared "
        "BVH (`common/bvh.wgsl`): bounce rays to the closest hit, shadow rays to any hit; shading is "
        "included, so the ratio understates the traversal's own gain. Before: binary SAH tree, 32-byte "
        "nodes, two boxes per visit, nodes and triangles in storage buffers. After: the same SAH tree "
        "collapsed into 4-wide nodes with byte-quantised child boxes (64 bytes, four boxes per visit, "
        "children visited nearest first), nodes and triangles in read-only storage textures or storage "
        "buffers (`--bvh-tables`, both columns; `auto` picks textures on CPU adapters, buffers on GPUs: "
        "gpu/bvh/mod.rs `BvhTables`), the environment's sampling table in a texture (lavapipe loads "
        "storage buffers inside loops lane by lane, and calls a generic texel-fetch function for a sampled "
        "texture: gpu/linear_texture.rs), and the alpha test compiled out for scenes without alpha-tested "
        "triangles (`BVH_ALPHA_TESTS`: lavapipe runs a branch's body with every lane masked off rather "
        "than skip it, so every triangle test paid for it); the rest of the shading is unchanged.",
        "",
        "| scene | rays / sample | before M rays/s | after, textures | after, buffers | textures / before "
        "| buffers / before | buffers / textures | ms / frame before | textures | buffers "
        "| GPU scene MiB before | after |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    scenes = list(dict.fromkeys(c["scene"] for c in after.results["cells"]))
    for scene in scenes:
        b, t, u = best[(scene, "before")], best[(scene, "textures")], best[(scene, "buffers")]
        lines.append(
            f"| {scene} | {t[1]:.2f} | {b[0] / 1e6:.3f} | {t[0] / 1e6:.3f} | {u[0] / 1e6:.3f} "
            f"| {t[0] / b[0]:.2f}× | {u[0] / b[0]:.2f}× | {u[0] / t[0]:.2f}× | {b[2]:.1f} | {t[2]:.1f} "
            f"| {u[2]:.1f} | {b[3] / 2**20:.1f} | {t[3] / 2**20:.1f} |")
    m.write_doc(SCRIPT, args.doc, lines)


if __name__ == "__main__":
    main()
