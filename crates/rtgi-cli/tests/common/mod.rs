//! What the CLI's integration tests share.

use std::path::Path;
use std::process::{Command, Output};

/// Runs the built `rtgi` binary with `args` in `dir`, with its reference cache in `dir/cache`, so a test
/// neither reads nor fills the user's cache.
pub fn rtgi_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rtgi"))
        .args(args)
        .current_dir(dir)
        .env("RTGI_CACHE_DIR", dir.join("cache"))
        .output()
        .expect("the rtgi binary runs")
}
