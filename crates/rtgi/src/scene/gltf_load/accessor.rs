//! Buffers, buffer views and accessors, read with every range checked against the bytes present.
//!
//! The `gltf` crate's reader trusts the document once it has been validated, and its validator itself
//! indexes arrays without bounds checks; a loader for files from the wild must check each offset,
//! stride and count itself so that a bad file becomes an error naming the accessor, not a panic.

use std::borrow::Cow;

use glam::{Vec2, Vec3, Vec4};
use gltf::json;
use gltf::json::accessor::{ComponentType, Type};
use gltf::json::validation::Checked;

use super::Loader;
use super::container::{UriTarget, read_uri_file, resolve_uri};

/// An upper bound on the bytes one accessor may expand to, so that a forged `count` in an accessor
/// without a buffer view (which means "all zeros") cannot make us allocate terabytes.
const MAX_ACCESSOR_BYTES: usize = 1 << 31;

/// An accessor's elements, tightly packed (stride removed, sparse substitutions applied).
struct Packed {
    bytes: Vec<u8>,
    component: ComponentType,
    components: usize,
    normalized: bool,
    count: usize,
}

fn component_size(c: ComponentType) -> usize {
    match c {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

/// One component as a float, applying glTF's normalisation rules for normalised integer data
/// (`KHR_mesh_quantization` and normalised UVs rely on them).
fn decode_float(c: ComponentType, b: &[u8], normalized: bool) -> f32 {
    let mut x = [0u8; 4];
    for (d, s) in x.iter_mut().zip(b) {
        *d = *s;
    }
    match c {
        ComponentType::F32 => f32::from_le_bytes(x),
        ComponentType::U32 => u32::from_le_bytes(x) as f32,
        ComponentType::I8 => {
            let v = x[0] as i8 as f32;
            if normalized { (v / 127.0).max(-1.0) } else { v }
        }
        ComponentType::U8 => {
            let v = x[0] as f32;
            if normalized { v / 255.0 } else { v }
        }
        ComponentType::I16 => {
            let v = i16::from_le_bytes([x[0], x[1]]) as f32;
            if normalized { (v / 32767.0).max(-1.0) } else { v }
        }
        ComponentType::U16 => {
            let v = u16::from_le_bytes([x[0], x[1]]) as f32;
            if normalized { v / 65535.0 } else { v }
        }
    }
}

fn decode_uint(c: ComponentType, b: &[u8]) -> Option<u32> {
    match c {
        ComponentType::U8 => b.first().map(|&x| x as u32),
        ComponentType::U16 => b.get(..2).map(|x| u16::from_le_bytes([x[0], x[1]]) as u32),
        ComponentType::U32 => b.get(..4).map(|x| u32::from_le_bytes([x[0], x[1], x[2], x[3]])),
        _ => None,
    }
}

fn to_usize(v: u64, what: &str) -> Result<usize, String> {
    usize::try_from(v).map_err(|_| format!("{what} {v} is too large"))
}

impl<'a> Loader<'a> {
    /// The bytes of buffer `index`, loaded on first use so that buffers only referenced by things rtgi
    /// ignores (animations, skins) need not exist.
    pub(super) fn buffer(&self, index: usize) -> Result<&[u8], String> {
        let cell = self.buffers.get(index).ok_or_else(|| {
            format!("buffer {index} does not exist (the file has {} buffers)", self.root.buffers.len())
        })?;
        if let Some(bytes) = cell.get() {
            return Ok(bytes);
        }
        let bytes = self.load_buffer(index)?;
        let bytes = cell.get_or_init(|| bytes);
        Ok(bytes)
    }

    fn load_buffer(&self, index: usize) -> Result<Cow<'a, [u8]>, String> {
        let buffer = self.root.buffers.get(index).ok_or_else(|| format!("buffer {index} does not exist"))?;
        let label = match &buffer.name {
            Some(name) => format!("buffer {index} '{name}'"),
            None => format!("buffer {index}"),
        };
        let bytes: Cow<'a, [u8]> = match &buffer.uri {
            None => match self.bin {
                Some(bin) if index == 0 => Cow::Borrowed(bin),
                Some(_) => {
                    return Err(format!(
                        "{label} has no URI, but only buffer 0 may refer to the GLB BIN chunk"
                    ));
                }
                None => return Err(format!("{label} has no URI and the file has no GLB BIN chunk")),
            },
            Some(uri) => match resolve_uri(uri, &self.base_dir).map_err(|e| format!("{label}: {e}"))? {
                UriTarget::Data { bytes, .. } => Cow::Owned(bytes),
                UriTarget::File(file) => {
                    Cow::Owned(read_uri_file(uri, &file).map_err(|e| format!("{label}: {e}"))?)
                }
            },
        };
        let declared = buffer.byte_length.0;
        if (bytes.len() as u64) < declared {
            return Err(format!(
                "{label} is too short: byteLength is {declared} but only {} bytes are present",
                bytes.len()
            ));
        }
        Ok(bytes)
    }

    /// The bytes of buffer view `index` and its declared stride.
    fn view(&self, index: usize) -> Result<(&[u8], Option<usize>), String> {
        let view = self.root.buffer_views.get(index).ok_or_else(|| {
            format!(
                "buffer view {index} does not exist (the file has {} views)",
                self.root.buffer_views.len()
            )
        })?;
        let buffer = self.buffer(view.buffer.value()).map_err(|e| format!("buffer view {index}: {e}"))?;
        let offset = to_usize(view.byte_offset.map_or(0, |o| o.0), "byteOffset")?;
        let length = to_usize(view.byte_length.0, "byteLength")?;
        let bytes = offset.checked_add(length).and_then(|end| buffer.get(offset..end)).ok_or_else(|| {
            format!(
                "buffer view {index} (bytes {offset}..{}) lies outside buffer {} ({} bytes)",
                offset as u128 + length as u128,
                view.buffer.value(),
                buffer.len()
            )
        })?;
        Ok((bytes, view.byte_stride.map(|s| s.0)))
    }

    /// The raw bytes of buffer view `index`, for images stored in the buffer.
    pub(super) fn view_bytes(&self, index: usize) -> Result<&[u8], String> {
        self.view(index).map(|(bytes, _)| bytes)
    }

    fn packed(&self, index: usize, what: &str) -> Result<Packed, String> {
        let label = format!("accessor {index} ({what})");
        let acc = self.root.accessors.get(index).ok_or_else(|| {
            format!("{label} does not exist (the file has {} accessors)", self.root.accessors.len())
        })?;
        let component = match acc.component_type {
            Checked::Valid(json::accessor::GenericComponentType(c)) => c,
            Checked::Invalid => return Err(format!("{label}: invalid componentType")),
        };
        let components = match acc.type_ {
            Checked::Valid(Type::Scalar) => 1,
            Checked::Valid(Type::Vec2) => 2,
            Checked::Valid(Type::Vec3) => 3,
            Checked::Valid(Type::Vec4) => 4,
            Checked::Valid(t) => return Err(format!("{label}: matrix type {t:?} is not valid here")),
            Checked::Invalid => return Err(format!("{label}: invalid type")),
        };
        let count = to_usize(acc.count.0, "count")?;
        let elem = component_size(component) * components;
        let total = count
            .checked_mul(elem)
            .filter(|&t| t <= MAX_ACCESSOR_BYTES)
            .ok_or_else(|| format!("{label}: count {count} is implausibly large"))?;
        let mut bytes;
        if let Some(view_index) = acc.buffer_view {
            let (view, stride) = self.view(view_index.value()).map_err(|e| format!("{label}: {e}"))?;
            let stride = stride.unwrap_or(elem);
            if stride < elem {
                return Err(format!(
                    "{label}: byteStride {stride} is smaller than an element ({elem} bytes)"
                ));
            }
            let offset = to_usize(acc.byte_offset.map_or(0, |o| o.0), "byteOffset")?;
            if count > 0 {
                let needed = stride
                    .checked_mul(count - 1)
                    .and_then(|x| x.checked_add(offset))
                    .and_then(|x| x.checked_add(elem));
                if needed.is_none_or(|n| n > view.len()) {
                    return Err(format!(
                        "{label}: {count} elements of {elem} bytes (stride {stride}, offset {offset}) do not \
                         fit in buffer view {} of {} bytes",
                        view_index.value(),
                        view.len()
                    ));
                }
            }
            bytes = Vec::with_capacity(total);
            for i in 0..count {
                let start = offset + i * stride;
                let src = view
                    .get(start..start + elem)
                    .ok_or_else(|| format!("{label}: element {i} out of range"))?;
                bytes.extend_from_slice(src);
            }
        } else {
            // No buffer view: the accessor is all zeros (usually with sparse substitutions).
            bytes = vec![0u8; total];
        }
        if let Some(sparse) = &acc.sparse {
            let n = to_usize(sparse.count.0, "sparse count")?;
            let index_type = match sparse.indices.component_type {
                Checked::Valid(json::accessor::IndexComponentType(c)) => c,
                Checked::Invalid => return Err(format!("{label}: invalid sparse index componentType")),
            };
            let index_size = component_size(index_type);
            let (iview, _) = self
                .view(sparse.indices.buffer_view.value())
                .map_err(|e| format!("{label}: sparse indices: {e}"))?;
            let (vview, _) = self
                .view(sparse.values.buffer_view.value())
                .map_err(|e| format!("{label}: sparse values: {e}"))?;
            let ioff = to_usize(sparse.indices.byte_offset.0, "byteOffset")?;
            let voff = to_usize(sparse.values.byte_offset.0, "byteOffset")?;
            for k in 0..n {
                let ib = k
                    .checked_mul(index_size)
                    .and_then(|x| x.checked_add(ioff))
                    .and_then(|s| iview.get(s..s.checked_add(index_size)?))
                    .ok_or_else(|| format!("{label}: sparse index {k} lies outside its buffer view"))?;
                let target = decode_uint(index_type, ib)
                    .ok_or_else(|| format!("{label}: sparse indices must be unsigned integers"))?
                    as usize;
                let src = k
                    .checked_mul(elem)
                    .and_then(|x| x.checked_add(voff))
                    .and_then(|s| vview.get(s..s.checked_add(elem)?))
                    .ok_or_else(|| format!("{label}: sparse value {k} lies outside its buffer view"))?;
                let dst = bytes
                    .get_mut(target.saturating_mul(elem)..target.saturating_add(1).saturating_mul(elem))
                    .ok_or_else(|| {
                        format!("{label}: sparse index {target} out of range ({count} elements)")
                    })?;
                dst.copy_from_slice(src);
            }
        }
        Ok(Packed { bytes, component, components, normalized: acc.normalized, count })
    }

    /// Reads a float attribute with `n` components per element.
    fn floats(&self, index: usize, n: usize, what: &str) -> Result<Vec<f32>, String> {
        let p = self.packed(index, what)?;
        if p.components != n {
            return Err(format!(
                "accessor {index} ({what}) has {} components per element, expected {n}",
                p.components
            ));
        }
        let size = component_size(p.component);
        Ok(p.bytes.chunks_exact(size).map(|c| decode_float(p.component, c, p.normalized)).collect())
    }

    pub(super) fn read_vec2(&self, index: usize, what: &str) -> Result<Vec<Vec2>, String> {
        Ok(self.floats(index, 2, what)?.chunks_exact(2).map(Vec2::from_slice).collect())
    }

    pub(super) fn read_vec3(&self, index: usize, what: &str) -> Result<Vec<Vec3>, String> {
        Ok(self.floats(index, 3, what)?.chunks_exact(3).map(Vec3::from_slice).collect())
    }

    pub(super) fn read_vec4(&self, index: usize, what: &str) -> Result<Vec<Vec4>, String> {
        Ok(self.floats(index, 4, what)?.chunks_exact(4).map(Vec4::from_slice).collect())
    }

    /// Reads animation key times, which the spec requires to be float scalars.
    pub(super) fn read_times(&self, index: usize, what: &str) -> Result<Vec<f32>, String> {
        if let Some(acc) = self.root.accessors.get(index) {
            let is_float = matches!(
                acc.component_type,
                Checked::Valid(json::accessor::GenericComponentType(ComponentType::F32))
            );
            if !is_float || acc.type_ != Checked::Valid(Type::Scalar) {
                return Err(format!(
                    "accessor {index} ({what}) must hold float scalars (key times in seconds)"
                ));
            }
        }
        self.floats(index, 1, what)
    }

    /// Reads triangle indices (unsigned scalar integers).
    pub(super) fn read_indices(&self, index: usize, what: &str) -> Result<Vec<u32>, String> {
        // Check the type first: a float index accessor would otherwise be reported as a size problem.
        if let Some(acc) = self.root.accessors.get(index) {
            let is_uint = matches!(
                acc.component_type,
                Checked::Valid(json::accessor::GenericComponentType(
                    ComponentType::U8 | ComponentType::U16 | ComponentType::U32
                ))
            );
            if !is_uint || acc.type_ != Checked::Valid(Type::Scalar) {
                return Err(format!("accessor {index} ({what}) must hold unsigned integer scalars"));
            }
        }
        let p = self.packed(index, what)?;
        if p.components != 1
            || !matches!(p.component, ComponentType::U8 | ComponentType::U16 | ComponentType::U32)
        {
            return Err(format!(
                "accessor {index} ({what}) must hold unsigned integer scalars (it has {} × {:?})",
                p.components, p.component
            ));
        }
        let size = component_size(p.component);
        let out: Vec<u32> = p.bytes.chunks_exact(size).filter_map(|c| decode_uint(p.component, c)).collect();
        debug_assert_eq!(out.len(), p.count);
        Ok(out)
    }

    /// The number of elements an accessor declares, for consistency checks between attributes.
    pub(super) fn accessor_count(&self, index: usize) -> Option<u64> {
        self.root.accessors.get(index).map(|a| a.count.0)
    }
}
