//! Checkpoints of a progressive render: the per-pixel sums and counts of a
//! [`Progress`], with the settings that produced them, in one small binary file that is
//! written atomically and checked whole on reading.
//!
//! Layout (little-endian): the magic `EMBERCKP`, a `u32` version, a `u32` length and
//! that many bytes of JSON settings (an object of strings), then per pixel row by row
//! `f64` × 3 sums, `u32` finite samples, `u32` samples taken, and last a `u64` FNV-1a
//! hash of everything before it. A resume must present the same settings (all but
//! `spp`, which may grow): anything else would not continue the same image.

use std::path::{Path, PathBuf};

use glam::DVec3;

use crate::film;
use crate::render::{Progress, RenderSettings};
use crate::scene::{CameraSettings, Scene};

const MAGIC: &[u8; 8] = b"EMBERCKP";
const VERSION: u32 = 1;
const PIXEL_BYTES: usize = 3 * 8 + 4 + 4;

#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error("cannot read checkpoint {path}: {reason}")]
    Read { path: PathBuf, reason: String },
    #[error("checkpoint {path} is not a valid ember checkpoint: {reason}")]
    Invalid { path: PathBuf, reason: String },
    #[error("checkpoint {path} was made with {key} {theirs}, but this render has {key} {ours}")]
    Mismatch {
        path: PathBuf,
        key: String,
        theirs: String,
        ours: String,
    },
    #[error("checkpoint {path} already has {done} samples per pixel, more than --spp {spp}")]
    PastTarget { path: PathBuf, done: u32, spp: u32 },
    #[error(transparent)]
    Write(#[from] film::FilmError),
}

/// What must match for a checkpoint to continue the same image, as (name, value) pairs
/// in a fixed order. Floats are written with `{:?}`, which round-trips exactly.
pub fn identity(
    scene: &Scene,
    camera: &CameraSettings,
    settings: &RenderSettings,
) -> Vec<(String, String)> {
    let v = |v: glam::Vec3| format!("{:?},{:?},{:?}", v.x, v.y, v.z);
    [
        ("width", settings.width.to_string()),
        ("height", settings.height.to_string()),
        ("max-depth", settings.max_depth.to_string()),
        ("seed", settings.seed.to_string()),
        ("integrator", format!("{:?}", settings.integrator)),
        // The field of view before the eye: the default eye is derived from it.
        ("fov", format!("{:?}", camera.vfov_degrees)),
        ("eye", v(camera.eye)),
        ("look-at", v(camera.look_at)),
        ("up", v(camera.up)),
        ("background", v(scene.background)),
        ("scene", format!("{:016x}", scene_hash(scene))),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_owned(), v))
    .collect()
}

/// FNV-1a over bytes: small, stable across Rust versions and platforms.
fn fnv1a(hash: u64, bytes: &[u8]) -> u64 {
    bytes.iter().fold(hash, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    })
}

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// A fingerprint of everything in the scene that shapes the image.
pub fn scene_hash(scene: &Scene) -> u64 {
    let m = &scene.mesh;
    let floats = m
        .positions
        .iter()
        .chain(&m.normals)
        .flat_map(|p| p.to_array())
        .chain(m.uvs.iter().flat_map(|t| t.to_array()));
    let mut h = FNV_OFFSET;
    for f in floats {
        h = fnv1a(h, &f.to_le_bytes());
    }
    for i in m.triangles.iter().flatten().chain(&m.material) {
        h = fnv1a(h, &i.to_le_bytes());
    }
    h = fnv1a(h, format!("{:?}", scene.materials).as_bytes());
    for t in &scene.textures {
        h = fnv1a(h, &t.width.to_le_bytes());
        h = fnv1a(h, &t.height.to_le_bytes());
        for c in t.texels.iter().flat_map(|c| c.to_array()) {
            h = fnv1a(h, &c.to_le_bytes());
        }
    }
    h
}

/// Encodes a checkpoint.
pub fn encode(identity: &[(String, String)], progress: &Progress) -> Vec<u8> {
    let json = serde_json::Value::Object(
        identity
            .iter()
            .map(|(k, v)| (k.clone(), serde_json::Value::String(v.clone())))
            .collect(),
    )
    .to_string();
    let mut out = Vec::with_capacity(24 + json.len() + progress.done.len() * PIXEL_BYTES);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(json.as_bytes());
    for ((s, k), d) in progress.sums.iter().zip(&progress.kept).zip(&progress.done) {
        for c in s.to_array() {
            out.extend_from_slice(&c.to_le_bytes());
        }
        out.extend_from_slice(&k.to_le_bytes());
        out.extend_from_slice(&d.to_le_bytes());
    }
    let hash = fnv1a(FNV_OFFSET, &out);
    out.extend_from_slice(&hash.to_le_bytes());
    out
}

/// Writes a checkpoint atomically: the file is the old one or the whole new one.
pub fn save(
    path: &Path,
    identity: &[(String, String)],
    progress: &Progress,
) -> Result<(), CheckpointError> {
    Ok(film::write_atomically(path, &encode(identity, progress))?)
}

/// Reads a checkpoint and checks it continues the render `identity` describes, to
/// `spp` samples per pixel.
pub fn load(
    path: &Path,
    identity: &[(String, String)],
    spp: u32,
) -> Result<Progress, CheckpointError> {
    let bytes = std::fs::read(path).map_err(|e| CheckpointError::Read {
        path: path.to_owned(),
        reason: e.to_string(),
    })?;
    let invalid = |reason: &str| CheckpointError::Invalid {
        path: path.to_owned(),
        reason: reason.to_owned(),
    };
    let (body, hash) = bytes
        .split_last_chunk::<8>()
        .ok_or_else(|| invalid("too short"))?;
    if !body.starts_with(MAGIC) {
        return Err(invalid("wrong magic bytes"));
    }
    if fnv1a(FNV_OFFSET, body) != u64::from_le_bytes(*hash) {
        return Err(invalid("checksum mismatch (truncated or damaged)"));
    }
    let mut rest = &body[MAGIC.len()..];
    let mut u32_field = || -> Result<u32, CheckpointError> {
        let (v, r) = rest
            .split_first_chunk::<4>()
            .ok_or_else(|| invalid("too short"))?;
        rest = r;
        Ok(u32::from_le_bytes(*v))
    };
    let version = u32_field()?;
    if version != VERSION {
        return Err(invalid(&format!("version {version}, expected {VERSION}")));
    }
    let json_len = u32_field()? as usize;
    if rest.len() < json_len {
        return Err(invalid("too short"));
    }
    let (json, pixels) = rest.split_at(json_len);
    let stored: serde_json::Map<String, serde_json::Value> =
        serde_json::from_slice(json).map_err(|e| invalid(&format!("settings: {e}")))?;
    for (key, ours) in identity {
        let theirs = stored.get(key).and_then(|v| v.as_str()).unwrap_or("(none)");
        if theirs != ours {
            return Err(CheckpointError::Mismatch {
                path: path.to_owned(),
                key: key.clone(),
                theirs: theirs.to_owned(),
                ours: ours.clone(),
            });
        }
    }
    let field = |k: &str| {
        identity
            .iter()
            .find(|(key, _)| key == k)
            .and_then(|(_, v)| v.parse().ok())
    };
    let (Some(width), Some(height)) = (field("width"), field("height")) else {
        return Err(invalid("settings lack the image size"));
    };
    let mut progress = Progress::new(width, height);
    if pixels.len() != progress.done.len() * PIXEL_BYTES {
        return Err(invalid("pixel data does not match the image size"));
    }
    for (i, px) in pixels.chunks_exact(PIXEL_BYTES).enumerate() {
        let f = |k: usize| f64::from_le_bytes(px[8 * k..8 * k + 8].try_into().expect("8 bytes"));
        let u = |at: usize| u32::from_le_bytes(px[at..at + 4].try_into().expect("4 bytes"));
        progress.sums[i] = DVec3::new(f(0), f(1), f(2));
        progress.kept[i] = u(24);
        progress.done[i] = u(28);
        if progress.kept[i] > progress.done[i] || !progress.sums[i].is_finite() {
            return Err(invalid("inconsistent pixel data"));
        }
    }
    let most = progress.done.iter().copied().max().unwrap_or(0);
    if most > spp {
        return Err(CheckpointError::PastTarget {
            path: path.to_owned(),
            done: most,
            spp,
        });
    }
    Ok(progress)
}
