//! Optional device capabilities a technique depends on, checked up front so that a missing one is a
//! clear error naming the capability and the technique instead of a wgpu validation panic mid-frame.
//!
//! [`crate::gpu::GpuContext::new`] requests every optional feature listed here that the adapter offers
//! (none is required), so [`require`] only fails where the driver really lacks the capability.

use super::{GpuContext, GpuError};

/// One capability beyond core WebGPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Need {
    /// Additive (or any) blending into 32-bit float render targets (`FLOAT32_BLENDABLE`).
    Float32Blending,
    /// Linear filtering of 32-bit float textures (`FLOAT32_FILTERABLE`).
    Float32Filtering,
    /// Atomic operations on `r32uint` storage textures (`TEXTURE_ATOMIC`).
    TextureAtomics,
    /// 16-bit floats in shaders (`SHADER_F16`).
    ShaderF16,
    /// A storage texture of `format` (2-D, 2-D array or 3-D alike: WebGPU ties storage support to the
    /// format, not the dimension), read-write if `read_write`, else write-only.
    StorageTexture { format: wgpu::TextureFormat, read_write: bool },
}

impl Need {
    /// The device feature this need stands for, if it is one.
    fn feature(self) -> Option<wgpu::Features> {
        match self {
            Need::Float32Blending => Some(wgpu::Features::FLOAT32_BLENDABLE),
            Need::Float32Filtering => Some(wgpu::Features::FLOAT32_FILTERABLE),
            Need::TextureAtomics => Some(wgpu::Features::TEXTURE_ATOMIC),
            Need::ShaderF16 => Some(wgpu::Features::SHADER_F16),
            Need::StorageTexture { .. } => None,
        }
    }

    fn describe(self) -> String {
        match self {
            Need::Float32Blending => "float32 blending (wgpu feature FLOAT32_BLENDABLE)".into(),
            Need::Float32Filtering => "float32 filtering (wgpu feature FLOAT32_FILTERABLE)".into(),
            Need::TextureAtomics => "r32uint texture atomics (wgpu feature TEXTURE_ATOMIC)".into(),
            Need::ShaderF16 => "f16 in shaders (wgpu feature SHADER_F16)".into(),
            Need::StorageTexture { format, read_write } => format!(
                "{} storage textures of format {format:?}",
                if read_write { "read-write" } else { "write-only" }
            ),
        }
    }
}

/// The optional features [`GpuContext::new`] requests when the adapter offers them.
pub(crate) fn optional_features() -> wgpu::Features {
    wgpu::Features::FLOAT32_FILTERABLE
        | wgpu::Features::FLOAT32_BLENDABLE
        | wgpu::Features::TEXTURE_ATOMIC
        | wgpu::Features::SHADER_F16
        // Read-write storage access to rgba32float, for in-place accumulation of radiance; also makes
        // `format_features` report the adapter's real format capabilities.
        | wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES
}

/// What the device can do with `format`: the adapter's own capabilities where the device enabled
/// `TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES`, otherwise what WebGPU guarantees (wgpu validates
/// against the same rule).
pub fn format_features(ctx: &GpuContext, format: wgpu::TextureFormat) -> wgpu::TextureFormatFeatures {
    let features = ctx.device.features();
    if features.contains(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES) {
        ctx.adapter.get_texture_format_features(format)
    } else {
        format.guaranteed_format_features(features)
    }
}

/// Whether the device meets `need`.
pub fn has(ctx: &GpuContext, need: Need) -> bool {
    met(ctx.device.features(), |f| format_features(ctx, f), need)
}

fn met(
    features: wgpu::Features,
    format_features: impl Fn(wgpu::TextureFormat) -> wgpu::TextureFormatFeatures,
    need: Need,
) -> bool {
    use wgpu::TextureFormatFeatureFlags as Flags;
    match need {
        Need::TextureAtomics => {
            features.contains(wgpu::Features::TEXTURE_ATOMIC)
                && format_features(wgpu::TextureFormat::R32Uint)
                    .allowed_usages
                    .contains(wgpu::TextureUsages::STORAGE_ATOMIC)
        }
        Need::StorageTexture { format, read_write } => {
            let f = format_features(format);
            let access = if read_write { Flags::STORAGE_READ_WRITE } else { Flags::STORAGE_WRITE_ONLY };
            f.allowed_usages.contains(wgpu::TextureUsages::STORAGE_BINDING) && f.flags.contains(access)
        }
        other => other.feature().is_some_and(|f| features.contains(f)),
    }
}

/// Checks that the device meets every one of `needs` of `who` (a technique or pass name); the error
/// lists every missing capability, the adapter and `who`.
pub fn require(ctx: &GpuContext, needs: &[Need], who: &str) -> Result<(), GpuError> {
    check(ctx.device.features(), |f| format_features(ctx, f), needs, who, &ctx.summary.name)
}

fn check(
    features: wgpu::Features,
    format_features: impl Fn(wgpu::TextureFormat) -> wgpu::TextureFormatFeatures,
    needs: &[Need],
    who: &str,
    adapter: &str,
) -> Result<(), GpuError> {
    let missing: Vec<String> =
        needs.iter().filter(|n| !met(features, &format_features, **n)).map(|n| n.describe()).collect();
    if missing.is_empty() {
        return Ok(());
    }
    Err(GpuError::MissingFeature { who: who.into(), missing: missing.join(", "), adapter: adapter.into() })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn guaranteed(features: wgpu::Features) -> impl Fn(wgpu::TextureFormat) -> wgpu::TextureFormatFeatures {
        move |f| f.guaranteed_format_features(features)
    }

    #[test]
    fn missing_features_are_named_with_the_technique() {
        let none = wgpu::Features::empty();
        let needs = [
            Need::Float32Blending,
            Need::TextureAtomics,
            Need::StorageTexture { format: wgpu::TextureFormat::Rgba16Float, read_write: false },
        ];
        let e = check(none, guaranteed(none), &needs, "voxel-gi", "test adapter").unwrap_err().to_string();
        assert_eq!(
            e,
            "voxel-gi needs float32 blending (wgpu feature FLOAT32_BLENDABLE), r32uint texture atomics \
             (wgpu feature TEXTURE_ATOMIC), which the device on 'test adapter' does not offer"
        );
        // rgba8unorm is never a read-write storage format in WebGPU's guarantees.
        let rw = Need::StorageTexture { format: wgpu::TextureFormat::Rgba8Unorm, read_write: true };
        let e = check(none, guaranteed(none), &[rw], "t", "a").unwrap_err().to_string();
        assert!(e.contains("read-write storage textures of format Rgba8Unorm"), "{e}");
        let all = wgpu::Features::FLOAT32_BLENDABLE | wgpu::Features::TEXTURE_ATOMIC;
        check(all, guaranteed(all), &needs, "voxel-gi", "a").expect("every need met");
    }

    /// On the real device: what `GpuContext::new` requested is what `require` sees.
    #[test]
    fn require_agrees_with_the_device() {
        let ctx = GpuContext::new(&crate::gpu::GpuOptions::default()).expect("a GPU adapter (lavapipe)");
        let write_only = Need::StorageTexture { format: wgpu::TextureFormat::Rgba32Float, read_write: false };
        require(&ctx, &[write_only], "mips").expect("core WebGPU storage format");
        for need in [Need::Float32Blending, Need::Float32Filtering, Need::TextureAtomics, Need::ShaderF16] {
            let offered = ctx.adapter.features().contains(need.feature().expect("a feature"));
            let result = require(&ctx, &[need], "probe");
            assert_eq!(result.is_ok(), offered && has(&ctx, need), "{need:?}: {result:?}");
            if let Err(e) = result {
                assert!(
                    e.to_string().starts_with("probe needs") && e.to_string().contains(&ctx.summary.name)
                );
            }
        }
    }
}
