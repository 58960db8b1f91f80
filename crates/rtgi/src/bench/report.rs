//! The bench report: a self-contained HTML page (inline SVG plots and base64 thumbnails, nothing
//! fetched) and a Markdown summary for `docs/measurements/`, both from [`BenchResults`] alone.
//!
//! Per scene and size: FLIP against time per frame for every cell (one curve per technique entry,
//! log time axis) with the Pareto front — the cells no other cell beats in both time and error — and
//! the path tracer's FLIP interpolated at each cell's time (equal-time comparison); stacked per-pass
//! bars; a table with thumbnails and error maps.

use std::fmt::Write as _;

use super::{BenchResults, CellResult, missing_cells};

/// Colours of the curves and pass segments (Tableau 20, dark shades first), in order of first
/// appearance.
const PALETTE: [&str; 20] = [
    "#4e79a7", "#f28e2b", "#e15759", "#76b7b2", "#59a14f", "#edc948", "#b07aa1", "#ff9da7", "#9c755f",
    "#79706e", "#a0cbe8", "#ffbe7d", "#ff9d9a", "#86bcb6", "#8cd17d", "#f1ce63", "#d4a6c8", "#fabfd2",
    "#d7b5a6", "#bab0ac",
];

/// A step of 1, 2, 2.5 or 5 × 10^k giving about `count` intervals up to `top`.
fn nice_step(top: f64, count: f64) -> f64 {
    let raw = top / count;
    let decade = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 2.5, 5.0, 10.0].iter().map(|m| m * decade).find(|s| *s >= raw).unwrap_or(10.0 * decade)
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// For each (time, error) point, whether it is on the Pareto front: no other point is at most as slow
/// and strictly more accurate, or equally accurate and strictly faster.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<bool> {
    points
        .iter()
        .map(|&(t, e)| !points.iter().any(|&(t2, e2)| (t2 <= t && e2 < e) || (t2 < t && e2 <= e)))
        .collect()
}

/// The cells of one plot: one scene at one size, in matrix order.
pub struct Group<'a> {
    pub scene: &'a str,
    pub width: u32,
    pub height: u32,
    pub cells: Vec<&'a CellResult>,
}

pub fn groups(results: &BenchResults) -> Vec<Group<'_>> {
    let mut out: Vec<Group> = Vec::new();
    for c in &results.cells {
        match out.iter_mut().find(|g| g.scene == c.scene && g.width == c.width && g.height == c.height) {
            Some(g) => g.cells.push(c),
            None => out.push(Group { scene: &c.scene, width: c.width, height: c.height, cells: vec![c] }),
        }
    }
    out
}

/// A measured cell's (time per frame, mean FLIP).
fn point(c: &CellResult) -> Option<(f64, f64)> {
    Some((c.frame_ms?, c.error?.flip))
}

impl Group<'_> {
    /// Cells with figures and whether each is on the front.
    pub fn front(&self) -> Vec<(&CellResult, (f64, f64), bool)> {
        let measured: Vec<(&CellResult, (f64, f64))> =
            self.cells.iter().filter_map(|c| Some((*c, point(c)?))).collect();
        let flags = pareto_front(&measured.iter().map(|m| m.1).collect::<Vec<_>>());
        measured.into_iter().zip(flags).map(|((c, p), f)| (c, p, f)).collect()
    }

    /// The path tracer's FLIP at `ms` per frame, interpolated in log time along the front of the
    /// group's `path` cells; `None` outside their time range (a bound is given instead by the caller).
    pub fn path_flip_at(&self, ms: f64) -> Option<f64> {
        let path: Vec<(f64, f64)> =
            self.cells.iter().filter(|c| c.technique == "path").filter_map(|c| point(c)).collect();
        let flags = pareto_front(&path);
        let mut front: Vec<(f64, f64)> = path.into_iter().zip(flags).filter(|p| p.1).map(|p| p.0).collect();
        front.sort_by(|a, b| a.0.total_cmp(&b.0));
        let first = front.first()?;
        let last = front.last()?;
        if ms < first.0 || ms > last.0 {
            return None;
        }
        front.windows(2).find(|w| ms <= w[1].0).map_or(Some(first.1), |w| {
            let (a, b) = (w[0], w[1]);
            let s = (ms.ln() - a.0.ln()) / (b.0.ln() - a.0.ln()).max(1e-12);
            Some(a.1 + (b.1 - a.1) * s)
        })
    }

    fn series(&self) -> Vec<&str> {
        let mut names: Vec<&str> = Vec::new();
        for c in &self.cells {
            if !names.contains(&c.series.as_str()) {
                names.push(&c.series);
            }
        }
        names
    }
}

/// Whether `cell` is on the front computed by [`Group::front`].
fn on_front(front: &[(&CellResult, (f64, f64), bool)], cell: &CellResult) -> bool {
    front.iter().any(|f| std::ptr::eq(f.0, cell) && f.2)
}

fn sweep_text(c: &CellResult) -> String {
    c.sweep.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>().join(" ")
}

fn cell_label(c: &CellResult) -> String {
    let sweep = sweep_text(c);
    if sweep.is_empty() { c.series.clone() } else { format!("{} {sweep}", c.series) }
}

/// 1-2-5 ticks covering [lo, hi] on a log axis.
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let mut ticks = Vec::new();
    let mut decade = 10f64.powf(lo.log10().floor());
    while decade <= hi * 1.0001 {
        for m in [1.0, 2.0, 5.0] {
            let t = decade * m;
            if t >= lo * 0.9999 && t <= hi * 1.0001 {
                ticks.push(t);
            }
        }
        decade *= 10.0;
    }
    ticks
}

fn number(v: f64) -> String {
    if v >= 100.0 {
        format!("{v:.0}")
    } else if v >= 10.0 {
        format!("{v:.1}")
    } else if v >= 1.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.3}")
    }
}

/// FLIP against time per frame: one curve per series, the front as a dashed step line.
pub fn pareto_svg(group: &Group) -> String {
    let (w, h, left, right, top, bottom) = (720.0, 400.0, 60.0, 230.0, 20.0, 45.0);
    let front = group.front();
    let mut svg = format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" class="pareto" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="11">"#
    );
    if front.is_empty() {
        svg.push_str(r#"<text x="20" y="30">no measured cell</text></svg>"#);
        return svg;
    }
    let (mut t_lo, mut t_hi, mut e_hi) = (f64::MAX, f64::MIN, 0.0f64);
    for (_, (t, e), _) in &front {
        t_lo = t_lo.min(*t);
        t_hi = t_hi.max(*t);
        e_hi = e_hi.max(*e);
    }
    // Some room either side on the log axis, and a non-empty range for a single point.
    let (t_lo, t_hi) = (t_lo / 1.25, t_hi * 1.25);
    let e_step = nice_step(if e_hi > 0.0 { e_hi } else { 1.0 }, 5.0);
    let e_ticks = (e_hi / e_step).ceil().max(1.0) as u32;
    let e_hi = e_step * f64::from(e_ticks);
    let (pw, ph) = (w - left - right, h - top - bottom);
    let x = |t: f64| left + (t.ln() - t_lo.ln()) / (t_hi.ln() - t_lo.ln()) * pw;
    let y = |e: f64| top + ph - e / e_hi * ph;
    let _ = write!(
        svg,
        r##"<rect x="{left}" y="{top}" width="{pw}" height="{ph}" fill="#fafafa" stroke="#999"/>"##
    );
    for t in log_ticks(t_lo, t_hi) {
        let _ = write!(
            svg,
            r##"<line x1="{0:.1}" y1="{top}" x2="{0:.1}" y2="{1}" stroke="#e0e0e0"/><text x="{0:.1}" y="{2}" text-anchor="middle">{3}</text>"##,
            x(t),
            top + ph,
            top + ph + 14.0,
            if t >= 1.0 { format!("{t:.0}") } else { number(t) }
        );
    }
    for k in 0..=e_ticks {
        let e = e_step * f64::from(k);
        let _ = write!(
            svg,
            r##"<line x1="{left}" y1="{0:.1}" x2="{1}" y2="{0:.1}" stroke="#e0e0e0"/><text x="{2}" y="{3:.1}" text-anchor="end">{4:.3}</text>"##,
            y(e),
            left + pw,
            left - 4.0,
            y(e) + 4.0,
            e
        );
    }
    let _ = write!(
        svg,
        r#"<text x="{0}" y="{1}" text-anchor="middle">time per frame (ms, log scale)</text><text transform="translate(14 {2}) rotate(-90)" text-anchor="middle">mean FLIP</text>"#,
        left + pw / 2.0,
        h - 8.0,
        top + ph / 2.0
    );
    // The front: a dashed staircase through the cells no other beats.
    let mut on_front: Vec<(f64, f64)> = front.iter().filter(|f| f.2).map(|f| f.1).collect();
    on_front.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut steps = String::new();
    for (k, (t, e)) in on_front.iter().enumerate() {
        if k > 0 {
            let _ = write!(steps, "{:.1},{:.1} ", x(*t), y(on_front[k - 1].1));
        }
        let _ = write!(steps, "{:.1},{:.1} ", x(*t), y(*e));
    }
    let _ = write!(steps, "{:.1},{:.1}", left + pw, y(on_front[on_front.len() - 1].1));
    let _ = write!(
        svg,
        r##"<polyline class="front" points="{steps}" fill="none" stroke="#222" stroke-width="1.2" stroke-dasharray="5 3"/>"##
    );
    for (k, series) in group.series().iter().enumerate() {
        let colour = PALETTE[k % PALETTE.len()];
        let mut pts: Vec<(&CellResult, (f64, f64), bool)> =
            front.iter().filter(|f| f.0.series == *series).cloned().collect();
        pts.sort_by(|a, b| a.1.0.total_cmp(&b.1.0));
        if pts.len() > 1 {
            let line: Vec<String> = pts.iter().map(|p| format!("{:.1},{:.1}", x(p.1.0), y(p.1.1))).collect();
            let _ = write!(
                svg,
                r#"<polyline class="series" points="{}" fill="none" stroke="{colour}" stroke-width="1.5"/>"#,
                line.join(" ")
            );
        }
        for (c, (t, e), on) in &pts {
            let _ = write!(
                svg,
                r##"<circle class="cell" cx="{:.1}" cy="{:.1}" r="{}" fill="{colour}" stroke="{}"><title>{}: {} ms, FLIP {:.4}</title></circle>"##,
                x(*t),
                y(*e),
                if *on { 5.0 } else { 3.5 },
                if *on { "#000" } else { "none" },
                escape(&cell_label(c)),
                number(*t),
                e
            );
        }
        let ly = top + 14.0 + 16.0 * k as f64;
        let _ = write!(
            svg,
            r#"<rect x="{0}" y="{1}" width="12" height="12" fill="{colour}"/><text x="{2}" y="{3}">{4}</text>"#,
            left + pw + 12.0,
            ly - 10.0,
            left + pw + 30.0,
            ly,
            escape(series)
        );
    }
    let ly = top + 14.0 + 16.0 * group.series().len() as f64;
    let _ = write!(
        svg,
        r##"<line x1="{0}" y1="{1}" x2="{2}" y2="{1}" stroke="#222" stroke-dasharray="5 3"/><text x="{3}" y="{4}">Pareto front</text></svg>"##,
        left + pw + 12.0,
        ly - 4.0,
        left + pw + 24.0,
        left + pw + 30.0,
        ly
    );
    svg
}

/// Per-pass time per frame as stacked horizontal bars, one per measured cell.
pub fn passes_svg(group: &Group) -> String {
    let cells: Vec<&CellResult> = group.cells.iter().copied().filter(|c| !c.passes.is_empty()).collect();
    let mut names: Vec<&str> = Vec::new();
    for c in &cells {
        for p in &c.passes {
            if !names.contains(&p.name.as_str()) {
                names.push(&p.name);
            }
        }
    }
    let (label_w, bar_w, row) = (260.0, 380.0, 16.0);
    let legend_rows = names.len().div_ceil(4) as f64;
    let h = 30.0 + row * cells.len() as f64 + 16.0 * legend_rows + 10.0;
    let w = label_w + bar_w + 80.0;
    let mut svg = format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" class="passes" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="11">"#
    );
    let longest =
        cells.iter().map(|c| c.passes.iter().map(|p| p.ms_per_frame).sum::<f64>()).fold(0.0, f64::max);
    if cells.is_empty() || longest <= 0.0 {
        svg.push_str(r#"<text x="10" y="20">no per-pass GPU times (timestamps unavailable)</text></svg>"#);
        return svg;
    }
    let _ = write!(
        svg,
        r#"<text x="{label_w}" y="14">GPU ms per frame by pass (longest {} ms)</text>"#,
        number(longest)
    );
    for (k, c) in cells.iter().enumerate() {
        let y = 24.0 + row * k as f64;
        let _ = write!(
            svg,
            r#"<text x="{}" y="{:.1}" text-anchor="end">{}</text>"#,
            label_w - 6.0,
            y + 11.0,
            escape(&cell_label(c))
        );
        let mut x = label_w;
        for p in &c.passes {
            let colour = PALETTE[names.iter().position(|n| *n == p.name).unwrap_or(0) % PALETTE.len()];
            let width = p.ms_per_frame / longest * bar_w;
            let _ = write!(
                svg,
                r#"<rect x="{x:.1}" y="{y:.1}" width="{width:.2}" height="{}" fill="{colour}"><title>{}: {} ms</title></rect>"#,
                row - 3.0,
                escape(&p.name),
                number(p.ms_per_frame)
            );
            x += width;
        }
        let total: f64 = c.passes.iter().map(|p| p.ms_per_frame).sum();
        let _ = write!(svg, r#"<text x="{:.1}" y="{:.1}">{}</text>"#, x + 4.0, y + 11.0, number(total));
    }
    let legend_top = 30.0 + row * cells.len() as f64;
    for (k, name) in names.iter().enumerate() {
        let (col, line) = ((k % 4) as f64, (k / 4) as f64);
        let (lx, ly) = (10.0 + col * 170.0, legend_top + 16.0 * line);
        let _ = write!(
            svg,
            r#"<rect x="{lx}" y="{ly}" width="10" height="10" fill="{}"/><text x="{}" y="{}">{}</text>"#,
            PALETTE[k % PALETTE.len()],
            lx + 14.0,
            ly + 9.0,
            escape(name)
        );
    }
    svg.push_str("</svg>");
    svg
}

fn provenance(results: &BenchResults) -> String {
    let adapters: Vec<String> = results
        .adapters
        .iter()
        .map(|a| {
            let limit = a.loop_iteration_limit.map_or(String::new(), |n| {
                format!("; it stops a shader invocation's loops after {n} iterations")
            });
            format!("{} ({} {}, {} {}{limit})", a.name, a.backend, a.device_type, a.driver, a.driver_info)
        })
        .collect();
    format!(
        "rtgi {} at commit {}; adapter {}; {} measured frames per cell after one warm-up frame, the first {} compared with the reference; shards {}",
        results.rtgi.version,
        results.rtgi.commit,
        adapters.join(", "),
        results.suite.frames,
        results.suite.error_frames,
        results.shards.join(", ")
    )
}

/// How a cell compares with the path tracer at its time per frame.
fn equal_time(group: &Group, c: &CellResult) -> String {
    match (c.technique.as_str(), c.frame_ms) {
        ("path", _) | (_, None) => String::new(),
        (_, Some(ms)) => match group.path_flip_at(ms) {
            Some(f) => format!("{f:.4}"),
            None => "outside path's range".into(),
        },
    }
}

fn mib(bytes: u64) -> String {
    format!("{:.1}", bytes as f64 / (1024.0 * 1024.0))
}

/// Sentences naming the cells on the front, fastest first, with the time range each owns.
pub fn front_summary(group: &Group) -> String {
    let mut on: Vec<(&CellResult, (f64, f64))> =
        group.front().into_iter().filter(|f| f.2).map(|f| (f.0, f.1)).collect();
    on.sort_by(|a, b| a.1.0.total_cmp(&b.1.0));
    if on.is_empty() {
        return "No cell has figures.".into();
    }
    let parts: Vec<String> = on
        .iter()
        .enumerate()
        .map(|(k, (c, (t, e)))| {
            let until =
                on.get(k + 1).map_or("and beyond".to_string(), |n| format!("to {} ms", number(n.1.0)));
            format!("{} ({} ms, FLIP {e:.4}) from {} ms {until}", cell_label(c), number(*t), number(*t))
        })
        .collect();
    let techniques: Vec<&str> = {
        let mut v: Vec<&str> = Vec::new();
        for (c, _) in &on {
            if !v.contains(&c.technique.as_str()) {
                v.push(&c.technique);
            }
        }
        v
    };
    format!("On the front, fastest first: {}. Techniques on it: {}.", parts.join("; "), techniques.join(", "))
}

/// The self-contained HTML report.
pub fn html(results: &BenchResults) -> String {
    let mut out = String::new();
    let title = format!("rtgi bench: {}", results.suite.name);
    let _ = write!(
        out,
        r#"<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{0}</title>
<style>
body {{ font-family: sans-serif; margin: 20px; color: #222; }}
table {{ border-collapse: collapse; font-size: 12px; margin: 8px 0 24px; }}
td, th {{ border: 1px solid #ccc; padding: 2px 6px; text-align: right; }}
td.l, th.l {{ text-align: left; }}
tr.front td {{ background: #eef6ee; }}
img {{ image-rendering: pixelated; vertical-align: middle; }}
.failure {{ color: #b00; }}
</style></head><body>
<h1>{0}</h1>
<p>{1}</p>
<p>{2}</p>
"#,
        escape(&title),
        escape(&results.suite.description),
        escape(&provenance(results))
    );
    let missing = missing_cells(results);
    if !missing.is_empty() {
        let _ = write!(
            out,
            r#"<p class="failure">{} of {} cells are missing (shards not merged): {:?}</p>"#,
            missing.len(),
            results.suite.cells,
            missing
        );
    }
    out.push_str(
        "<p>Each cell renders every measured frame afresh (no accumulation or history). Time per frame is the \
         GPU time from timestamps (all passes, G-buffer included) where the adapter's timestamps are reliable, \
         else wall time. FLIP and relMSE are means over the compared frames against the path-traced reference; \
         <b>path at equal time</b> is the path tracer's FLIP at the cell's time, interpolated in log time along \
         the path cells' front. Highlighted rows are on the Pareto front.</p>\n",
    );
    out.push_str("<h2>References</h2><table><tr><th class=\"l\">scene</th><th>time</th><th>size</th><th>spp</th><th class=\"l\">path settings</th><th class=\"l\">key</th><th>render ms</th><th>image</th></tr>\n");
    for r in &results.references {
        let _ = writeln!(
            out,
            r#"<tr><td class="l">{}</td><td>{}</td><td>{}×{}</td><td>{}</td><td class="l">{}</td><td class="l">{}</td><td>{}</td><td><img src="data:image/png;base64,{}"></td></tr>"#,
            escape(&r.scene),
            r.time,
            r.width,
            r.height,
            r.spp,
            escape(&r.settings.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>().join(" ")),
            r.key,
            if r.cached { "cached".to_string() } else { number(r.render_ms) },
            r.thumbnail_png
        );
    }
    out.push_str("</table>\n");
    for group in groups(results) {
        let _ = writeln!(out, "<h2>{} at {}×{}</h2>", escape(group.scene), group.width, group.height);
        let _ = writeln!(out, "<p>{}</p>", escape(&front_summary(&group)));
        out.push_str(&pareto_svg(&group));
        out.push('\n');
        out.push_str(&passes_svg(&group));
        out.push_str("\n<table><tr><th class=\"l\">technique</th><th class=\"l\">sweep</th><th>ms/frame</th><th>p95</th><th>source</th><th>FLIP</th><th>path at equal time</th><th>relMSE</th><th>RMSE</th><th>GPU MiB</th><th>setup ms</th><th>image</th><th>FLIP map</th></tr>\n");
        let front = group.front();
        for c in &group.cells {
            let on = on_front(&front, c);
            let img = |p: &Option<String>| {
                p.as_ref().map_or(String::new(), |b| format!(r#"<img src="data:image/png;base64,{b}">"#))
            };
            if let Some(f) = &c.failure {
                let _ = writeln!(
                    out,
                    r#"<tr><td class="l">{}</td><td class="l">{}</td><td class="l failure" colspan="11">failed: {}</td></tr>"#,
                    escape(&c.series),
                    escape(&sweep_text(c)),
                    escape(f)
                );
                continue;
            }
            let summary = c.frame_time();
            let e = c.error;
            let _ = writeln!(
                out,
                r#"<tr{}><td class="l">{}</td><td class="l">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>"#,
                if on { r#" class="front""# } else { "" },
                escape(&c.series),
                escape(&sweep_text(c)),
                summary.map_or("–".into(), |s| number(s.mean_ms)),
                summary.map_or("–".into(), |s| number(s.p95_ms)),
                c.time_source,
                e.map_or("–".into(), |e| format!("{:.4}", e.flip)),
                equal_time(&group, c),
                e.map_or("–".into(), |e| format!("{:.5}", e.rel_mse)),
                e.map_or("–".into(), |e| format!("{:.5}", e.rmse)),
                mib(c.gpu_memory_bytes),
                number(c.setup_ms),
                img(&c.thumbnail_png),
                img(&c.error_map_png)
            );
        }
        out.push_str("</table>\n");
    }
    out.push_str("</body></html>\n");
    out
}

/// The file name of a group's Pareto plot among [`plot_files`].
fn plot_name(group: &Group) -> String {
    let scene: String =
        group.scene.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect();
    format!("pareto-{scene}-{}x{}.svg", group.width, group.height)
}

/// Every group's Pareto plot as a standalone SVG file (name, contents), for pages that show images but
/// not inline SVG (the Markdown report links them).
pub fn plot_files(results: &BenchResults) -> Vec<(String, String)> {
    groups(results).iter().map(|g| (plot_name(g), pareto_svg(g))).collect()
}

/// The Markdown summary committed under `docs/measurements/`: provenance, the front per scene (with
/// the plot from [`plot_files`]), and every cell's figures.
pub fn markdown(results: &BenchResults, html_name: &str) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "# rtgi bench: {}\n", results.suite.name);
    if !results.suite.description.is_empty() {
        let _ = writeln!(out, "{}\n", results.suite.description);
    }
    let _ = writeln!(
        out,
        "Printed by `rtgi bench {}` ({}); plots, per-pass bars and images in [{html_name}]({html_name}), raw figures in `results.json`.\n",
        results.suite.file,
        provenance(results)
    );
    let missing = missing_cells(results);
    if !missing.is_empty() {
        let _ = writeln!(
            out,
            "**{} of {} cells missing** (shards not merged): {missing:?}\n",
            missing.len(),
            results.suite.cells
        );
    }
    for group in groups(results) {
        let _ = writeln!(out, "## {} at {}×{}\n", group.scene, group.width, group.height);
        let _ = writeln!(out, "{}\n", front_summary(&group));
        let _ = writeln!(out, "![FLIP against time per frame, {}]({})\n", group.scene, plot_name(&group));
        out.push_str("| technique | sweep | ms/frame | p95 | FLIP | path FLIP at equal time | relMSE | GPU MiB | front |\n|---|---|---|---|---|---|---|---|---|\n");
        let front = group.front();
        for c in &group.cells {
            if let Some(f) = &c.failure {
                let _ = writeln!(
                    out,
                    "| {} | {} | failed: {} | | | | | | |",
                    c.series,
                    sweep_text(c),
                    f.replace('|', "/")
                );
                continue;
            }
            let on = on_front(&front, c);
            let summary = c.frame_time();
            let _ = writeln!(
                out,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                c.series,
                sweep_text(c),
                summary.map_or("–".into(), |s| number(s.mean_ms)),
                summary.map_or("–".into(), |s| number(s.p95_ms)),
                c.error.map_or("–".into(), |e| format!("{:.4}", e.flip)),
                equal_time(&group, c),
                c.error.map_or("–".into(), |e| format!("{:.5}", e.rel_mse)),
                mib(c.gpu_memory_bytes),
                if on { "★" } else { "" }
            );
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_front_holds_exactly_the_cells_nothing_beats() {
        let points = [(1.0, 0.5), (2.0, 0.3), (2.0, 0.4), (4.0, 0.35), (8.0, 0.1), (0.5, 0.9), (8.0, 0.1)];
        // (2, 0.4) loses to (2, 0.3); (4, 0.35) to (2, 0.3); equal points are both kept.
        assert_eq!(pareto_front(&points), vec![true, true, false, false, true, true, true]);
    }

    #[test]
    fn ticks_cover_the_range_on_a_1_2_5_scale() {
        assert_eq!(log_ticks(0.8, 30.0), vec![1.0, 2.0, 5.0, 10.0, 20.0]);
        assert_eq!(nice_step(0.457, 5.0), 0.1);
        assert_eq!(nice_step(0.12, 5.0), 0.025);
    }
}
