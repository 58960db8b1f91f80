//! The byte level of a glTF asset: the GLB container, URIs (data URIs and relative paths) and base64.
//!
//! Written by hand rather than taken from the `gltf` crate because its GLB reader computes
//! `header.length - 12` without checking (an overflow panic on a short header in debug builds) and its
//! import helpers report failures without saying which buffer or image was at fault.

use std::path::{Path, PathBuf};

/// The two chunks of a binary glTF file.
pub(super) struct Glb<'a> {
    pub json: &'a [u8],
    pub bin: Option<&'a [u8]>,
}

const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// Whether `bytes` start like a GLB file (as opposed to glTF JSON).
pub(super) fn is_glb(bytes: &[u8]) -> bool {
    bytes.starts_with(GLB_MAGIC)
}

fn read_u32(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Splits a GLB file into its JSON and BIN chunks, checking every length against the data present, so
/// that a truncated download is reported as such instead of as a confusing JSON or accessor error.
pub(super) fn parse_glb(bytes: &[u8]) -> Result<Glb<'_>, String> {
    let truncated =
        |what: &str| format!("truncated or malformed .glb: {what} (file is {} bytes)", bytes.len());
    let version = read_u32(bytes, 4).ok_or_else(|| truncated("incomplete 12-byte header"))?;
    let length = read_u32(bytes, 8).ok_or_else(|| truncated("incomplete 12-byte header"))?;
    if version != 2 {
        return Err(format!("binary glTF version {version} is not supported (rtgi reads glTF 2.0)"));
    }
    let length = length as usize;
    if length > bytes.len() {
        return Err(truncated(&format!("header declares {length} bytes")));
    }
    if length < 12 {
        return Err(truncated(&format!("header declares an impossible length of {length} bytes")));
    }
    let data = &bytes[..length];

    let mut json = None;
    let mut bin = None;
    let mut at = 12usize;
    while at < data.len() {
        let chunk_len =
            read_u32(data, at).ok_or_else(|| truncated(&format!("incomplete chunk header at byte {at}")))?;
        let chunk_type = read_u32(data, at + 4)
            .ok_or_else(|| truncated(&format!("incomplete chunk header at byte {at}")))?;
        let start = at + 8;
        let end =
            start.checked_add(chunk_len as usize).filter(|&end| end <= data.len()).ok_or_else(|| {
                truncated(&format!(
                    "chunk at byte {at} declares {chunk_len} bytes but only {} remain",
                    data.len().saturating_sub(start)
                ))
            })?;
        let chunk = &data[start..end];
        match chunk_type {
            CHUNK_JSON if json.is_none() && at == 12 => json = Some(chunk),
            CHUNK_JSON => return Err(truncated("unexpected second JSON chunk")),
            CHUNK_BIN if json.is_some() && bin.is_none() => bin = Some(chunk),
            CHUNK_BIN => return Err(truncated("BIN chunk in the wrong place")),
            // The spec says readers must ignore chunks of unknown types.
            _ => {}
        }
        // Chunks are 4-byte aligned; a writer that forgets the padding is tolerated at the very end.
        at = end.checked_add(3).map_or(usize::MAX, |e| e & !3);
    }
    let json = json.ok_or_else(|| truncated("no JSON chunk"))?;
    Ok(Glb { json, bin })
}

/// What a URI in a glTF file refers to.
pub(super) enum UriTarget {
    /// Decoded bytes of a `data:` URI, with the media type it declared.
    Data { bytes: Vec<u8>, mime: String },
    /// A file path (percent-decoded), relative to the glTF file unless absolute.
    File(PathBuf),
}

/// Interprets a glTF URI. Only `data:` URIs and relative (or absolute) file paths are supported: rtgi
/// never touches the network, and saying so is better than a confusing "file not found".
pub(super) fn resolve_uri(uri: &str, base_dir: &Path) -> Result<UriTarget, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (header, payload) =
            rest.split_once(',').ok_or_else(|| "malformed data URI (no ',' separator)".to_string())?;
        let Some(mime) = header.strip_suffix(";base64") else {
            return Err("data URI is not base64-encoded (only base64 data URIs are supported)".into());
        };
        let bytes = decode_base64(payload).map_err(|e| format!("malformed base64 in data URI: {e}"))?;
        return Ok(UriTarget::Data { bytes, mime: mime.to_string() });
    }
    // A scheme is letters, digits, '+', '-', '.' before ':' — but a one-letter "scheme" is a Windows
    // drive letter, which we treat as a path.
    if let Some((scheme, _)) = uri.split_once(':') {
        let is_scheme = scheme.len() > 1
            && scheme.chars().all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
            && scheme.starts_with(|c: char| c.is_ascii_alphabetic());
        if is_scheme {
            return Err(format!(
                "URI scheme '{scheme}:' is not supported (only relative file paths and data URIs)"
            ));
        }
    }
    let decoded = percent_decode(uri)?;
    Ok(UriTarget::File(base_dir.join(decoded)))
}

/// Reads a file named by a glTF URI, with an error that names both the URI and the resolved path.
pub(super) fn read_uri_file(uri: &str, file: &Path) -> Result<Vec<u8>, String> {
    std::fs::read(file).map_err(|e| {
        let why = if e.kind() == std::io::ErrorKind::NotFound {
            "file not found".to_string()
        } else {
            e.to_string()
        };
        format!("cannot read '{uri}' ({}): {why}", file.display())
    })
}

/// Decodes `%XX` escapes; glTF URIs are RFC 3986 references, so a space is written `%20`.
fn percent_decode(s: &str) -> Result<String, String> {
    if !s.contains('%') {
        return Ok(s.to_string());
    }
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while let Some(&b) = bytes.get(i) {
        if b == b'%' {
            let hex = bytes
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or_else(|| format!("malformed percent escape in URI '{s}'"))?;
            out.push(hex);
            i += 3;
        } else {
            out.push(b);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| format!("URI '{s}' does not decode to UTF-8"))
}

/// Standard base64 (RFC 4648 alphabet), padding optional, ASCII whitespace ignored.
pub(super) fn decode_base64(s: &str) -> Result<Vec<u8>, String> {
    fn value(c: u8) -> Option<u32> {
        match c {
            b'A'..=b'Z' => Some((c - b'A') as u32),
            b'a'..=b'z' => Some((c - b'a') as u32 + 26),
            b'0'..=b'9' => Some((c - b'0') as u32 + 52),
            b'+' | b'-' => Some(62),
            b'/' | b'_' => Some(63),
            _ => None,
        }
    }
    let mut out = Vec::with_capacity(s.len() / 4 * 3 + 3);
    let mut acc = 0u32;
    let mut bits = 0u32;
    let mut padding = false;
    for (i, c) in s.bytes().enumerate() {
        if c.is_ascii_whitespace() {
            continue;
        }
        if c == b'=' {
            padding = true;
            continue;
        }
        if padding {
            return Err(format!("data after '=' padding at character {i}"));
        }
        let v = value(c).ok_or_else(|| format!("invalid character {:?} at position {i}", c as char))?;
        acc = (acc << 6) | v;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    if bits >= 6 {
        return Err("truncated base64 data".into());
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trips_known_vectors() {
        assert_eq!(decode_base64("").unwrap(), b"");
        assert_eq!(decode_base64("Zg==").unwrap(), b"f");
        assert_eq!(decode_base64("Zm8=").unwrap(), b"fo");
        assert_eq!(decode_base64("Zm9v").unwrap(), b"foo");
        assert_eq!(decode_base64("Zm9vYmFy").unwrap(), b"foobar");
        assert_eq!(decode_base64("Zm9vYg").unwrap(), b"foob");
        assert!(decode_base64("Zm9v!").is_err());
        assert!(decode_base64("Z").is_err());
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b.bin").unwrap(), "a b.bin");
        assert!(percent_decode("a%2").is_err());
    }

    #[test]
    fn glb_parser_never_panics_on_prefixes() {
        let mut glb = b"glTF".to_vec();
        glb.extend_from_slice(&2u32.to_le_bytes());
        glb.extend_from_slice(&28u32.to_le_bytes());
        glb.extend_from_slice(&8u32.to_le_bytes());
        glb.extend_from_slice(&CHUNK_JSON.to_le_bytes());
        glb.extend_from_slice(b"{}      ");
        assert!(parse_glb(&glb).is_ok());
        for n in 0..glb.len() {
            assert!(parse_glb(&glb[..n]).is_err(), "prefix {n}");
        }
    }
}
