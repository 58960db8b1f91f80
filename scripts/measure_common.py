"""Shared by the measurement scripts (measure-igi.py, measure-rsm.py): they declare their renders as bench
suites in benches/, run `rtgi bench SUITE --out DIR --images`, and print their documents from results.json
and, for comparisons the bench does not make (one cell against another, region luminance, error maps),
`rtgi compare` / `rtgi tonemap` on the images it kept. Python 3 standard library only.

Environment: RTGI (the rtgi binary; default: built with `cargo build --release -p rtgi-cli` into
$CARGO_TARGET_DIR or target/), SCRATCH (where the bench runs write, default target/measure/<script>),
NODEVICE_SELECT (set to 1 unless given). References come from the reference cache ($RTGI_CACHE_DIR or the
default cache; see the README), rendered once when missing.
"""
import argparse
import json
import tomllib
import re
import math
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
os.chdir(ROOT)
os.environ.setdefault("NODEVICE_SELECT", "1")


def log(script, msg):
    print(f"[{script} {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def run(cmd):
    """Runs `cmd`, returns its stdout; on failure exits with the command and its output."""
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"failed: {' '.join(map(str, cmd))}\n{r.stdout}\n{r.stderr}")
    return r.stdout


def dirty_files():
    """Tracked files with uncommitted changes: figures printed from such a tree name no commit."""
    return run(["git", "status", "--porcelain", "--untracked-files=no"]).strip()


def refuse_dirty_tree(allow, script):
    """Exits unless the tree is clean or `allow` (then the documents name the commit `-dirty`, as
    `git describe --dirty` in results.json does). A copy of the tree without its repository (a GPU
    machine's) passes: the rtgi binary, built in the repository, names its own commit."""
    if not (ROOT / ".git").exists() or shutil.which("git") is None:
        log(script, "no git repository here; the documents name the commit the rtgi binary was built at")
        return
    dirty = dirty_files()
    if dirty and not allow:
        sys.exit(f"{script}: the tree has uncommitted changes, so the figures would name no commit; "
                 f"commit them or pass --allow-dirty:\n{dirty}")
    if dirty:
        log(script, "warning: uncommitted changes; the document will name the commit '-dirty'")


def describe():
    """The commit the figures come from: $RTGI_COMMIT (a copy of the tree without its history names the
    commit it was copied from), else `git describe` of this checkout (`-dirty` with uncommitted changes),
    as `rtgi bench` names it in results.json."""
    if os.environ.get("RTGI_COMMIT", "").strip():
        return os.environ["RTGI_COMMIT"].strip()
    if not (ROOT / ".git").exists() or shutil.which("git") is None:
        return "unknown"
    return run(["git", "describe", "--always", "--dirty", "--abbrev=12"]).strip()


def suite_arguments(script, suite, doc, description, extra=None):
    """The command line of the scripts that print a document from a bench suite: --suite FILE, --size WxH,
    --doc NAME, --allow-dirty, and what `extra(parser)` adds. Refuses a dirty tree unless allowed and
    builds the binary: returns (args, rtgi)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--suite", default=suite)
    parser.add_argument("--size", help="WxH: run the suite at this size instead of its own")
    parser.add_argument("--doc", default=doc)
    parser.add_argument("--allow-dirty", action="store_true")
    if extra:
        extra(parser)
    args = parser.parse_args()
    refuse_dirty_tree(args.allow_dirty, script)
    return args, rtgi_binary()


def script_arguments(script, description, doc, extra):
    """The command line of a script that prints one document from its own renders: what `extra(parser)` adds,
    --doc NAME and --allow-dirty. Refuses a dirty tree unless allowed and builds the binary: returns (args,
    rtgi, the commit, the load average at the start)."""
    parser = argparse.ArgumentParser(description=description)
    extra(parser)
    parser.add_argument("--doc", default=doc)
    parser.add_argument("--allow-dirty", action="store_true")
    args = parser.parse_args()
    refuse_dirty_tree(args.allow_dirty, script)
    return args, rtgi_binary(), describe(), load_average()


def command_line(script):
    """How the running script was invoked, as a document names it (without --allow-dirty)."""
    return f"python3 scripts/{script}" + "".join(f" {a}" for a in sys.argv[1:] if a != "--allow-dirty")


def suite_at_size(suite_path, size, out):
    """The suite file at `suite_path` (relative to the repository), or with `size` a copy of it in `out`
    whose `sizes` is that one size."""
    suite_file = ROOT / suite_path
    if not size:
        return suite_file
    copy = Path(out) / f"{suite_file.stem}-{size}.toml"
    copy.write_text(re.sub(r"(?m)^sizes = .*$", f'sizes = ["{size}"]', suite_file.read_text()))
    return copy


def printed_by(script, args, size, results, adapter, cpu):
    """A document's first sentences: the command that printed it, the suite, commit and adapter, and
    where the bench's own report lies."""
    command = command_line(script)
    return (f"Printed by `{command}` from `rtgi bench {args.suite}`" + (f" at {size}" if args.size else "")
            + f" at commit `{results['rtgi']['commit']}` on {adapter_text(adapter)}"
            + (", 2 CPU cores" if cpu else "") + ". The bench's own report (Pareto plots, every cell with "
            f"thumbnails and error maps) is in [`{args.doc}-bench/`]({args.doc}-bench/report.md).")


def rtgi_binary():
    """$RTGI, else the release build (built first, a no-op when up to date)."""
    if os.environ.get("RTGI"):
        return Path(os.environ["RTGI"])
    run(["cargo", "build", "--release", "-p", "rtgi-cli"])
    return Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target")) / "release" / "rtgi"


def scratch(script):
    path = Path(os.environ.get("SCRATCH", ROOT / "target" / "measure" / script))
    path.mkdir(parents=True, exist_ok=True)
    return path


def _same(a, b):
    """Parameter values as the bench writes them (text) against values given in Python."""
    if isinstance(b, bool):
        b = "true" if b else "false"
    try:
        return float(a) == float(b)
    except (TypeError, ValueError):
        return str(a) == str(b)


class Bench:
    """One `rtgi bench` run: its results.json and the images it kept."""

    def __init__(self, rtgi, suite, out, images=True, options=()):
        self.rtgi, self.suite, self.out = rtgi, suite, Path(out)
        started = time.time()
        cmd = [rtgi, "bench", suite, "--out", self.out] + (["--images"] if images else []) + list(options)
        r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
        self.seconds = time.time() - started
        if not (self.out / "results.json").exists():
            sys.exit(f"failed: {' '.join(map(str, cmd))}\n{r.stdout}\n{r.stderr}")
        self.results = json.loads((self.out / "results.json").read_text())
        failed = [c for c in self.results["cells"] if c["failure"]]
        if r.returncode != 0 or failed:
            sys.exit(f"{suite}: {len(failed)} cells failed (first: {failed[0]['failure'] if failed else '?'})\n"
                     f"{r.stderr}")

    @property
    def commit(self):
        return self.results["rtgi"]["commit"]

    @property
    def adapter(self):
        (a,) = self.results["adapters"]
        return a

    @property
    def reference_seconds(self):
        return sum(r["render_ms"] for r in self.results["references"]) / 1000

    def cell(self, scene, technique, **settings):
        """The cell of `technique` on `scene` whose parameters are exactly `settings`."""
        found = [c for c in self.results["cells"]
                 if c["scene"] == scene and c["technique"] == technique and c["settings"].keys() == settings.keys()
                 and all(_same(c["settings"][k], v) for k, v in settings.items())]
        if len(found) != 1:
            sys.exit(f"{self.suite}: {len(found)} cells of {technique} {settings} on {scene}, expected one")
        return found[0]

    def image(self, cell):
        """The kept EXR of a cell (its first compared frame)."""
        return self.out / "images" / cell["image_file"]

    def reference(self, scene):
        """The kept EXR of the scene's reference (a still scene: one reference)."""
        (r,) = [r for r in self.results["references"] if r["scene"] == scene]
        return self.out / "images" / r["image_file"]

    def references(self):
        return self.results["references"]


def same_run(benches):
    """Commit and adapter of runs that must share both (one document's header)."""
    commits = {b.commit for b in benches}
    adapters = {json.dumps(b.adapter, sort_keys=True) for b in benches}
    if len(commits) != 1 or len(adapters) != 1:
        sys.exit(f"the bench runs disagree on commit {commits} or adapter {adapters}")
    return benches[0].commit, benches[0].adapter


def adapter_text(a):
    return f"{a['name']} [{a.get('driver_info', '')}, {a.get('backend', '')}]"


def compare(rtgi, ref, test, error_map=None, region=None):
    cmd = [rtgi, "compare", ref, test, "--json"]
    if error_map:
        cmd += ["--error-map", error_map]
    if region:
        cmd += ["--region", region]
    return json.loads(run(cmd))


def tonemap(rtgi, src, dst):
    run([rtgi, "tonemap", src, dst])


def scene_reference_settings(suite, scene):
    """The path settings of a scene's reference in words ("max_bounces = 0"), or None for full GI."""
    reference = next((e.get("set") for e in suite.get("scenes", []) if e["scene"] == scene), None)
    return ", ".join(f"{k} = {v}" for k, v in reference.items()) if reference else None


def pass_ms(cell, name):
    """A pass's time per frame in a cell (None when the cell has no such pass)."""
    for p in cell["passes"]:
        if p["name"] == name:
            return p["ms_per_frame"]
    return None


def time_source(benches):
    """How the runs timed their frames, in words."""
    sources = {c["time_source"] for b in benches for c in b.results["cells"]}
    if sources == {"gpu"}:
        return "GPU timestamps"
    if sources == {"wall"}:
        return "wall times"
    return "GPU timestamps where reliable, else wall times"


def reference_text(r):
    """A results.json reference in words: scene, size, samples, `path` settings."""
    settings = " ".join(f"{k}={v}" for k, v in sorted(r["settings"].items()))
    return (f"`{r['scene']}` {r['width']}×{r['height']} at {r['spp']} spp"
            + (f" with `{settings}`" if settings else " with all bounces"))


def load_average():
    """The 1-minute load average (None where the system does not report one)."""
    try:
        return os.getloadavg()[0]
    except OSError:
        return None


def load_text(start, end):
    """The machine's load during a run, in words: figures the timings depend on."""
    if start is None or end is None:
        return ""
    cores = os.cpu_count()
    return (f"The 1-minute load average was {start:.1f} when the run started and {end:.1f} when it ended, on "
            f"{cores} CPU cores" + (": other processes shared the CPU, so absolute times are inflated and noisier "
                                    "than on an idle machine." if max(start, end) > cores + 0.5 else "."))


def render_sequence(rtgi, out, scene, name, technique, settings, size, frames, extra=()):
    """Renders FRAMES frames of SCENE at 30 fps into OUT/name_%04d.exr (`settings` as --set, `extra` added to
    the command line); returns its stats."""
    stats = out / f"{name}.json"
    sets = [x for k, v in settings.items() for x in ("--set", f"{k}={v}")]
    run([rtgi, "render", "--scene", scene, "--technique", technique, "--size", size, "--frames", frames,
         "--fps", 30, *sets, *extra, "--out", out / f"{name}_%04d.exr", "--stats", stats])
    return json.loads(stats.read_text())


def write_doc(script, name, lines):
    """Writes docs/measurements/NAME.md from `lines` (a blank line appended) and prints it."""
    text = "\n".join(lines + [""])
    doc = ROOT / "docs" / "measurements" / f"{name}.md"
    doc.write_text(text)
    print(text)
    log(script, f"wrote {doc}")


def duration(seconds):
    return f"{int(seconds // 60)} min {int(seconds % 60)} s"


def log_log_interpolate(points, x):
    """The value at `x` of (x, value) points, interpolated in log-log between the nearest two (None outside
    them or with fewer than two)."""
    if x is None or len(points) < 2:
        return None
    points = sorted(points)
    for (x0, v0), (x1, v1) in zip(points, points[1:]):
        if x0 <= x <= x1:
            a = (math.log(x) - math.log(x0)) / (math.log(x1) - math.log(x0))
            return math.exp(math.log(v0) + a * (math.log(v1) - math.log(v0)))
    return None


def join_and(items):
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def dark_floor(width, height):
    """The floor of two-rooms' dark room (the camera's room) as `rtgi compare --region`: at 128x128 the
    rows 100-127, every pixel below the doorway's sill line, show room 2's floor, which only light
    through the doorway may reach. The camera's vertical field of view is fixed, so at other sizes the
    same rows scale with the height and wider images show more of the floor at the sides."""
    top = round(100 * height / 128)
    return f"0,{top},{width},{height - top}"


def leak_table(rtgi, out, cells, size, spp, intro=""):
    """The "Leaks" section: per two-rooms cell with an image, the mean luminance of the dark room's floor
    against the reference's (rendered into `out` at `size` with the scene's reference spp), FLIP and
    relMSE. Returns the lines (none without such cells)."""
    two = [c for c in cells if c["scene"] == "two-rooms" and c.get("image_file")]
    if not two:
        return []
    width, height = (int(v) for v in size.split("x"))
    region = dark_floor(width, height)
    ref_exr = out / "two-rooms-reference.exr"
    run([rtgi, "reference", "--scene", "two-rooms", "--size", size, "--spp", spp["two-rooms"], "--out", ref_exr])
    lines = ["## Leaks: light on two-rooms' dark floor", "",
             f"Mean luminance of the dark room's floor (pixels {region}: x, y, w, h) against the "
             "reference's; light reaches it only through the doorway." + intro, "",
             "| cell | floor / reference | FLIP | relMSE |", "|---|---|---|---|"]
    for c in two:
        r = compare(rtgi, ref_exr, out / "images" / c["image_file"], region=region)["region"]
        lines.append(f"| {label(c)} | {r['test_luminance'] / r['reference_luminance']:.3f} | "
                     f"{c['error']['flip']:.4f} | {c['error']['rel_mse']:.5f} |")
    return lines + [""]


def label(cell):
    sweep = " ".join(f"{k}={v}" for k, v in cell["sweep"].items())
    return f"{cell['series']} {sweep}".strip()


def path_flip_at(cells, ms):
    """FLIP of the path tracer at time `ms`, interpolated in log time along its cells; None outside."""
    path = sorted((c["frame_ms"], c["error"]["flip"]) for c in cells if c["technique"] == "path" and c["error"])
    for (t0, f0), (t1, f1) in zip(path, path[1:]):
        if t0 <= ms <= t1:
            w = (math.log(ms) - math.log(t0)) / (math.log(t1) - math.log(t0))
            return f0 + w * (f1 - f0)
    return None


# The passes of each technique's indirect light: without the G-buffer, the shadow maps, the RSM (rendered
# only when lights or geometry move) and the direct light. The "GI ms" of the volume-GI documents.
GI_PASSES = {
    "vxgi": ("vxgi voxelization", "vxgi injection", "vxgi mips", "vxgi bounce", "vxgi bounce mips",
             "vxgi cone tracing"),
    "lpv": ("lpv flux scale", "lpv injection", "lpv geometry injection", "lpv resolve", "lpv propagation",
            "lpv lookup"),
    "rsm": ("rsm gather", "upsample", "full-resolution fixup", "composite"),
}


def gi_ms(cell):
    names = GI_PASSES.get(cell["technique"], ())
    return sum(p["ms_per_frame"] for p in cell["passes"] if p["name"] in names)


def gi_tables(cells, width, height, compared, default):
    """Per scene: every cell's frame time, GI time (techniques of GI_PASSES), GI time over rsm's (the
    techniques in `compared`), FLIP, relMSE, path's FLIP at its time and whether it is on the scene's
    front; then the per-pass split of the cell `default(cell)` picks."""
    lines = []
    for scene in dict.fromkeys(c["scene"] for c in cells):
        sc = [c for c in cells if c["scene"] == scene]
        rsm = next((c for c in sc if c["technique"] == "rsm"), None)
        lines += [f"## {scene} ({width}×{height})", "",
                  "| cell | ms/frame | GI ms | GI ms / rsm's | FLIP | relMSE | path's FLIP at this time | on the "
                  "front |", "|---|---|---|---|---|---|---|---|"]
        for c in sc:
            gi = f"{gi_ms(c):.2f}" if c["technique"] in GI_PASSES else "–"
            ratio = (f"{gi_ms(c) / gi_ms(rsm):.2f}" if rsm and c["technique"] in compared and gi_ms(rsm) > 0
                     else "–")
            lines.append(f"| {label(c)} | {c['frame_ms']:.1f} | {gi} | {ratio} | {c['error']['flip']:.4f} | "
                         f"{c['error']['rel_mse']:.5f} | {path_flip_text(sc, c)} | "
                         f"{'yes' if on_front(sc, c) else 'no'} |")
        lines.append("")
        chosen = next((c for c in sc if default(c)), None)
        if chosen:
            split = ", ".join(f"{p['name']} {p['ms_per_frame']:.2f}" for p in chosen["passes"])
            lines += [f"{label(chosen)} per pass, ms/frame: {split}.", ""]
    return lines


def on_front(cells, cell):
    """Whether `cell` is on the error-vs-time front of `cells` (one scene's): no other cell is both
    faster and more accurate (FLIP)."""
    t, f = cell["frame_ms"], cell["error"]["flip"]
    return not any(o["frame_ms"] <= t and o["error"]["flip"] <= f and (o["frame_ms"], o["error"]["flip"]) != (t, f)
                   for o in cells)


def path_flip_text(cells, cell):
    """The "path's FLIP at this time" column of `cell` among `cells` (one scene's): "–" for path itself
    or outside path's times."""
    p = path_flip_at(cells, cell["frame_ms"])
    return f"{p:.4f}" if p is not None and cell["technique"] != "path" else "–"


def run_suite_into_doc(rtgi, out, doc_dir, suite_path, size, doc):
    """Runs `rtgi bench suite_path --images` into `out` (at `size` instead of the suite's own when given)
    and copies its report to doc_dir/DOC-bench/. Returns (suite as parsed, size, results, the cells with
    an error figure, the adapter, whether it is a CPU driver, the reference spp per scene)."""
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    suite = tomllib.loads((ROOT / suite_path).read_text())
    suite_file = suite_at_size(suite_path, size, out)
    size = size or suite["sizes"][0]
    print(f"running {suite_path} at {size} ...", flush=True)
    subprocess.run([str(rtgi), "bench", str(suite_file), "--out", str(out), "--images"], check=True)
    results = json.loads((out / "results.json").read_text())
    bench_doc = doc_dir / f"{doc}-bench"
    if bench_doc.exists():
        shutil.rmtree(bench_doc)
    bench_doc.mkdir(parents=True)
    for f in out.iterdir():
        if f.is_file() and f.suffix != ".toml":
            shutil.copy(f, bench_doc / f.name)
    cells = [c for c in results["cells"] if c["error"]]
    adapter = results["adapters"][0]
    cpu = adapter.get("device_type") == "Cpu"
    spp = {sc["scene"]: sc.get("spp", suite["reference"]["spp"]) for sc in suite["scenes"]}
    return suite, size, results, cells, adapter, cpu, spp


def run_documented_suite(script, scratch_name, suite_path, doc, description):
    """The common start of a script that prints one document from one bench suite: its command line
    (suite_arguments), the run into docs/measurements/DOC-bench/ (run_suite_into_doc) and the document's
    first sentences (printed_by, then the load averages around the run). Returns a namespace: args, suite,
    size, width, height, results, cells, adapter, cpu, spp (per scene), ref_spp (in words), header."""
    from types import SimpleNamespace
    args, rtgi = suite_arguments(script, suite_path, doc, description)
    start = load_average()
    suite, size, results, cells, adapter, cpu, spp = run_suite_into_doc(
        rtgi, scratch(scratch_name) / "bench", ROOT / "docs/measurements", args.suite, args.size, args.doc)
    width, height = (int(v) for v in size.split("x"))
    header = printed_by(script, args, size, results, adapter, cpu) + " " + load_text(start, load_average())
    return SimpleNamespace(args=args, suite=suite, size=size, width=width, height=height, results=results,
                           cells=cells, adapter=adapter, cpu=cpu, spp=spp,
                           ref_spp="; ".join(f"{k} {v}" for k, v in spp.items()), header=header)
