//! Discrete distributions sampled in constant time: Walker's alias method, built once
//! (for example over a scene's emitters) and queried per sample without allocation.

use super::ONE_BELOW;

/// An alias table over `n` outcomes with given non-negative weights (Vose's O(n)
/// construction). Sampling costs one multiplication and one comparison, whatever `n`.
#[derive(Clone, Debug, Default)]
pub struct AliasTable {
    /// Each bin's coin, side by side so that a draw reads one place.
    entries: Vec<AliasEntry>,
    /// Normalised probability of each outcome.
    pmf: Vec<f32>,
}

/// One bin of an alias table: the probability of keeping the bin's own outcome rather
/// than jumping to `alias`. Public so that a table can live inside other records (an
/// environment map keeps each texel's entry beside its radiance: [`alias_draw`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AliasEntry {
    pub keep: f32,
    pub alias: u32,
}

impl AliasTable {
    /// The table for `weights`; outcomes with weight 0 (or not finite) are never chosen.
    /// Returns `None` when no weight is positive.
    pub fn new(weights: &[f32]) -> Option<Self> {
        let clean = |w: f32| {
            if w.is_finite() && w > 0.0 {
                w as f64
            } else {
                0.0
            }
        };
        let total: f64 = weights.iter().map(|&w| clean(w)).sum();
        if total.is_nan() || total <= 0.0 || weights.len() > u32::MAX as usize {
            return None;
        }
        let n = weights.len();
        // Scaled so that the mean bin holds exactly 1.
        let mut scaled: Vec<f64> = weights
            .iter()
            .map(|&w| clean(w) * n as f64 / total)
            .collect();
        let pmf = weights.iter().map(|&w| (clean(w) / total) as f32).collect();
        let mut keep = vec![1.0f32; n];
        let mut alias: Vec<u32> = (0..n as u32).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) =
            (0..n).partition(|&i| scaled[i] < 1.0);
        while let (Some(s), Some(&l)) = (small.pop(), large.last()) {
            keep[s] = scaled[s] as f32;
            alias[s] = l as u32;
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // What is left holds (up to rounding) exactly 1: always keep it.
        for i in small.into_iter().chain(large) {
            keep[i] = 1.0;
            alias[i] = i as u32;
        }
        let entries = keep
            .into_iter()
            .zip(alias)
            .map(|(keep, alias)| AliasEntry { keep, alias })
            .collect();
        Some(AliasTable { entries, pmf })
    }

    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }

    /// Probability of outcome `i`.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf[i]
    }

    /// Bin `i`'s entry.
    #[inline]
    pub fn entry(&self, i: usize) -> AliasEntry {
        self.entries[i]
    }

    /// An outcome drawn with probability [`pmf`](Self::pmf) from one uniform `u` in
    /// `[0, 1)`, and a fresh uniform in `[0, 1)` made of what the choice left of `u`
    /// (see [`alias_draw`]).
    #[inline]
    pub fn sample(&self, u: f64) -> (usize, f32) {
        alias_draw(self.entries.len(), u, |i| self.entries[i])
    }
}

/// The draw of an alias table of `n` bins whose entries `entry` gives, from one
/// uniform `u` in `[0, 1)`: the outcome, and a fresh uniform in `[0, 1)` made of what
/// the choice left of `u`.
///
/// The integer part of `u · n` picks a bin and its fraction tosses the bin's coin; the
/// fraction, rescaled within the side of the coin it fell on, is uniform and
/// independent of the outcome. Passing it on to the next draw (a point on the chosen
/// light) keeps a stratified `u` stratified over outcome and point together. `u` needs
/// about `log2(n)` more bits than the fraction should keep, so pass an `f64` with
/// random low bits ([`Rng::refine`](super::Rng::refine)).
#[inline]
pub fn alias_draw(n: usize, u: f64, entry: impl Fn(usize) -> AliasEntry) -> (usize, f32) {
    let (column, fraction) = alias_bin(n, u);
    let AliasEntry { keep, alias } = entry(column);
    let (outcome, rest) = if fraction < keep {
        (column, fraction / keep)
    } else {
        (alias as usize, (fraction - keep) / (1.0 - keep))
    };
    (outcome, rest.clamp(0.0, ONE_BELOW))
}

/// The bin of [`alias_draw`]'s first step, whose entry it reads, and the fraction of
/// `u` within it.
#[inline]
pub fn alias_bin(n: usize, u: f64) -> (usize, f32) {
    let scaled = u * n as f64;
    let column = (scaled as usize).min(n - 1);
    (column, (scaled - column as f64) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn frequencies_match_weights() {
        let weights = [1.0, 0.0, 3.0, 0.5, 5.5];
        let table = AliasTable::new(&weights).unwrap();
        let total: f32 = weights.iter().sum();
        let mut rng = Rng::seeded(3);
        let n = 200_000;
        let mut counts = [0u32; 5];
        // The fractions left over stay uniform whatever the outcome (mean 1/2).
        let mut rest_sums = [0.0f64; 5];
        for _ in 0..n {
            let (outcome, rest) = table.sample(rng.f64());
            assert!((0.0..1.0).contains(&rest));
            counts[outcome] += 1;
            rest_sums[outcome] += f64::from(rest);
        }
        for (i, &w) in weights.iter().enumerate() {
            let p = w / total;
            assert!((table.pmf(i) - p).abs() < 1e-6);
            let sigma = (n as f32 * p * (1.0 - p)).sqrt();
            assert!(
                (counts[i] as f32 - n as f32 * p).abs() <= 5.0 * sigma + 1e-3,
                "outcome {i}: {} draws, expected {}",
                counts[i],
                n as f32 * p
            );
            if counts[i] > 1000 {
                let mean = rest_sums[i] / f64::from(counts[i]);
                let sigma = (1.0 / 12.0 / f64::from(counts[i])).sqrt();
                assert!(
                    (mean - 0.5).abs() < 5.0 * sigma,
                    "outcome {i}: rest mean {mean}"
                );
            }
        }
    }

    #[test]
    fn no_positive_weight_is_none() {
        assert!(AliasTable::new(&[]).is_none());
        assert!(AliasTable::new(&[0.0, f32::NAN, -1.0]).is_none());
    }
}
