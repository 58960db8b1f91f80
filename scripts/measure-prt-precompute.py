#!/usr/bin/env python3
"""Prints docs/measurements/prt-precompute-lavapipe.md: how prt's transfer precomputation scales with the
vertex count (issue 14): time, memory and ray throughput.

    cargo build --release -p rtgi-cli && python3 scripts/measure-prt-precompute.py   # about 4 min on lavapipe
    python3 scripts/measure-prt-precompute.py --doc prt-precompute-gpu                 # a GPU

Renders one 32×32 frame of `prt` (order 4, 256 directions per vertex, transfer_cache=off so every run
precomputes) on spheres-env with 2 to 10 spheres per row (`count`; 64×32 segments per sphere) for each
transfer kind (wavelet transfer at 6 × 16² texels, 512 terms per vertex), and reads from the stats the `transfer precomputation` pass's GPU time, the transfer's
bytes, vertices and rays. Rays/s = rays / precomputation time. A least-squares line time = a + b·vertices
shows whether the cost is linear in the vertex count. Options: --counts N,N,..., --doc NAME, --allow-dirty.
"""
import argparse
import json
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-prt-precompute.py"
PASS = "transfer precomputation"
KINDS = [("unshadowed", {}), ("shadowed", {}), ("interreflected", {"bounces": 1}),
         ("wavelet", {"wavelet_resolution": 16, "wavelet_transfer_terms": 512})]


def precompute(rtgi, out, count, transfer, extra):
    stats = out / f"{transfer}-{count}.json"
    settings = {"transfer": transfer, "order": 4, "transfer_samples": 256, "transfer_cache": "off", **extra}
    sets = [x for k, v in settings.items() for x in ("--set", f"{k}={v}")]
    m.run([rtgi, "render", "--scene", f"spheres-env:count={count}", "--technique", "prt", "--size", "32x32",
           *sets, "--out", out / f"{transfer}-{count}.exr", "--stats", stats])
    s = json.loads(stats.read_text())
    ms = next(p["gpu_ms"] if p["gpu_ms"] is not None else p["wall_ms"] for p in s["passes"] if p["name"] == PASS)
    c = s["counters"]
    return {"vertices": int(c["transfer_vertices"]), "bytes": c["transfer_bytes"], "rays": c["transfer_rays"],
            "ms": ms, "adapter": s["adapter"]}


def line_fit(xs, ys):
    """Least squares y = a + b x; returns a, b and the largest |residual| / y."""
    n = len(xs)
    mx, my = sum(xs) / n, sum(ys) / n
    b = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
    a = my - b * mx
    return a, b, max(abs(y - (a + b * x)) / y for x, y in zip(xs, ys))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--counts", default="2,4,6,8,10")
    parser.add_argument("--doc", default="prt-precompute-lavapipe")
    parser.add_argument("--allow-dirty", action="store_true")
    args = parser.parse_args()
    m.refuse_dirty_tree(args.allow_dirty, SCRIPT)
    # The commit the binary is built from, named before the runs (the tree may change while they run).
    commit = m.describe()
    rtgi = m.rtgi_binary()
    out = m.scratch("prt-precompute")
    counts = [int(c) for c in args.counts.split(",")]
    start = m.load_average()
    rows = {}
    for transfer, extra in KINDS:
        for count in counts:
            m.log(SCRIPT, f"{transfer}, count={count} ...")
            rows[(transfer, count)] = precompute(rtgi, out, count, transfer, extra)
    adapter = next(iter(rows.values()))["adapter"]
    cpu = adapter.get("device_type") == "Cpu"
    lines = [
        "# prt: transfer precomputation against vertex count", "",
        f"Printed by `{m.command_line(SCRIPT)}` at commit `{commit}` on {m.adapter_text(adapter)}"
        + (", 2 CPU cores" if cpu else "") + ". " + m.load_text(start, m.load_average()), "",
        "One 32×32 frame of `prt` per row (order 4: 16 coefficients per vertex and channel; 256 cosine-"
        "distributed directions per vertex and bounce; `transfer_cache=off`) on `spheres-env:count=N` (2N "
        "spheres of 64×32 segments on a ground). ms: the `transfer precomputation` pass's GPU time; bytes: "
        "the transfer buffer; rays: vertices × directions × (1 + bounces) (unshadowed transfer traces none: "
        "its directions are only projected); interreflected: 1 bounce; wavelet: a 6 × 16² cube map, one ray "
        "per texel facing the vertex (768), then the Haar transform and the selection of 512 terms per "
        "vertex (4 bytes each), all in the pass.", "",
        "| transfer | spheres | vertices | bytes | ms | µs per vertex | rays/s |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for transfer, extra in KINDS:
        for count in counts:
            r = rows[(transfer, count)]
            rays = "–" if transfer == "unshadowed" else f"{r['rays'] / (r['ms'] / 1e3) / 1e6:.2f} M"
            lines.append(f"| {transfer} | {2 * count} | {r['vertices']} | {r['bytes'] / 1e6:.2f} MB | "
                         f"{r['ms']:.0f} | {r['ms'] * 1e3 / r['vertices']:.1f} | {rays} |")
    lines += ["", "Linear fit of the time against the vertex count (ms = a + b·vertices):", ""]
    for transfer, _ in KINDS:
        xs = [rows[(transfer, c)]["vertices"] for c in counts]
        ys = [rows[(transfer, c)]["ms"] for c in counts]
        a, b, worst = line_fit(xs, ys)
        per = [y / x for x, y in zip(xs, ys)]
        lines.append(f"- {transfer}: a = {a:.0f} ms, b = {b * 1e3:.1f} µs per vertex; the largest "
                     f"departure from the line is {100 * worst:.1f} % of a row's time; time per vertex "
                     f"{min(per) * 1e3:.1f}–{max(per) * 1e3:.1f} µs. Bytes are exactly linear: "
                     f"{rows[(transfer, counts[0])]['bytes'] / xs[0]:.0f} per vertex.")
    m.write_doc(SCRIPT, args.doc, lines)


if __name__ == "__main__":
    main()
