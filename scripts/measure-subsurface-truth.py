#!/usr/bin/env python3
"""Prints docs/measurements/subsurface-truth-lavapipe.md: the dipole (`subsurface`) and the Lambertian stand-in against the path tracer's random walk.

    cargo build --release -p rtgi-cli && python3 scripts/measure-subsurface-truth.py      # about 12 min on lavapipe
    python3 scripts/measure-subsurface-truth.py --size 512x512 --spp 65536 --doc subsurface-truth-gpu   # a GPU

On `translucent` (a skin sphere and a marble slab, lit from the front by a point light and from behind by a
spot light), the ground truth is `path` with `subsurface=walk max_bounces=0`: direct light with subsurface
transport simulated (a random walk through each medium under its rough dielectric boundary), which is what
`subsurface` approximates with the dipole. Against it: `subsurface` at its defaults and with the exact sum of
its samples (ε = 0, ρ = 0: the dipole alone, without the hierarchy's error), the same with d'Eon's better dipole
(`dipole=better`), with the entry Fresnel term (`entry_fresnel=true`) and with Frisvad et al.'s directional dipole (`dipole=directional`, also at the default ε and ρ), the classical and the
better dipole with Jensen et al.'s single-scattering term (`single_scattering=4`, 16 frames), and `path` with
`subsurface=lambertian max_bounces=0` (what every technique without subsurface transport shows: the Lambertian
of the medium's total diffuse reflectance). Then one bounce of indirect light: `subsurface indirect_samples=4`
against the walk with `max_bounces=1`, on the translucent patches. Last, equal time: the walk at the samples
per pixel one frame of `subsurface` costs, and at 4, 16 and 64 times that. The reference's own noise is measured from two independent renders
of a quarter of its samples. Reports FLIP and relative MSE over the image, and the mean radiance of a patch of
the slab's unlit front (light shining through 12 cm of marble) and of the sphere.
Options: --size WxH, --spp N (the reference's samples per pixel), --doc NAME, --allow-dirty.
"""
import json
import sys

sys.dont_write_bytecode = True
import measure_common as m  # noqa: E402

SCRIPT = "measure-subsurface-truth.py"
OUT = m.scratch("subsurface-truth")
# Patches as fractions (x, y, w, h) of the image: inside the slab's front face and inside the sphere.
PATCHES = {"slab front": (0.69, 0.31, 0.19, 0.31), "sphere": (0.08, 0.34, 0.23, 0.27)}
SPP_PER_FRAME = 64
# Frames over which the single-scattering term's Monte Carlo estimate converges.
SINGLE_FRAMES = 16


def main():
    def options(parser):
        parser.add_argument("--size", default="64x64")
        parser.add_argument("--spp", type=int, default=4096)

    args, rtgi, commit, start_load = m.script_arguments(
        SCRIPT, __doc__.splitlines()[0], "subsurface-truth-lavapipe", options)
    width, height = (int(v) for v in args.size.split("x"))

    def render(name, technique, settings, frames=1):
        out = OUT / f"{args.size}-{name}.exr"
        stats_path = OUT / f"{args.size}-{name}.json"
        m.log(SCRIPT, f"{args.size}: {name}")
        sets = [x for k, v in settings.items() for x in ("--set", f"{k}={v}")]
        m.run([rtgi, "render", "--scene", "translucent", "--technique", technique, "--size", args.size,
               "--frames", frames, *sets, "--out", out, "--stats", stats_path])
        return out, json.loads(stats_path.read_text())

    def walk(name, spp, seed, subsurface="walk", bounces=0):
        per_frame = min(spp, SPP_PER_FRAME)
        return render(name, "path", {"subsurface": subsurface, "max_bounces": bounces, "spp": per_frame,
                                     "seed": seed}, frames=-(-spp // per_frame))

    reference, ref_stats = walk("reference", args.spp, 0)
    quarter = max(args.spp // 4, 1)
    half_a, _ = walk("quarter-a", quarter, 1)
    half_b, _ = walk("quarter-b", quarter, 2)
    noise = m.compare(rtgi, half_a, half_b)
    candidates = [
        ("`subsurface` (defaults)", *render("dipole", "subsurface", {})),
        ("`subsurface` ε 0, ρ 0 (the dipole's exact sum)", *render("dipole-exact", "subsurface",
                                                                   {"epsilon": 0, "rho": 0})),
        ("`path subsurface=lambertian` (the stand-in)", *walk("lambertian", min(args.spp, 1024), 3, "lambertian")),
        ("`subsurface dipole=better` ε 0, ρ 0 (d'Eon's better dipole, exact sum)",
         *render("better-exact", "subsurface", {"dipole": "better", "epsilon": 0, "rho": 0})),
        ("`subsurface entry_fresnel=true` ε 0, ρ 0 (the dipole with the entry Fresnel term, exact sum)",
         *render("entry-fresnel-exact", "subsurface", {"entry_fresnel": "true", "epsilon": 0, "rho": 0})),
        ("`subsurface dipole=directional` ε 0, ρ 0 (Frisvad et al.'s directional dipole, exact sum)",
         *render("directional-exact", "subsurface", {"dipole": "directional", "epsilon": 0, "rho": 0})),
        ("`subsurface dipole=directional` (defaults otherwise)", *render("directional", "subsurface",
                                                                       {"dipole": "directional"})),
        (f"`subsurface single_scattering=4` ε 0, ρ 0, {SINGLE_FRAMES} frames (the classical dipole + single "
         "scattering)", *render("single-exact", "subsurface", {"single_scattering": 4, "epsilon": 0, "rho": 0},
                                frames=SINGLE_FRAMES)),
        (f"`subsurface dipole=better single_scattering=4` ε 0, ρ 0, {SINGLE_FRAMES} frames (the better dipole + "
         "single scattering)", *render("better-single-exact", "subsurface",
                                       {"dipole": "better", "single_scattering": 4, "epsilon": 0, "rho": 0},
                                       frames=SINGLE_FRAMES)),
        (f"`subsurface dipole=better single_scattering=4`, {SINGLE_FRAMES} frames (defaults otherwise)",
         *render("better-single", "subsurface", {"dipole": "better", "single_scattering": 4},
                 frames=SINGLE_FRAMES)),
    ]

    def region(name):
        x, y, w, h = PATCHES[name]
        return f"{round(x * width)},{round(y * height)},{round(w * width)},{round(h * height)}"

    rows = []
    for label, out, stats in candidates:
        error = m.compare(rtgi, reference, out)
        patches = {p: m.compare(rtgi, reference, out, region=region(p))["region"] for p in PATCHES}
        rows.append((label, error, patches, stats))

    # One bounce of indirect light: the walk with max_bounces=1 against the samples lit by direct light
    # only and with indirect_samples rays each (their noise averaged over frames). Only the translucent
    # patches compare: `subsurface` lights the opaque surfaces with direct light alone.
    bounce, _ = walk("reference-bounce", args.spp, 0, bounces=1)
    indirect_frames = 16
    indirect_candidates = [
        ("`subsurface` ε 0, ρ 0 (direct light on the samples)", candidates[1][1]),
        (f"`subsurface indirect_samples=4` ε 0, ρ 0, {indirect_frames} frames",
         render("indirect-exact", "subsurface", {"indirect_samples": 4, "epsilon": 0, "rho": 0},
                frames=indirect_frames)[0]),
        (f"`subsurface indirect_samples=4`, {indirect_frames} frames (defaults otherwise)",
         render("indirect", "subsurface", {"indirect_samples": 4}, frames=indirect_frames)[0]),
    ]
    indirect_rows = [(label, {p: m.compare(rtgi, bounce, out, region=region(p))["region"] for p in PATCHES})
                     for label, out in indirect_candidates]
    # Equal time: the walk at the samples per pixel that one steady frame of `subsurface` (defaults)
    # costs, and at 4, 16 and 64 times that, against the reference (whose own noise is in every row).
    _, steady = render("dipole-steady", "subsurface", {}, frames=4)
    subsurface_ms = steady["frame_gpu"]["mean_ms"]
    # The better dipole with single scattering: one frame's error, and a steady frame's time.
    better_single_frame, _ = render("better-single-1", "subsurface", {"dipole": "better", "single_scattering": 4})
    _, better_single_steady = render("better-single-steady", "subsurface",
                                     {"dipole": "better", "single_scattering": 4}, frames=4)
    better_single_ms = better_single_steady["frame_gpu"]["mean_ms"]
    better_single_error = m.compare(rtgi, reference, better_single_frame)
    walk_ms_per_spp = ref_stats["frame_gpu"]["mean_ms"] / SPP_PER_FRAME
    equal_spp = max(1, round(subsurface_ms / walk_ms_per_spp))
    equal_rows = []
    for k in (1, 4, 16, 64):
        spp = equal_spp * k
        spp = spp if spp <= SPP_PER_FRAME else SPP_PER_FRAME * round(spp / SPP_PER_FRAME)
        out, _ = walk(f"walk-{spp}spp", spp, 7)
        equal_rows.append((k, spp, m.compare(rtgi, reference, out)))
    end_load = m.load_average()
    adapter = ref_stats["adapter"]
    cpu = adapter.get("device_type") == "Cpu"
    c = ref_stats["counters"]
    lines = [
        "# Subsurface scattering against the path-traced ground truth", "",
        f"Printed by `{m.command_line(SCRIPT)}` at commit `{commit}` on {m.adapter_text(adapter)}"
        + (", 2 CPU cores" if cpu else "") + ". " + m.load_text(start_load, end_load), "",
        f"`translucent` at {args.size.replace('x', '×')}. Ground truth: `path subsurface=walk max_bounces=0` at "
        f"{args.spp} samples per pixel (pixel centres, as the G-buffer of `subsurface`): direct light with the "
        "light's transport through each medium simulated by a random walk (isotropic scattering with the reduced "
        "coefficients σ_a, σ_s', under a rough dielectric boundary of the material's roughness and the medium's "
        f"η; {c['rays_per_sample']:.1f} rays per sample, {int(c.get('truncated_walks', 0))} walks cut short). "
        "Its own noise: two independent renders of a quarter of its samples differ by relMSE "
        f"{noise['rel_mse']:.5f} and FLIP {noise['flip']:.4f}, so the reference itself carries about a "
        f"quarter of that relMSE ({noise['rel_mse'] / 8:.5f}: half the difference of two images, over 4 times the "
        "samples). Patches: mean linear luminance in a rectangle inside the slab's front face (lit only through "
        "the slab, by the spot light behind it) and inside the sphere.", "",
        "| against the walk | relMSE | FLIP | " + " | ".join(f"{p} luminance (truth)" for p in PATCHES) + " |",
        "|---|---:|---:|" + "---:|" * len(PATCHES),
    ]
    for label, error, patches, _ in rows:
        cells = [f"{patches[p]['test_luminance']:.4f} ({patches[p]['reference_luminance']:.4f})" for p in PATCHES]
        lines.append(f"| {label} | {error['rel_mse']:.5f} | {error['flip']:.4f} | " + " | ".join(cells) + " |")
    (_, dipole, dipole_patches, _), (_, lambertian, lambertian_patches, _) = rows[1], rows[2]
    (_, better, better_patches, _), (_, entry, entry_patches, _) = rows[3], rows[4]
    (_, directional, directional_patches, _) = rows[5]
    (_, single, single_patches, _), (_, better_single, better_single_patches, _) = rows[7], rows[8]

    def share(patches, p):
        return f"{100 * patches[p]['test_luminance'] / patches[p]['reference_luminance']:.0f} %"

    lines += ["", f"Against the walk, the dipole's exact sum has FLIP {dipole['flip']:.4f} and relMSE "
              f"{dipole['rel_mse']:.5f}, the Lambertian stand-in FLIP {lambertian['flip']:.4f} and relMSE "
              f"{lambertian['rel_mse']:.5f}. Light shining through the slab: the dipole gives "
              f"{share(dipole_patches, 'slab front')} of the walk's luminance on its unlit front, the stand-in "
              f"{share(lambertian_patches, 'slab front')}; on the sphere {share(dipole_patches, 'sphere')} and "
              f"{share(lambertian_patches, 'sphere')}. The better dipole: FLIP {better['flip']:.4f}, relMSE "
              f"{better['rel_mse']:.5f}, {share(better_patches, 'slab front')} on the slab's front and "
              f"{share(better_patches, 'sphere')} on the sphere. The dipole with the entry Fresnel term: FLIP "
              f"{entry['flip']:.4f}, relMSE {entry['rel_mse']:.5f}, {share(entry_patches, 'slab front')} on the "
              f"slab's front and {share(entry_patches, 'sphere')} on the sphere. The directional dipole (exact sum): FLIP "
              f"{directional['flip']:.4f}, relMSE {directional['rel_mse']:.5f}, "
              f"{share(directional_patches, 'slab front')} on the slab's front and "
              f"{share(directional_patches, 'sphere')} on the sphere. With Jensen et al.'s single-scattering "
              f"term the classical dipole has FLIP {single['flip']:.4f}, relMSE {single['rel_mse']:.5f}, "
              f"{share(single_patches, 'slab front')} on the slab's front and {share(single_patches, 'sphere')} "
              f"on the sphere, the better dipole FLIP {better_single['flip']:.4f}, relMSE "
              f"{better_single['rel_mse']:.5f}, {share(better_single_patches, 'slab front')} and "
              f"{share(better_single_patches, 'sphere')}."]
    lines += ["", "## One bounce of indirect light", "",
              f"Against `path subsurface=walk max_bounces=1` at {args.spp} samples per pixel (direct light and one "
              "bounce, off the floor, the wall and the other object, into each medium), in the translucent "
              "patches only (`subsurface` lights opaque surfaces with direct light alone). Mean linear luminance "
              "as a share of the walk's:", "",
              "| against the walk with one bounce | " + " | ".join(f"{p} (truth)" for p in PATCHES) + " |",
              "|---|" + "---:|" * len(PATCHES)]
    for label, patches in indirect_rows:
        cells = [f"{share(patches, p)} ({patches[p]['reference_luminance']:.4f})" for p in PATCHES]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    dipole_default = rows[0][1]
    lines += ["", "## Equal time", "",
              f"One steady frame of `subsurface` (defaults) costs {subsurface_ms:.1f} ms of GPU time here (mean "
              f"of frames 2–4); one sample per pixel of the walk {walk_ms_per_spp:.1f} ms (the reference's "
              f"frames), so at equal time the walk gets {equal_spp} samples per pixel. Errors against the "
              "reference:", "",
              "| estimator | GPU time | relMSE | FLIP |", "|---|---:|---:|---:|",
              f"| `subsurface` (defaults), 1 frame | {subsurface_ms:.1f} ms | {dipole_default['rel_mse']:.5f} | "
              f"{dipole_default['flip']:.4f} |",
              f"| `subsurface dipole=better single_scattering=4`, 1 frame | {better_single_ms:.1f} ms | "
              f"{better_single_error['rel_mse']:.5f} | {better_single_error['flip']:.4f} |"]
    for k, spp, error in equal_rows:
        lines.append(f"| walk, {spp} spp ({k}× the time) | {spp * walk_ms_per_spp:.1f} ms | "
                     f"{error['rel_mse']:.5f} | {error['flip']:.4f} |")
    m.write_doc(SCRIPT, args.doc, lines)


if __name__ == "__main__":
    main()
