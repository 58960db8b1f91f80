//! `rtgi bench SUITE.toml --out DIR [--shard I/N]` and `rtgi bench merge RESULTS... --out DIR`.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow, bail};
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use rtgi::bench::{self, BenchResults, BuildInfo, Progress, Shard, Suite, report};

#[derive(Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct BenchArgs {
    #[command(subcommand)]
    command: Option<BenchCommand>,
    /// The suite: a TOML file declaring scenes, techniques, parameter sweeps and sizes (docs/bench.md).
    #[arg(required = true)]
    suite: Option<PathBuf>,
    /// Directory for results.json, report.html and report.md.
    #[arg(long, value_name = "DIR", required = true)]
    out: Option<PathBuf>,
    /// Run only cells whose index is I modulo N (a job-array slice); join with `rtgi bench merge`.
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
    /// Also write each cell's first compared frame as DIR/images/cell-NNNN.exr (linear) and each
    /// reference under its cache file name, named in results.json as `image_file`, for comparisons of
    /// your own.
    #[arg(long)]
    images: bool,
    #[command(flatten)]
    gpu: crate::GpuArgs,
}

#[derive(Subcommand)]
enum BenchCommand {
    /// Join the results.json files of shards of one suite into one results.json and report.
    Merge {
        /// results.json files, or directories holding one.
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        /// Directory for the merged results.json, report.html and report.md.
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
    },
}

/// `$RTGI_COMMIT` when set (a copy of the tree without its history, e.g. on a GPU machine, names the
/// commit it was copied from), else `git describe` of the checkout the suite lives in (the commit the
/// figures come from), else "unknown".
fn commit(near: &Path) -> String {
    if let Some(commit) = std::env::var("RTGI_COMMIT").ok().filter(|c| !c.trim().is_empty()) {
        return commit.trim().to_string();
    }
    let dir = near.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::process::Command::new("git")
        .args(["describe", "--always", "--dirty", "--abbrev=12"])
        .current_dir(dir)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".into())
}

fn write_outputs(results: &BenchResults, out: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("{}: cannot create the directory", out.display()))?;
    let write = |name: &str, text: &str| -> anyhow::Result<()> {
        let path = out.join(name);
        std::fs::write(&path, text).with_context(|| format!("{}: cannot write", path.display()))
    };
    write("results.json", &serde_json::to_string_pretty(results)?)?;
    write("report.html", &report::html(results))?;
    write("report.md", &report::markdown(results, "report.html"))?;
    for (name, svg) in report::plot_files(results) {
        write(&name, &svg)?;
    }
    Ok(())
}

/// Failed cells are in the report; the command still fails so scripts notice.
fn check_failures(results: &BenchResults, out: &Path) -> anyhow::Result<()> {
    let failed: Vec<String> = results
        .cells
        .iter()
        .filter_map(|c| {
            c.failure.as_ref().map(|f| format!("cell {} ({} on {}): {f}", c.index, c.series, c.scene))
        })
        .collect();
    if !failed.is_empty() {
        bail!(
            "{} of {} cells failed (figures of the others are in {}); first: {}",
            failed.len(),
            results.cells.len(),
            out.display(),
            failed[0]
        );
    }
    Ok(())
}

fn read_results(input: &Path) -> anyhow::Result<BenchResults> {
    let path = if input.is_dir() { input.join("results.json") } else { input.to_path_buf() };
    let text = std::fs::read_to_string(&path).with_context(|| format!("{}: cannot read", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: not a bench results file", path.display()))
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    if let Some(BenchCommand::Merge { inputs, out }) = &args.command {
        let parts = inputs.iter().map(|p| read_results(p)).collect::<anyhow::Result<Vec<_>>>()?;
        let merged = bench::merge(parts).map_err(|e| anyhow!("merge: {e}"))?;
        write_outputs(&merged, out)?;
        let missing = bench::missing_cells(&merged);
        eprintln!(
            "merged {} cells of {} from shards {} into {}",
            merged.cells.len(),
            merged.suite.cells,
            merged.shards.join(", "),
            out.display()
        );
        if !missing.is_empty() {
            eprintln!("warning: {} cells are in no shard: {missing:?}", missing.len());
        }
        return check_failures(&merged, out);
    }
    let (Some(suite_path), Some(out)) = (&args.suite, &args.out) else {
        bail!("give a suite file and --out DIR");
    };
    let shard = match &args.shard {
        Some(s) => Shard::parse(s).map_err(|e| anyhow!("--shard {e}"))?,
        None => Shard::ALL,
    };
    let suite = Suite::load(suite_path).map_err(|e| anyhow!(e))?;
    let gpu = args.gpu.context()?;
    let build = BuildInfo { version: env!("CARGO_PKG_VERSION").into(), commit: commit(suite_path) };
    let cells = suite.cells.iter().filter(|c| shard.contains(c.index)).count();
    let bar = std::io::stderr().is_terminal().then(|| {
        let bar = ProgressBar::new(cells as u64);
        if let Ok(style) =
            ProgressStyle::with_template("{bar:30} {pos}/{len} cells  {elapsed} (eta {eta})  {msg}")
        {
            bar.set_style(style);
        }
        bar
    });
    let mut progress = |p: Progress| {
        let Some(bar) = &bar else { return };
        match p {
            Progress::Reference { scene, time, width, height, spp } => {
                bar.set_message(format!("reference {scene} t={time} {width}x{height} {spp} spp"))
            }
            Progress::Cell { done, cell, scene, .. } => {
                bar.set_position(done as u64);
                let sweep: Vec<String> = cell.sweep.iter().map(|(k, v)| format!("{k}={v}")).collect();
                bar.set_message(format!("{} {} on {scene}", cell.series, sweep.join(" ")));
            }
        }
    };
    let images = args.images.then(|| out.join("images"));
    if let Some(dir) = &images {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create the directory", dir.display()))?;
    }
    let results = bench::run(&gpu, &suite, shard, build, images.as_deref(), &mut progress)?;
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    write_outputs(&results, out)?;
    eprintln!(
        "bench '{}': {} cells (shard {shard}) on {} → {}",
        suite.name,
        results.cells.len(),
        gpu.summary.name,
        out.join("report.html").display()
    );
    check_failures(&results, out)
}
