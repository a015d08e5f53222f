//! Reading a glTF file and the bytes it refers to: the JSON (a `.gltf`, or a `.glb`'s
//! first chunk, its chunks split here with every length checked), validated by the
//! `gltf` crate, and each buffer's bytes (the GLB's binary chunk, a `data:` URI, or a
//! file beside the glTF, opened through [`crate::io`]). Memory is checked before each
//! allocation; a required extension ember does not read is an error.

use std::path::{Path, PathBuf};

use base64::Engine;
use gltf::Document;

use crate::io::{InputFile, ReadError};
use crate::limits::{check_fits, human_bytes};

/// Most bytes of memory one byte of glTF JSON costs while parsing: the text and the
/// `gltf` crate's document of it (maps and strings per object).
pub const MEMORY_PER_JSON_BYTE: u64 = 16;

/// The extensions ember reads; a file that requires another is refused.
pub const SUPPORTED_EXTENSIONS: [&str; 7] = [
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_texture_transform",
    "KHR_mesh_quantization",
];

/// The supported extensions that the `gltf` crate has no feature for: ember's accessor
/// reader takes the integer vertex attributes `KHR_mesh_quantization` allows.
const EXTENSIONS_READ_HERE: [&str; 1] = ["KHR_mesh_quantization"];

/// A glTF document with its buffers' bytes and the folder its URIs are relative to.
pub struct Source {
    /// The file, for messages.
    pub path: PathBuf,
    pub document: Document,
    /// One per buffer of the document, each at least its declared `byteLength`.
    pub buffers: Vec<Vec<u8>>,
    pub folder: PathBuf,
    /// Extensions the file uses that ember does not read, for one warning each.
    pub unsupported: Vec<String>,
}

/// The GLB header's magic: ASCII `glTF`.
const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// Reads `path` (a `.gltf` or `.glb`) and every buffer it names.
pub fn read(path: &Path) -> Result<Source, String> {
    let input = InputFile::open(path).map_err(|e| e.reason)?;
    let what = format!("the file ({})", human_bytes(input.len()));
    check_fits(&what, input.len())?;
    let bytes = input.read_all().map_err(|e| e.reason)?;
    let (json, bin) = if bytes.starts_with(GLB_MAGIC) {
        split_glb(&bytes)?
    } else {
        (&bytes[..], None)
    };
    check_fits(
        "parsing its JSON",
        (json.len() as u64).saturating_mul(MEMORY_PER_JSON_BYTE),
    )?;
    let mut root = gltf::json::Root::from_slice(json).map_err(|e| format!("invalid JSON: {e}"))?;
    let unsupported = check_extensions(&root)?;
    check_attribute_accessors(&root)?;
    check_image_sources(&root)?;
    // Read here, not by the `gltf` crate, whose validation would refuse them.
    root.extensions_required
        .retain(|name| !EXTENSIONS_READ_HERE.contains(&name.as_str()));
    let document = Document::from_json(root).map_err(validation_message)?;
    let folder = path.parent().unwrap_or(Path::new("")).to_path_buf();
    // The binary chunk becomes a buffer in the file's own allocation, not a copy.
    let bin_at = bin.map(|chunk| {
        (
            chunk.as_ptr() as usize - bytes.as_ptr() as usize,
            chunk.len(),
        )
    });
    let bin = bin_at.map(|(start, length)| {
        let mut owned = bytes;
        owned.truncate(start + length);
        owned.drain(..start);
        owned
    });
    let buffers = read_buffers(&document, &folder, bin)?;
    Ok(Source {
        path: path.to_owned(),
        document,
        buffers,
        folder,
        unsupported,
    })
}

/// A GLB's JSON chunk and its binary chunk if it has one, after checking the header
/// and that no length points past the file.
fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>), String> {
    let word = |at: usize| -> Option<u32> {
        let b = bytes.get(at..at + 4)?;
        Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let truncated = |what: &str| format!("the GLB is truncated: it ends inside {what}");
    let version = word(4).ok_or_else(|| truncated("its header"))?;
    if version != 2 {
        return Err(format!(
            "GLB version {version}: ember reads glTF 2.0 (version 2)"
        ));
    }
    let declared = word(8).ok_or_else(|| truncated("its header"))? as usize;
    if declared > bytes.len() {
        return Err(format!(
            "the GLB header says {declared} bytes, but the file has {}",
            bytes.len()
        ));
    }
    let bytes = &bytes[..declared];
    let chunk = |at: usize, what: &str| -> Result<Option<(u32, &[u8])>, String> {
        if at >= bytes.len() {
            return Ok(None);
        }
        let (Some(length), Some(kind)) = (word(at), word(at + 4)) else {
            return Err(truncated(&format!("the header of its {what} chunk")));
        };
        let start = at + 8;
        let end = start
            .checked_add(length as usize)
            .filter(|&end| end <= bytes.len())
            .ok_or_else(|| {
                format!(
                    "the GLB's {what} chunk says {length} bytes, but only {} follow it",
                    bytes.len().saturating_sub(start)
                )
            })?;
        Ok(Some((kind, &bytes[start..end])))
    };
    let json = match chunk(12, "first")? {
        Some((CHUNK_JSON, json)) => json,
        Some((kind, _)) => {
            return Err(format!(
                "the GLB's first chunk is of type {kind:#010x}, not JSON"
            ))
        }
        None => return Err(truncated("its header")),
    };
    // Chunks start on 4-byte boundaries (the JSON is padded with spaces).
    let next = (12 + 8 + json.len()).next_multiple_of(4);
    let bin = match chunk(next, "second")? {
        Some((CHUNK_BIN, bin)) => Some(bin),
        // Chunks of other types are to be ignored, as the specification says.
        _ => None,
    };
    Ok((json, bin))
}

/// The first of the `gltf` crate's validation errors, on one line.
fn validation_message(e: gltf::Error) -> String {
    match e {
        gltf::Error::Validation(errors) => {
            let more = match errors.len() {
                0 | 1 => String::new(),
                n => format!(" (and {} more problems)", n - 1),
            };
            match errors.first() {
                Some((path, error)) => format!("invalid glTF: {path}: {error}{more}"),
                None => "invalid glTF".into(),
            }
        }
        e => format!("invalid glTF: {e}"),
    }
}

/// Refuses a file that requires an extension ember does not read; returns those it
/// uses without requiring them.
fn check_extensions(root: &gltf::json::Root) -> Result<Vec<String>, String> {
    let supported = |name: &str| SUPPORTED_EXTENSIONS.contains(&name);
    if let Some(name) = root.extensions_required.iter().find(|n| !supported(n)) {
        return Err(format!(
            "it requires the extension {name}, which ember does not read (ember reads {})",
            SUPPORTED_EXTENSIONS.join(", ")
        ));
    }
    Ok(root
        .extensions_used
        .iter()
        .filter(|n| !supported(n))
        .cloned()
        .collect())
}

/// Refuses a primitive attribute naming an accessor that does not exist, before the
/// `gltf` crate's validation, which indexes the accessors by it unchecked.
fn check_attribute_accessors(root: &gltf::json::Root) -> Result<(), String> {
    let count = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(index) = primitive.attributes.values().find(|a| a.value() >= count) {
                return Err(format!(
                    "primitive {p} of mesh {m} names accessor {}, but there are {count}",
                    index.value()
                ));
            }
        }
    }
    Ok(())
}

/// Refuses an image that names neither a URI nor a buffer view with its MIME type, which
/// the `gltf` crate takes for granted.
fn check_image_sources(root: &gltf::json::Root) -> Result<(), String> {
    for (i, image) in root.images.iter().enumerate() {
        let ok = match (&image.uri, &image.buffer_view) {
            (Some(_), None) => true,
            (None, Some(_)) => image.mime_type.is_some(),
            _ => false,
        };
        if !ok {
            return Err(format!(
                "image {i} needs a uri, or a bufferView with its mimeType (and not both)"
            ));
        }
    }
    Ok(())
}

/// The bytes of every buffer, in order.
fn read_buffers(
    document: &Document,
    folder: &Path,
    mut bin: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, String> {
    let mut buffers = Vec::with_capacity(document.buffers().len());
    for buffer in document.buffers() {
        let index = buffer.index();
        let declared = buffer.length() as u64;
        let bytes = match buffer.source() {
            gltf::buffer::Source::Bin => bin.take().ok_or_else(|| {
                format!("buffer {index} is the GLB's binary chunk, which the file does not have")
            })?,
            gltf::buffer::Source::Uri(uri) => read_uri(uri, folder, declared)
                .map_err(|reason| format!("buffer {index}: {reason}"))?,
        };
        if (bytes.len() as u64) < declared {
            return Err(format!(
                "buffer {index} declares {declared} bytes (byteLength), but holds {}",
                bytes.len()
            ));
        }
        buffers.push(bytes);
    }
    Ok(buffers)
}

/// The bytes a buffer's or image's URI names: a `data:` URI's, or a file's relative
/// to `folder`. A file is read only when its size fits in memory.
pub fn read_uri(uri: &str, folder: &Path, declared: u64) -> Result<Vec<u8>, String> {
    if let Some(data) = uri.strip_prefix("data:") {
        return decode_data_uri(data);
    }
    let path = uri_path(uri, folder)?;
    let input = InputFile::open(&path).map_err(|e| e.to_string())?;
    let what = format!("{} ({})", path.display(), human_bytes(input.len()));
    check_fits(&what, input.len().max(declared))?;
    input.read_all().map_err(|e: ReadError| e.to_string())
}

/// The file a relative URI names: percent-escapes decoded, relative to `folder`.
pub fn uri_path(uri: &str, folder: &Path) -> Result<PathBuf, String> {
    if uri.contains("://") {
        return Err(format!(
            "the URI {uri:?} names a resource elsewhere: ember reads files beside the glTF"
        ));
    }
    let decoded = percent_decode(uri).ok_or_else(|| format!("the URI {uri:?} is malformed"))?;
    Ok(folder.join(decoded))
}

/// `%20` and the like as the bytes they stand for; `None` for a broken escape or text
/// that is not UTF-8 once decoded.
fn percent_decode(uri: &str) -> Option<String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// The bytes of a `data:[MIME][;base64],DATA` URI (after `data:`); only base64 data
/// is accepted, as glTF writes.
fn decode_data_uri(data: &str) -> Result<Vec<u8>, String> {
    let Some((header, payload)) = data.split_once(',') else {
        return Err("a data: URI without a comma before its data".into());
    };
    if !header.ends_with(";base64") {
        return Err(format!(
            "a data: URI ({header}) that is not base64: glTF embeds data as base64"
        ));
    }
    check_fits("a data: URI's bytes", payload.len() as u64)?;
    base64::engine::general_purpose::STANDARD
        .decode(payload.trim_end())
        .map_err(|e| format!("a data: URI whose base64 is broken: {e}"))
}

/// The MIME type a `data:` URI declares (`image/png`), if it is one.
pub fn data_uri_mime(uri: &str) -> Option<&str> {
    let header = uri.strip_prefix("data:")?.split(',').next()?;
    header.split(';').next().filter(|m| !m.is_empty())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uris_are_percent_decoded_and_data_uris_base64() {
        assert_eq!(percent_decode("a%20b.bin").as_deref(), Some("a b.bin"));
        assert_eq!(percent_decode("bad%2"), None);
        assert_eq!(percent_decode("bad%zz"), None);
        assert_eq!(
            decode_data_uri("application/octet-stream;base64,AAEC").unwrap(),
            [0, 1, 2]
        );
        assert!(decode_data_uri("text/plain,hello").is_err());
        assert!(decode_data_uri(";base64,@@@").is_err());
        assert_eq!(data_uri_mime("data:image/png;base64,AA"), Some("image/png"));
    }

    #[test]
    fn glb_lengths_are_checked() {
        let json = br#"{"asset":{"version":"2.0"}}    "#;
        let mut glb = Vec::new();
        glb.extend_from_slice(b"glTF");
        glb.extend_from_slice(&2u32.to_le_bytes());
        glb.extend_from_slice(&((12 + 8 + json.len()) as u32).to_le_bytes());
        glb.extend_from_slice(&(json.len() as u32).to_le_bytes());
        glb.extend_from_slice(&CHUNK_JSON.to_le_bytes());
        glb.extend_from_slice(json);
        let (j, bin) = split_glb(&glb).unwrap();
        assert_eq!(j, json);
        assert!(bin.is_none());
        let err = split_glb(&glb[..glb.len() - 1]).unwrap_err();
        assert!(err.contains("header says"), "{err}");
        let mut lying = glb.clone();
        lying[12..16].copy_from_slice(&1000u32.to_le_bytes());
        let err = split_glb(&lying).unwrap_err();
        assert!(err.contains("chunk says 1000 bytes"), "{err}");
        assert!(split_glb(b"glTF\x02\x00")
            .unwrap_err()
            .contains("truncated"));
    }
}
