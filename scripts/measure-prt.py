#!/usr/bin/env python3
"""Prints docs/measurements/prt-lavapipe.md: precomputed radiance transfer (diffuse and glossy, per vertex) on
spheres-env and pillars against the path tracer at equal time (issue 14).

    cargo build --release -p rtgi-cli && python3 scripts/measure-prt.py   # about 10 min on lavapipe
    python3 scripts/measure-prt.py --size 1920x1080 --doc prt-gpu            # a GPU

Runs `rtgi bench benches/prt.toml --images` and prints each cell's time per frame (and its `prt shading`
pass), the precomputation's time (in the warm-up frame), FLIP and relMSE against the full-GI
path-traced reference and the path tracer's FLIP at the same time. Options: --suite FILE, --size WxH,
--doc NAME, --allow-dirty.
"""
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-prt.py"
SHADING = "prt shading"
PRECOMPUTE = "transfer precomputation"


def warmup_ms(cell, name):
    """A pass's time in the cell's warm-up frame (None when it had no such pass)."""
    for p in cell.get("warmup_passes", []):
        if p["name"] == name:
            return p["ms_per_frame"]
    return None


def cheaper_text(cells):
    """How many prt cells cost less per frame than the path tracer's cheapest cell (they have no path
    FLIP at their time)."""
    path = [c["frame_ms"] for c in cells if c["technique"] == "path"]
    prt = [c for c in cells if c["technique"] == "prt"]
    if not path or not prt:
        return ""
    cheaper = sum(c["frame_ms"] < min(path) for c in prt)
    return (f"{cheaper} of the {len(prt)} prt cells cost less per frame than the path tracer's cheapest "
            f"({min(path):.0f} ms), so they have no path FLIP at their time. ")


def main():
    run = m.run_documented_suite(SCRIPT, "prt", "benches/prt.toml", "prt-lavapipe", __doc__.splitlines()[0])
    suite, cells, cpu, ref_spp = run.suite, run.cells, run.cpu, run.ref_spp
    lines = [
        f"# Precomputed radiance transfer ({run.width}×{run.height})", "",
        run.header,
        "",
        f"Each cell: a fresh renderer, one warm-up frame (prt precomputes its transfer and projects "
        f"the environment there; the precomputation column is that pass's time), then "
        f"{suite.get('frames', 3)} timed frames, {suite.get('error_frames', 2)} of them compared with the "
        f"path-traced full-GI reference (spp: {ref_spp}). Each scene is lit by its sky alone. prt's "
        "transfer is per vertex; unless glossy it is diffuse: spheres-env's glossy and metal spheres get no "
        "environment light (the reference's reflections) from the diffuse cells, while `prt glossy` "
        "carries the shadowed sky to every lobe through its transfer matrices (blurred to the order's "
        "bands: the chart's mirrors stay blurred). spheres-env's ground has 1 m cells, too coarse for the "
        "spheres' contact shadows; pillars is all Lambertian on a ground of 9 cm cells. Unless "
        "interreflected the sky reaches each surface once; env-harmonics shades every lobe but without "
        "visibility. The transferred-radiance pass of glossy transfer runs in the warm-up frame (the sky "
        "is still), so the timed frames shade only. `prt glossy interreflected` adds to the glossy "
        "matrices a second, RGB matrix carrying the light of 2 bounces off the other surfaces (which "
        "reflect it diffusely). `prt wavelet` is shadowed diffuse transfer in Haar "
        "wavelets over a cube map of 6 × R² texels (one visibility ray per texel and vertex, the vertex's "
        "largest wavelet_transfer_terms kept), lit by the sky resampled onto the cube with its wavelet_terms "
        "largest terms kept (6, 18 and 61 are 0.1, 0.3 and 1 % of 6 × 32²); its lighting passes too run in "
        "the warm-up frame. "
        "ms/frame: the whole frame's GPU time; shading: the `prt shading` pass"
        + (". On lavapipe: compare cells with each other, not with GPU figures." if cpu else "."), "",
    ]
    scenes = list(dict.fromkeys(c["scene"] for c in cells))
    for scene in scenes:
        own = [c for c in cells if c["scene"] == scene]
        lines += [f"## {scene}", ""]
        settings = m.scene_reference_settings(suite, scene)
        if settings:
            lines += [f"This scene's reference is the path tracer with {settings} (not full GI).", ""]
        lines += [
            cheaper_text(own), "",
            "| cell | ms/frame | shading ms | precomputation ms | FLIP | relMSE | path's FLIP at this time "
            "| FLIP / path's |",
            "|---|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for c in own:
            p = m.path_flip_at(own, c["frame_ms"]) if c["technique"] != "path" else None
            ratio = c["error"]["flip"] / p if p else None
            shading = m.pass_ms(c, SHADING)
            pre = warmup_ms(c, PRECOMPUTE)
            lines.append(f"| {m.label(c)} | {c['frame_ms']:.2f} | "
                         f"{f'{shading:.2f}' if shading is not None else '–'} | "
                         f"{f'{pre:.0f}' if pre is not None else '–'} | {c['error']['flip']:.4f} | "
                         f"{c['error']['rel_mse']:.5f} | {m.path_flip_text(own, c)} | "
                         f"{f'{ratio:.2f}' if ratio is not None else '–'} |")
        lines.append("")
    m.write_doc(SCRIPT, run.args.doc, lines)


if __name__ == "__main__":
    main()
