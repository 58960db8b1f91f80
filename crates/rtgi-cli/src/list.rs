//! `rtgi list`: built-in scenes and techniques with their parameters. Needs no GPU.

use std::fmt::Write as _;
use std::io::Write as _;

use rtgi::params::ParamSpec;

struct Entry {
    name: &'static str,
    description: &'static str,
    params: &'static [ParamSpec],
    /// How a technique handles motion (scenes have none).
    motion: Option<&'static str>,
}

pub fn run() -> anyhow::Result<()> {
    let scenes: Vec<Entry> = rtgi::scene::builtin::list()
        .iter()
        .map(|s| Entry { name: s.name, description: s.description, params: s.params, motion: None })
        .collect();
    let techniques: Vec<Entry> = rtgi::techniques::registry()
        .iter()
        .map(|t| Entry {
            name: t.name,
            description: t.description,
            params: t.params,
            motion: Some(t.motion.describe()),
        })
        .collect();

    let mut text = String::new();
    section(&mut text, "Built-in scenes (--scene NAME or NAME:key=value,...):", &scenes);
    text.push('\n');
    section(&mut text, "Techniques (--technique NAME, parameters with --set key=value):", &techniques);
    text.push('\n');
    let post = [Entry {
        name: "motion-blur",
        description: "non-linear motion blur of any technique's image over --shutter SECONDS: each moving \
                      pixel's quadratic screen-space curve scattered as lines (post-process)",
        params: &rtgi::post::motion_blur::MOTION_BLUR_PARAMS,
        motion: None,
    }];
    section(
        &mut text,
        "Post-processes (rtgi render --shutter S, parameters with --motion-blur-set key=value):",
        &post,
    );
    text.push_str("\nParameters are shown as key=default, then kind and meaning.\n");

    match std::io::stdout().lock().write_all(text.as_bytes()) {
        // `rtgi list | head` closing the pipe early is not an error.
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => Ok(other?),
    }
}

fn section(out: &mut String, title: &str, entries: &[Entry]) {
    let _ = writeln!(out, "{title}");
    if entries.is_empty() {
        let _ = writeln!(out, "  (none registered)");
        return;
    }
    let name_width = entries.iter().map(|e| e.name.len()).max().unwrap_or(0);
    let params = || entries.iter().flat_map(|e| e.params);
    let setting_width = params().map(|p| p.name.len() + 1 + p.default.len()).max().unwrap_or(0);
    let kind_width = params().map(|p| p.kind.to_string().len()).max().unwrap_or(0);
    for entry in entries {
        let _ = writeln!(out, "  {:<name_width$}  {}", entry.name, entry.description);
        if let Some(motion) = entry.motion {
            let _ = writeln!(out, "      motion: {motion}");
        }
        for p in entry.params {
            let setting = format!("{}={}", p.name, p.default);
            let kind = p.kind.to_string();
            let _ = writeln!(out, "      {setting:<setting_width$}  {kind:<kind_width$}  {}", p.doc);
        }
    }
}
