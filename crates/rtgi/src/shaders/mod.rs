//! The WGSL library and its composer.
//!
//! Shaders are plain WGSL with two extensions: a line `#import common/NAME.wgsl` inlines a module of
//! the shared library (once per shader, dependencies first), and lines `#if NAME` / `#else` / `#endif`
//! keep or drop the lines between them by a bool define (for declarations, whose types WGSL cannot
//! choose by a constant: the BVH's tables as textures or buffers). Constants that Rust and WGSL share
//! are generated from Rust through [`Defines`], so there is a single source of truth for them.
//!
//! Every module and technique shader is validated with naga in unit tests, so a WGSL error fails
//! `cargo test` rather than a render.

use std::collections::HashSet;
use std::fmt::Write as _;

/// The shared WGSL library, embedded in the binary.
pub const COMMON_MODULES: &[(&str, &str)] = &[
    ("common/math.wgsl", include_str!("common/math.wgsl")),
    ("common/linear_texture.wgsl", include_str!("common/linear_texture.wgsl")),
    ("common/random.wgsl", include_str!("common/random.wgsl")),
    ("common/bvh.wgsl", include_str!("common/bvh.wgsl")),
    ("common/color.wgsl", include_str!("common/color.wgsl")),
    ("common/sampling.wgsl", include_str!("common/sampling.wgsl")),
    ("common/brdf.wgsl", include_str!("common/brdf.wgsl")),
    ("common/scene.wgsl", include_str!("common/scene.wgsl")),
    ("common/environment.wgsl", include_str!("common/environment.wgsl")),
    ("common/lights.wgsl", include_str!("common/lights.wgsl")),
    ("common/frame_uniforms.wgsl", include_str!("common/frame_uniforms.wgsl")),
    ("common/frame.wgsl", include_str!("common/frame.wgsl")),
    ("common/light_sampling.wgsl", include_str!("common/light_sampling.wgsl")),
    ("common/direct_light.wgsl", include_str!("common/direct_light.wgsl")),
    ("common/direct_light_prediction.wgsl", include_str!("common/direct_light_prediction.wgsl")),
    ("common/sh.wgsl", include_str!("common/sh.wgsl")),
    ("common/hsh.wgsl", include_str!("common/hsh.wgsl")),
    ("common/sh_lobes.wgsl", include_str!("common/sh_lobes.wgsl")),
    ("common/raster.wgsl", include_str!("common/raster.wgsl")),
    ("common/gbuffer.wgsl", include_str!("common/gbuffer.wgsl")),
    ("common/mesh_of_triangle.wgsl", include_str!("common/mesh_of_triangle.wgsl")),
    ("common/indirect.wgsl", include_str!("common/indirect.wgsl")),
    ("common/ray_differentials.wgsl", include_str!("common/ray_differentials.wgsl")),
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

    /// Whether a constant `name` is defined.
    pub fn has(&self, name: &str) -> bool {
        let prefix = format!("const {name}:");
        self.lines.iter().any(|l| l.starts_with(&prefix))
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

    pub fn vec3u(mut self, name: &str, v: [u32; 3]) -> Self {
        self.lines.push(format!("const {name}: vec3u = vec3u({}u, {}u, {}u);", v[0], v[1], v[2]));
        self
    }

    pub fn vec3f(mut self, name: &str, v: [f32; 3]) -> Self {
        self.lines.push(format!("const {name}: vec3f = vec3f({:?}, {:?}, {:?});", v[0], v[1], v[2]));
        self
    }

    pub fn bool(mut self, name: &str, value: bool) -> Self {
        self.lines.push(format!("const {name}: bool = {value};"));
        self
    }

    /// The value of the bool constant `name`, if defined.
    pub fn bool_value(&self, name: &str) -> Option<bool> {
        let prefix = format!("const {name}: bool = ");
        self.lines.iter().find_map(|l| match l.strip_prefix(&prefix)? {
            "true;" => Some(true),
            "false;" => Some(false),
            _ => None,
        })
    }
}

/// Bool defines a shader that includes `common/bvh.wgsl` gets unless it sets them: the traversal that
/// handles instances and alpha tests (correct for every scene; `GpuScene::bvh_defines` selects the
/// faster one without them where a scene has none), with its tables in textures (`BvhTables`).
const BVH_DEFAULTS: [(&str, bool); 3] =
    [("BVH_INSTANCES", true), ("BVH_ALPHA_TESTS", true), ("BVH_TABLES_IN_BUFFERS", false)];

fn condition(shader: &str, name: &str, defines: &Defines) -> Result<bool, ShaderError> {
    defines
        .bool_value(name)
        .or_else(|| BVH_DEFAULTS.iter().find(|(n, _)| *n == name).map(|(_, v)| *v))
        .ok_or_else(|| ShaderError {
            shader: shader.into(),
            message: format!("#if {name}: no bool define of that name"),
        })
}

fn module_source(path: &str) -> Option<&'static str> {
    COMMON_MODULES.iter().find(|(p, _)| *p == path).map(|(_, s)| *s)
}

fn append_resolved(
    shader: &str,
    source: &str,
    defines: &Defines,
    seen: &mut HashSet<String>,
    stack: &mut Vec<String>,
    out: &mut String,
) -> Result<(), ShaderError> {
    let here = stack.last().map(String::as_str).unwrap_or(shader).to_string();
    let error = |message: String| ShaderError { shader: shader.into(), message };
    let mut body = String::new();
    // Open #if blocks: (whether their condition holds, whether #else was seen).
    let mut blocks: Vec<(bool, bool)> = Vec::new();
    for line in source.lines() {
        let trimmed = line.trim();
        if let Some(name) = trimmed.strip_prefix("#if ") {
            blocks.push((condition(shader, name.trim(), defines)?, false));
            continue;
        }
        if trimmed == "#else" {
            match blocks.last_mut() {
                Some((_, seen_else @ false)) => *seen_else = true,
                _ => return Err(error(format!("{here}: #else without #if"))),
            }
            continue;
        }
        if trimmed == "#endif" {
            if blocks.pop().is_none() {
                return Err(error(format!("{here}: #endif without #if")));
            }
            continue;
        }
        if !blocks.iter().all(|&(holds, in_else)| holds != in_else) {
            continue;
        }
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
                append_resolved(shader, src, defines, seen, stack, out)?;
                stack.pop();
            }
        } else {
            body.push_str(line);
            body.push('\n');
        }
    }
    if !blocks.is_empty() {
        return Err(error(format!("{here}: #if without #endif")));
    }
    let _ = writeln!(out, "// ---- {here} ----");
    out.push_str(&body);
    Ok(())
}

/// Resolves the imports and `#if` blocks of `source` (named `shader` in errors) and prepends
/// `defines`. A shader that includes `common/bvh.wgsl` gets [`BVH_DEFAULTS`] for what it leaves
/// undefined.
pub fn compose(shader: &str, source: &str, defines: &Defines) -> Result<String, ShaderError> {
    let mut out = String::new();
    for line in &defines.lines {
        out.push_str(line);
        out.push('\n');
    }
    let mut seen = HashSet::new();
    append_resolved(shader, source, defines, &mut seen, &mut Vec::new(), &mut out)?;
    if seen.contains("common/bvh.wgsl") {
        for (name, value) in BVH_DEFAULTS {
            if !defines.has(name) {
                out.insert_str(0, &format!("const {name}: bool = {value};\n"));
            }
        }
    }
    Ok(out)
}

/// Composes `source` and creates a shader module from it.
pub fn create_module(
    ctx: &crate::gpu::GpuContext,
    shader: &str,
    source: &str,
    defines: &Defines,
) -> Result<wgpu::ShaderModule, ShaderError> {
    let code = compose(shader, source, defines)?;
    ctx.count_shader_compilation();
    Ok(ctx.device.create_shader_module(wgpu::ShaderModuleDescriptor {
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

    /// Each module is validated on top of `common/frame.wgsl`, which declares every binding and
    /// includer-provided function that library modules may use (e.g. `bvh_nodes`, `bvh_alpha_test`).
    #[test]
    fn every_common_module_validates() {
        // What a module expects its including shader to declare (each says so in its header).
        let provided = |path: &str| match path {
            "common/direct_light_prediction.wgsl" => {
                "fn predicted_light(i: u32) -> Light { return lights[i]; }\n"
            }
            "common/sh_lobes.wgsl" => "fn incident_sh(k: u32) -> vec3f { return vec3f(f32(k)); }\n",
            "common/mesh_of_triangle.wgsl" => {
                "@group(3) @binding(0) var<storage, read> mesh_starts: array<vec2u>;\n"
            }
            _ => "",
        };
        for (path, _) in COMMON_MODULES {
            let source = format!("#import common/frame.wgsl\n#import {path}\n{}", provided(path));
            validate(path, &source, &Defines::new());
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

    #[test]
    fn if_blocks_keep_the_lines_their_define_selects() {
        let source = "a\n#if A\nb\n#if B\nc\n#else\nd\n#endif\n#else\ne\n#endif\nf\n";
        let body = |a: bool, b: bool| {
            let code = compose("t", source, &Defines::new().bool("A", a).bool("B", b)).unwrap();
            code.lines().filter(|l| l.len() == 1).collect::<String>()
        };
        assert_eq!(body(true, true), "abcf");
        assert_eq!(body(true, false), "abdf");
        assert_eq!(body(false, true), "aef");
        assert_eq!(body(false, false), "aef");
        for bad in ["#if A\n", "#endif\n", "#else\n", "#if A\n#else\n#else\n#endif\n", "#if C\n#endif\n"] {
            assert!(compose("t", bad, &Defines::new().bool("A", true)).is_err(), "{bad:?}");
        }
        // The BVH's own switches have defaults (the traversal that is correct for every scene).
        let code = compose("t", "#if BVH_TABLES_IN_BUFFERS\nx\n#else\ny\n#endif\n", &Defines::new()).unwrap();
        assert!(code.lines().any(|l| l == "y") && !code.lines().any(|l| l == "x"));
    }
}

/// Layout checks of `#[repr(C)]` structs against their WGSL twins, through naga reflection.
#[cfg(test)]
pub mod layout {
    /// Asserts that every named WGSL `const` of `module` has the Rust value next to it: enum constants
    /// that Rust and WGSL both use (light kinds, environment kinds, ...) are checked instead of trusted.
    pub fn assert_u32_constants(module: &naga::Module, constants: &[(&str, u32)]) {
        for (name, value) in constants {
            let (_, c) = module
                .constants
                .iter()
                .find(|(_, c)| c.name.as_deref() == Some(*name))
                .unwrap_or_else(|| panic!("WGSL const {name} not found"));
            match module.global_expressions[c.init] {
                naga::Expression::Literal(naga::Literal::U32(v)) => {
                    assert_eq!(v, *value, "WGSL const {name} is {v}, Rust says {value}")
                }
                ref other => panic!("WGSL const {name} is not a u32 literal: {other:?}"),
            }
        }
    }

    /// Size of the WGSL struct `name` and the byte offsets of its members, in declaration order.
    pub fn wgsl_struct(module: &naga::Module, name: &str) -> (u32, Vec<(String, u32)>) {
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).expect("layout");
        for (_, ty) in module.types.iter() {
            if ty.name.as_deref() == Some(name)
                && let naga::TypeInner::Struct { members, span } = &ty.inner
            {
                return (
                    *span,
                    members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset)).collect(),
                );
            }
        }
        panic!("WGSL struct {name} not found");
    }

    /// Asserts that the WGSL struct `name` has `size` bytes and the given member offsets.
    pub fn assert_layout(module: &naga::Module, name: &str, size: usize, offsets: &[(&str, usize)]) {
        let (span, members) = wgsl_struct(module, name);
        assert_eq!(span as usize, size, "size of {name}: WGSL {span}, Rust {size}");
        for (field, offset) in offsets {
            let m = members
                .iter()
                .find(|(n, _)| n == field)
                .unwrap_or_else(|| panic!("{name}.{field} missing in WGSL"));
            assert_eq!(m.1 as usize, *offset, "offset of {name}.{field}: WGSL {}, Rust {offset}", m.1);
        }
    }
}
