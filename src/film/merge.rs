//! Merging the shards of a split render into one film.
//!
//! Every header is read and checked first (same render, ranges disjoint and covering
//! `0..spp`, every shard complete), so a refusal costs no pixel reading; then the shards
//! are streamed one at a time, in sample order, into one film: memory is one film plus
//! a read buffer, whatever the number of shards. A shard whose checksum fails aborts the
//! merge, and nothing is written.
//!
//! What the merge guarantees: the counts are exact, and each pixel's sum is the sum of
//! the same `f64` values as in one process, grouped by shard: `(s₀+…+s₄) + (s₅+…+s₉)`
//! where one process computes `((s₀+…+s₄) + s₅) + …`. The two differ by `f64` rounding
//! (a relative 1e-16 per addition), so EXR/HDR output agrees to within that before its
//! conversion to `f32` (nearly always to the bit), and 8-bit output is the same bytes
//! unless a pixel's value lies within that rounding of one of the 255 quantisation
//! steps. A single shard (`--shard 0/1`) equals one process bit for bit.

use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use super::checkpoint::{first_difference, CheckpointError, FilmReader, Header, Identity};
use super::{shard_samples, Film};

#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    #[error("nothing to merge: give the shard files")]
    NoInput,
    #[error(transparent)]
    File(#[from] CheckpointError),
    #[error("{path} is given twice")]
    SamePath { path: PathBuf },
    #[error(
        "{path} was made with {key} {theirs}, but {other} (like most shards) with {key} {ours}"
    )]
    Mismatch {
        path: PathBuf,
        other: PathBuf,
        key: String,
        theirs: String,
        ours: String,
    },
    #[error("{path} duplicates {other}: both are {label}, samples {range:?}")]
    Duplicate {
        path: PathBuf,
        other: PathBuf,
        label: String,
        range: Range<u32>,
    },
    #[error("{path} (samples {range:?}) overlaps {other} (samples {other_range:?})")]
    Overlap {
        path: PathBuf,
        range: Range<u32>,
        other: PathBuf,
        other_range: Range<u32>,
    },
    #[error(
        "no shard holds samples {range:?} of 0..{spp}{hint}: render it, or merge the rest \
         with --allow-partial"
    )]
    Missing {
        range: Range<u32>,
        spp: u32,
        hint: String,
    },
    #[error(
        "{path} ({label}) is incomplete: {done} of its {want} samples per pixel; continue \
         it with --resume, or merge anyway with --allow-partial"
    )]
    Incomplete {
        path: PathBuf,
        label: String,
        done: u32,
        want: u32,
    },
    #[error("{path} changed while it was being merged")]
    Changed { path: PathBuf },
}

/// What a merge had to leave out (only with `allow_partial`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MergeReport {
    /// Sample ranges no shard holds.
    pub missing: Vec<Range<u32>>,
    /// Shards with fewer samples than their range (the merge used what they have).
    pub incomplete: Vec<PathBuf>,
}

/// Merges the shard files `paths` into one film over `0..spp`. Without `allow_partial`
/// any gap or incomplete shard is refused; with it, the film holds what there is (each
/// pixel's mean over the samples present is still an unbiased estimate) and the report
/// says what is missing.
pub fn merge(paths: &[PathBuf], allow_partial: bool) -> Result<(Film, MergeReport), MergeError> {
    let shards = read_headers(paths)?;
    check_same_render(&shards)?;
    let mut sorted: Vec<&(PathBuf, Header)> = shards.iter().collect();
    sorted.sort_by_key(|(_, h)| (h.samples.start, h.samples.end));
    check_disjoint(&sorted)?;
    let (first, spp) = (&sorted[0].1, sorted[0].1.spp);
    let report = MergeReport {
        missing: gaps(&sorted, spp),
        incomplete: sorted
            .iter()
            .filter(|(_, h)| !h.complete)
            .map(|(p, _)| p.clone())
            .collect(),
    };
    if !allow_partial {
        refuse_partial(&sorted, &report, spp)?;
    }
    let mut film = Film::new(first.width, first.height, 0..spp);
    for (path, header) in sorted {
        let reader = FilmReader::open(path)?;
        if reader.header != *header {
            return Err(MergeError::Changed { path: path.clone() });
        }
        reader.read_pixels(|i, p, t| {
            film.pixels[i].merge(p);
            if let Some(t) = t {
                film.training_mut()[i].merge(t);
            }
        })?;
    }
    Ok((film, report))
}

fn read_headers(paths: &[PathBuf]) -> Result<Vec<(PathBuf, Header)>, MergeError> {
    if paths.is_empty() {
        return Err(MergeError::NoInput);
    }
    // One file under two names (`s0.shard`, `./s0.shard`, a link) is given twice.
    let mut seen: Vec<crate::io::FileIdentity> = Vec::with_capacity(paths.len());
    let mut shards = Vec::with_capacity(paths.len());
    for path in paths {
        let identity = crate::io::file_identity(path);
        if seen.iter().any(|s| s.same(&identity)) {
            return Err(MergeError::SamePath { path: path.clone() });
        }
        seen.push(identity);
        shards.push((path.clone(), FilmReader::open(path)?.header));
    }
    Ok(shards)
}

/// What must be equal across shards: the identity and the total sample count.
fn render_key(h: &Header) -> Identity {
    let mut key = h.identity.clone();
    key.push(("spp".into(), h.spp.to_string()));
    key
}

/// The shards must all come from one render. The odd one out is the culprit: the
/// identity most shards share is taken as the render's (the first such on a tie).
fn check_same_render(shards: &[(PathBuf, Header)]) -> Result<(), MergeError> {
    let keys: Vec<Identity> = shards.iter().map(|(_, h)| render_key(h)).collect();
    let count = |k: &Identity| keys.iter().filter(|o| *o == k).count();
    let reference = (0..keys.len())
        .max_by_key(|&i| (count(&keys[i]), std::cmp::Reverse(i)))
        .expect("at least one shard");
    for (i, key) in keys.iter().enumerate() {
        if let Some((k, theirs, ours)) = first_difference(key, &keys[reference]) {
            return Err(MergeError::Mismatch {
                path: shards[i].0.clone(),
                other: shards[reference].0.clone(),
                key: k,
                theirs,
                ours,
            });
        }
    }
    Ok(())
}

/// Sorted by range: no two shards may hold the same sample of a pixel.
fn check_disjoint(sorted: &[&(PathBuf, Header)]) -> Result<(), MergeError> {
    let mut labels: HashMap<(u32, u32), &Path> = HashMap::new();
    for (path, h) in sorted {
        if let Some(other) = h.shard.and_then(|s| labels.insert(s, path)) {
            return Err(MergeError::Duplicate {
                path: path.clone(),
                other: other.to_owned(),
                label: h.label(),
                range: h.samples.clone(),
            });
        }
    }
    for pair in sorted.windows(2) {
        let ((a_path, a), (b_path, b)) = (pair[0], pair[1]);
        if a.samples.is_empty() || b.samples.is_empty() || a.samples.end <= b.samples.start {
            continue;
        }
        if a.samples == b.samples {
            return Err(MergeError::Duplicate {
                path: b_path.clone(),
                other: a_path.clone(),
                label: b.label(),
                range: b.samples.clone(),
            });
        }
        return Err(MergeError::Overlap {
            path: b_path.clone(),
            range: b.samples.clone(),
            other: a_path.clone(),
            other_range: a.samples.clone(),
        });
    }
    Ok(())
}

/// The parts of `0..spp` no shard holds, in order.
fn gaps(sorted: &[&(PathBuf, Header)], spp: u32) -> Vec<Range<u32>> {
    let mut missing = Vec::new();
    let mut next = 0;
    for (_, h) in sorted.iter().filter(|(_, h)| !h.samples.is_empty()) {
        if h.samples.start > next {
            missing.push(next..h.samples.start);
        }
        next = next.max(h.samples.end);
    }
    if next < spp {
        missing.push(next..spp);
    }
    missing
}

/// Which shards of an N-way split would hold `range`, if the shards say N.
fn missing_shards(range: &Range<u32>, spp: u32, n: Option<u32>) -> String {
    let Some(n) = n else {
        return String::new();
    };
    let ids: Vec<String> = (0..n)
        .filter(|&i| {
            let r = shard_samples(spp, (i, n));
            !r.is_empty() && r.start < range.end && range.start < r.end
        })
        .map(|i| format!("{i}/{n}"))
        .collect();
    format!(" (shard {})", ids.join(", "))
}

fn refuse_partial(
    sorted: &[&(PathBuf, Header)],
    report: &MergeReport,
    spp: u32,
) -> Result<(), MergeError> {
    if let Some(range) = report.missing.first() {
        let n = sorted.iter().find_map(|(_, h)| h.shard.map(|(_, n)| n));
        return Err(MergeError::Missing {
            hint: missing_shards(range, spp, n),
            range: range.clone(),
            spp,
        });
    }
    if let Some((path, h)) = sorted.iter().find(|(p, _)| report.incomplete.contains(p)) {
        return Err(MergeError::Incomplete {
            path: path.clone(),
            label: h.label(),
            done: h.min_done,
            want: h.samples.len() as u32,
        });
    }
    Ok(())
}
