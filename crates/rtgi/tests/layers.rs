//! Imports run one way: scene → gpu → frame → techniques → post → renderer. This test reads every source file
//! of the library and fails when non-test code names a module of a higher layer (`crate::x` paths, in
//! `use` declarations or inline). Test code (files named `tests.rs`/`*_tests.rs`/`test_*.rs` and
//! everything after a file's first `#[cfg(test)]`) may reach up: tests assemble whole pipelines.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The layer of each top-level module; a module may import its own layer and the ones below.
const LAYERS: [(&str, u32); 23] = [
    ("error", 0),
    ("stable_hash", 0),
    ("cache", 0),
    ("scene", 0),
    ("image", 0),
    ("montage", 0),
    ("params", 0),
    ("sh", 0),
    ("hsh", 0),
    ("sequences", 0),
    ("metrics", 0),
    ("shaders", 1),
    ("gpu", 1),
    ("frame", 2),
    ("techniques", 3),
    // Post-processes of any technique's image, which the renderer applies.
    ("post", 4),
    ("renderer", 5),
    ("render", 5),
    ("reference", 5),
    ("testing", 5),
    ("bench", 6),
    // The crate root re-exports `SceneError`; naming it is naming `error`.
    ("SceneError", 0),
    ("lib", 6),
];

fn source_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("read src") {
        let path = entry.expect("dir entry").path();
        if path.is_dir() {
            source_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The first path segments after every `crate::` in `code` (`crate::{a, b::c}` gives a and b).
fn crate_references(code: &str) -> Vec<String> {
    let mut refs = Vec::new();
    for (i, _) in code.match_indices("crate::") {
        // `$crate::` in macros refers to the macro's own crate paths the same way.
        let rest = &code[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            for item in group[..end].split(',') {
                let name: String =
                    item.trim().chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                if !name.is_empty() {
                    refs.push(name);
                }
            }
        } else {
            let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            refs.push(name);
        }
    }
    refs
}

fn is_test_file(path: &Path) -> bool {
    let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("");
    name == "tests" || name.ends_with("_tests") || name.starts_with("test_") || name == "testing"
}

#[test]
fn no_module_imports_a_layer_above_it() {
    let layers: BTreeMap<&str, u32> = LAYERS.into_iter().collect();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    source_files(&src, &mut files);
    files.sort();
    assert!(files.len() > 50, "found only {} source files under {}", files.len(), src.display());
    let mut violations = Vec::new();
    for file in &files {
        let relative = file.strip_prefix(&src).expect("under src");
        let top = relative.components().next().and_then(|c| c.as_os_str().to_str()).unwrap_or("");
        let module = top.trim_end_matches(".rs");
        let own = *layers.get(module).unwrap_or_else(|| panic!("{module}: add the module to LAYERS"));
        if is_test_file(file) || module == "lib" {
            continue;
        }
        let text = std::fs::read_to_string(file).expect("read source");
        let code = text.split("#[cfg(test)]").next().unwrap_or("");
        for line in code.lines().filter(|l| !l.trim_start().starts_with("//")) {
            for name in crate_references(line) {
                let Some(&layer) = layers.get(name.as_str()) else { continue };
                if layer > own {
                    violations.push(format!(
                        "{}: `{}` imports {name} (layer {layer} > {own})",
                        relative.display(),
                        line.trim()
                    ));
                }
            }
        }
    }
    assert!(violations.is_empty(), "imports that run up a layer:\n{}", violations.join("\n"));
}

#[test]
fn the_reference_parser_sees_grouped_and_inline_paths() {
    assert_eq!(crate_references("use crate::{frame::X, gpu};"), ["frame", "gpu"]);
    assert_eq!(
        crate_references("let x: crate::render::RenderError = y; crate::techniques::f()"),
        ["render", "techniques"]
    );
}
