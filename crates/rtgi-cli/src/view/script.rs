//! `rtgi view --script FILE`: UI actions, one per line, run in order as if made in the panel (they go
//! through the same commands), for tests and reproducible captures. `#` starts a comment.
//!
//! ```text
//! frames N                 render until N frames have accumulated since the last change, then hold
//! run                      render on (after `frames`)
//! scene SPEC               e.g. cornell or two-rooms:key=value or a .glb path
//! technique NAME [K=V...]  switch technique (parameters as --set)
//! set K=V [K=V...]         set parameters of the current technique (the others keep their values)
//! camera X,Y,Z,TX,TY,TZ,FOV
//! scene-camera             back to the scene's own camera
//! time SECONDS
//! exposure EV
//! shutter SECONDS          motion blur over this shutter around each frame's time (0: off)
//! compare TECHNIQUE|off    a second renderer of the same view (`path`: the progressive reference)
//! flip on|off              the FLIP map against the comparison
//! screenshot FILE          the rendered image: .png (tone-mapped) or .exr (linear)
//! window-screenshot FILE   the whole window, panel included (.png)
//! render-command FILE      the `rtgi render` command of the current view (as the panel copies it)
//! measure N FILE.json      wall time per rendered frame over the next N frames, written as JSON
//! quit
//! ```

use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow, bail};

#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    Frames(u32),
    Run,
    Scene(String),
    Technique(String, Vec<(String, String)>),
    Set(Vec<(String, String)>),
    Camera(String),
    SceneCamera,
    Time(f32),
    Exposure(f32),
    Shutter(f32),
    Compare(Option<String>),
    Flip(bool),
    Screenshot(PathBuf),
    WindowScreenshot(PathBuf),
    RenderCommand(PathBuf),
    Measure(u32, PathBuf),
    Quit,
}

/// The actions of `text` (from `path`, named in errors with the line).
pub fn parse(path: &Path, text: &str) -> anyhow::Result<Vec<Action>> {
    text.lines()
        .enumerate()
        .filter_map(|(i, line)| {
            let line = line.split('#').next().unwrap_or("").trim();
            (!line.is_empty()).then_some((i + 1, line))
        })
        .map(|(number, line)| {
            parse_line(line).with_context(|| format!("{}:{number}: '{line}'", path.display()))
        })
        .collect()
}

fn parse_line(line: &str) -> anyhow::Result<Action> {
    let mut words = line.split_whitespace();
    let verb = words.next().unwrap_or("");
    let rest: Vec<&str> = words.collect();
    let one = || -> anyhow::Result<&str> {
        match rest.as_slice() {
            [value] => Ok(value),
            _ => Err(anyhow!("'{verb}' takes one argument")),
        }
    };
    let none = || -> anyhow::Result<()> {
        if rest.is_empty() { Ok(()) } else { Err(anyhow!("'{verb}' takes no argument")) }
    };
    let settings = |words: &[&str]| -> anyhow::Result<Vec<(String, String)>> {
        words.iter().map(|w| rtgi::params::parse_setting(w).map_err(anyhow::Error::msg)).collect()
    };
    let number = |text: &str| -> anyhow::Result<f32> {
        text.parse::<f32>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| anyhow!("'{text}' is not a finite number"))
    };
    let count = |text: &str| -> anyhow::Result<u32> {
        text.parse::<u32>().ok().filter(|n| *n > 0).ok_or_else(|| anyhow!("'{text}' is not a positive count"))
    };
    Ok(match verb {
        "frames" => Action::Frames(count(one()?)?),
        "run" => none().map(|_| Action::Run)?,
        "scene" => Action::Scene(one()?.to_string()),
        "technique" => match rest.split_first() {
            Some((name, settings_words)) => Action::Technique(name.to_string(), settings(settings_words)?),
            None => bail!("'technique' needs a name"),
        },
        "set" if !rest.is_empty() => Action::Set(settings(&rest)?),
        "set" => bail!("'set' needs KEY=VALUE"),
        "camera" => Action::Camera(one()?.to_string()),
        "scene-camera" => none().map(|_| Action::SceneCamera)?,
        "time" => Action::Time(number(one()?)?),
        "exposure" => Action::Exposure(number(one()?)?),
        "shutter" => match number(one()?)? {
            s if s >= 0.0 => Action::Shutter(s),
            s => bail!("'shutter' needs seconds, at least 0, not {s}"),
        },
        "compare" => Action::Compare(Some(one()?.to_string()).filter(|t| t != "off")),
        "flip" => match one()? {
            "on" => Action::Flip(true),
            "off" => Action::Flip(false),
            other => bail!("'flip {other}': expected on or off"),
        },
        "screenshot" => Action::Screenshot(PathBuf::from(one()?)),
        "window-screenshot" => Action::WindowScreenshot(PathBuf::from(one()?)),
        "render-command" => Action::RenderCommand(PathBuf::from(one()?)),
        "measure" => match rest.as_slice() {
            [n, file] => Action::Measure(count(n)?, PathBuf::from(file)),
            _ => bail!("'measure' takes a frame count and a .json file"),
        },
        "quit" => none().map(|_| Action::Quit)?,
        other => bail!("unknown action '{other}' (see `rtgi view --help`)"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_action_and_names_the_line_of_an_error() {
        let text = "# a comment\nframes 4\ntechnique rsm vpls=64 samples=32\nset samples=16  # inline\n\
                    camera 0,1,3,0,1,0,45\ncompare path\ncompare off\nflip on\nexposure -1.5\ntime 2\n\
                    screenshot a.png\nwindow-screenshot w.png\nmeasure 30 m.json\nrun\nscene-camera\nshutter 0.25\nquit\n";
        let actions = parse(Path::new("s.txt"), text).expect("parses");
        assert_eq!(actions[0], Action::Frames(4));
        assert_eq!(
            actions[1],
            Action::Technique(
                "rsm".into(),
                vec![("vpls".into(), "64".into()), ("samples".into(), "32".into())]
            )
        );
        assert_eq!(actions[2], Action::Set(vec![("samples".into(), "16".into())]));
        assert_eq!(actions[4], Action::Compare(Some("path".into())));
        assert_eq!(actions[5], Action::Compare(None));
        assert_eq!(actions[7], Action::Exposure(-1.5));
        assert_eq!(actions[11], Action::Measure(30, "m.json".into()));
        assert_eq!(actions[14], Action::Shutter(0.25));
        assert_eq!(actions.len(), 16);
        for bad in [
            "frames 0",
            "frames",
            "set",
            "flip maybe",
            "time x",
            "jump 3",
            "quit now",
            "measure 3",
            "shutter -1",
        ] {
            let e = parse(Path::new("s.txt"), &format!("run\n{bad}\n")).expect_err(bad);
            assert!(format!("{e:#}").starts_with("s.txt:2:"), "{e:#}");
        }
    }
}
