//! The WGSL library and its composer.
//!
//! Shaders are plain WGSL with one extension: a line `#import common/NAME.wgsl` inlines a module of
//! the shared library (once per shader, dependencies first). Constants that Rust and WGSL share are
//! generated from Rust through [`Defines`], so there is a single source of truth for them.
//!
//! Every module and technique shader is validated with naga in unit tests, so a WGSL error fails
//! `cargo test` rather than a render.

use std::collections::HashSet;
use std::fmt::Write as _;

/// The shared WGSL library, embedded in the binary.
pub const COMMON_MODULES: &[(&str, &str)] = &[
    ("common/math.wgsl", include_str!("common/math.wgsl")),
    ("common/random.wgsl", include_str!("common/random.wgsl")),
    ("common/bvh.wgsl", include_str!("common/bvh.wgsl")),
];

/// Errors of shader composition (always a bug in rtgi's shaders, but reported, not panicked).
#[derive(Debug, thiserror::Error)]
#[error("shader '{shader}': {message}")]
pub struct ShaderError {
    pub shader: String,
    pub message: String,
}

/// Constants generated from Rust and prepended to a composed shader as `const NAME: TYPE = VALUE;`.
#[derive(Clone, Debug, Default)]
pub struct Defines {
    lines: Vec<String>,
}

impl Defines {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn u32(mut self, name: &str, value: u32) -> Self {
        self.lines.push(format!("const {name}: u32 = {value}u;"));
        self
    }

    pub fn i32(mut self, name: &str, value: i32) -> Self {
        self.lines.push(format!("const {name}: i32 = {value}i;"));
        self
    }

    pub fn f32(mut self, name: &str, value: f32) -> Self {
        self.lines.push(format!("const {name}: f32 = {value:?};"));
        self
    }

    pub fn bool(mut self, name: &str, value: bool) -> Self {
        self.lines.push(format!("const {name}: bool = {value};"));
        self
    }
}

fn module_source(path: &str) -> Option<&'static str> {
    COMMON_MODULES.iter().find(|(p, _)| *p == path).map(|(_, s)| *s)
}

fn append_resolved(
    shader: &str,
    source: &str,
    seen: &mut HashSet<String>,
    stack: &mut Vec<String>,
    out: &mut String,
) -> Result<(), ShaderError> {
    let mut body = String::new();
    for line in source.lines() {
        let trimmed = line.trim();
        if let Some(path) = trimmed.strip_prefix("#import ") {
            let path = path.trim().trim_matches('"');
            if stack.iter().any(|p| p == path) {
                return Err(ShaderError {
                    shader: shader.into(),
                    message: format!("import cycle: {} -> {path}", stack.join(" -> ")),
                });
            }
            if seen.insert(path.to_string()) {
                let src = module_source(path).ok_or_else(|| ShaderError {
                    shader: shader.into(),
                    message: format!("unknown module '{path}'"),
                })?;
                stack.push(path.to_string());
                append_resolved(shader, src, seen, stack, out)?;
                stack.pop();
            }
        } else {
            body.push_str(line);
            body.push('\n');
        }
    }
    let _ = writeln!(out, "// ---- {} ----", stack.last().map(String::as_str).unwrap_or(shader));
    out.push_str(&body);
    Ok(())
}

/// Resolves the imports of `source` (named `shader` in errors) and prepends `defines`.
pub fn compose(shader: &str, source: &str, defines: &Defines) -> Result<String, ShaderError> {
    let mut out = String::new();
    for line in &defines.lines {
        out.push_str(line);
        out.push('\n');
    }
    append_resolved(shader, source, &mut HashSet::new(), &mut Vec::new(), &mut out)?;
    Ok(out)
}

/// Composes `source` and creates a shader module from it.
pub fn create_module(
    device: &wgpu::Device,
    shader: &str,
    source: &str,
    defines: &Defines,
) -> Result<wgpu::ShaderModule, ShaderError> {
    let code = compose(shader, source, defines)?;
    Ok(device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(shader),
        source: wgpu::ShaderSource::Wgsl(code.into()),
    }))
}

/// Parses and validates composed WGSL with naga; returns the module for reflection (layout tests).
#[cfg(test)]
pub fn validate(shader: &str, source: &str, defines: &Defines) -> naga::Module {
    let code = compose(shader, source, defines).unwrap_or_else(|e| panic!("{e}"));
    let module = naga::front::wgsl::parse_str(&code)
        .unwrap_or_else(|e| panic!("{shader}: WGSL parse error:\n{}", e.emit_to_string(&code)));
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{shader}: WGSL validation error:\n{}", e.emit_to_string(&code)));
    module
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What a module needs from its includer (globals, callbacks), declared the way a real includer
    /// would, so that such modules are validated too rather than skipped. A module absent here must
    /// validate on its own.
    const INCLUDER_PRELUDES: &[(&str, &str)] = &[(
        "common/bvh.wgsl",
        "@group(0) @binding(0) var<storage, read> bvh_nodes: array<BvhNode>;\n\
         @group(0) @binding(1) var<storage, read> bvh_tris: array<vec4f>;\n\
         fn bvh_alpha_test(triangle: u32, u: f32, v: f32) -> bool { return true; }\n\
         @compute @workgroup_size(1) fn bvh_prelude_main() {\n\
             let r = Ray(vec3f(0.0), vec3f(0.0, 0.0, 1.0));\n\
             let hit = trace_closest(r, 0.0, FLT_MAX);\n\
             let any = trace_any(r, 0.0, FLT_MAX);\n\
         }\n",
    )];

    #[test]
    fn every_common_module_validates_alone() {
        for (path, _) in COMMON_MODULES {
            let prelude = INCLUDER_PRELUDES.iter().find(|(p, _)| p == path).map_or("", |(_, s)| *s);
            validate(path, &format!("#import {path}\n{prelude}"), &Defines::new());
        }
        for (path, _) in INCLUDER_PRELUDES {
            assert!(module_source(path).is_some(), "prelude for unknown module {path}");
        }
    }

    #[test]
    fn imports_are_inlined_once_dependencies_first() {
        let code = compose(
            "t",
            "#import common/random.wgsl\n#import common/math.wgsl\nfn f() {}\n",
            &Defines::new(),
        )
        .unwrap();
        assert_eq!(code.matches("---- common/math.wgsl").count(), 1);
        assert!(compose("t", "#import common/nope.wgsl\n", &Defines::new()).is_err());
        let code = compose("t", "", &Defines::new().u32("N", 3).f32("X", 0.5)).unwrap();
        assert!(code.contains("const N: u32 = 3u;") && code.contains("const X: f32 = 0.5;"));
    }
}
