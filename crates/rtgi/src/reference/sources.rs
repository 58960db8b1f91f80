// What a reference's cache key hashes besides the scene and the request: a stable hasher and the
// library sources that shape a path-traced reference.
//
// This file is compiled twice: as `rtgi::reference::sources` and, through `include!`, inside
// `crates/rtgi/build.rs`, which hashes the sources at build time into `RTGI_REFERENCE_SOURCES_HASH`.
// It therefore uses `std` only, names nothing of the crate but `crate::stable_hash` (which build.rs
// includes too) and has no inner doc comments (`include!` does not accept them).

use std::path::Path;

pub use crate::stable_hash::StableHasher;

/// Whether the source file at `path` (relative to `crates/rtgi/src`, `/`-separated) can change the
/// pixels of a path-traced reference.
///
/// The rule excludes what provably cannot and keeps everything else, rather than listing what can: a
/// file added later (a new module the renderer uses, a new shared WGSL file) is then covered without
/// anyone remembering this list, and the price of a wrong guess is a reference rendered again, never a
/// stale one. Hashing all of `src/` would also be safe, but every edit of a GI technique or a test
/// would throw away minutes of cached references. Excluded:
/// - other techniques' folders (`techniques/<name>/` except `path/`): a reference never runs them;
/// - test code (`tests.rs`, `*_tests.rs`, `test_*.rs`, the `testing` harness), as in `tests/layers.rs`;
/// - `metrics/`: it compares images, it does not make them;
/// - `bench/`: it asks for references and measures against them, a layer above the renderer;
/// - the scene generators and glTF reader/writer (`scene/builtin/`, `scene/gltf_load*`,
///   `scene/gltf_export*`): what they produce is a `Scene`, whose content the key hashes itself.
///
/// Kept, among the rest: the path tracer's host code and WGSL (`techniques/path/`), the pipeline and
/// dispatch helpers and the registry (`techniques/compute.rs`, `techniques/mod.rs`), the GPU scene
/// upload with the emitter and environment sampling tables (`gpu/scene.rs`), the BVH build
/// (`gpu/bvh/`), the shared WGSL (`shaders/`), the frame resources (`frame/`: camera uniforms), the
/// renderer, `render.rs`, this module and `reference.rs`, the parameters and the EXR writer
/// (`image.rs`). Not covered at all: dependency versions (wgpu, naga), the toolchain and the driver.
pub fn is_reference_source(path: &str) -> bool {
    if !(path.ends_with(".rs") || path.ends_with(".wgsl")) {
        return false;
    }
    let file = path.rsplit('/').next().unwrap_or(path);
    let stem = file.split('.').next().unwrap_or(file);
    if stem == "tests" || stem.ends_with("_tests") || stem.starts_with("test_") {
        return false;
    }
    if path == "testing.rs"
        || path.starts_with("testing/")
        || path.starts_with("metrics/")
        || path.starts_with("bench/")
    {
        return false;
    }
    if path.starts_with("scene/builtin/")
        || path.starts_with("scene/gltf_load")
        || path.starts_with("scene/gltf_export")
    {
        return false;
    }
    if let Some(rest) = path.strip_prefix("techniques/")
        && let Some((folder, _)) = rest.split_once('/')
    {
        return folder == "path";
    }
    true
}

/// Every file under `src_root` that [`is_reference_source`] keeps, as (relative path, contents),
/// sorted by path; `dirs` receives every folder walked (so a build script can watch them for new
/// files).
pub fn collect_reference_sources(
    src_root: &Path,
    dirs: &mut Vec<std::path::PathBuf>,
) -> std::io::Result<Vec<(String, Vec<u8>)>> {
    fn walk(
        root: &Path,
        dir: &Path,
        dirs: &mut Vec<std::path::PathBuf>,
        out: &mut Vec<(String, Vec<u8>)>,
    ) -> std::io::Result<()> {
        dirs.push(dir.to_path_buf());
        for entry in std::fs::read_dir(dir)? {
            let path = entry?.path();
            if path.is_dir() {
                walk(root, &path, dirs, out)?;
                continue;
            }
            let Ok(relative) = path.strip_prefix(root) else { continue };
            let relative: Vec<String> =
                relative.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
            let relative = relative.join("/");
            if is_reference_source(&relative) {
                let contents = std::fs::read(&path)?;
                out.push((relative, contents));
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(src_root, src_root, dirs, &mut out)?;
    out.sort();
    Ok(out)
}

/// The hash of (path, contents) pairs, independent of their order: a renamed, added, removed or
/// edited file changes it.
pub fn hash_sources(files: &[(String, Vec<u8>)]) -> u64 {
    let mut sorted: Vec<&(String, Vec<u8>)> = files.iter().collect();
    sorted.sort();
    let mut h = StableHasher::default();
    h.u32(sorted.len() as u32);
    for (path, contents) in sorted {
        // Lengths first, so that no two different lists hash the same byte stream.
        h.str(path).bytes(&(contents.len() as u64).to_le_bytes()).bytes(contents);
    }
    h.finish()
}
