//! The film: where a render's samples are added. Per pixel it holds the sum of the
//! finite sample estimates (in `f64`, added in sample order), how many of them were
//! finite, and how many samples were taken, for one range of sample indices that is the
//! same for every pixel (`0..spp` for a whole render, a shard's share otherwise).
//!
//! Sample `i` of a pixel always uses the random stream `(seed, pixel, i)` and is added
//! after samples `first..i`, so however a render is split into passes, interrupted and
//! resumed, the sums are bit for bit the same. Films of adjacent sample ranges merge
//! (shards); a film resolves to an [`Image`]; [`checkpoint`] stores one in a file.

pub mod checkpoint;
pub mod merge;

use std::ops::Range;

use glam::DVec3;

use crate::image::Image;

/// Per-pixel sample sums and counts over the sample indices `samples`.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// The sample indices this film accumulates; pixel `i` holds samples
    /// `samples.start .. samples.start + done[i]`.
    pub samples: Range<u32>,
    pub sums: Vec<DVec3>,
    pub kept: Vec<u32>,
    pub done: Vec<u32>,
}

/// A rectangle of a [`Film`] (x0, y0, width, height), copied out so that one worker at
/// a time can add samples to it; written back with [`Film::write_tile`].
#[derive(Clone, Debug)]
pub struct FilmTile {
    pub rect: (u32, u32, u32, u32),
    pub sums: Vec<DVec3>,
    pub kept: Vec<u32>,
    pub done: Vec<u32>,
}

impl Film {
    /// An empty film for the sample indices `samples` of a `width × height` image.
    pub fn new(width: u32, height: u32, samples: Range<u32>) -> Self {
        let n = width as usize * height as usize;
        Film {
            width,
            height,
            samples,
            sums: vec![DVec3::ZERO; n],
            kept: vec![0; n],
            done: vec![0; n],
        }
    }

    /// Fewest samples any pixel has.
    pub fn min_done(&self) -> u32 {
        self.done.iter().copied().min().unwrap_or(0)
    }

    /// Samples taken over the whole image.
    pub fn total_done(&self) -> u64 {
        self.done.iter().map(|&d| u64::from(d)).sum()
    }

    /// Whether every pixel has every sample of the film's range.
    pub fn is_complete(&self) -> bool {
        self.min_done() >= self.samples.len() as u32
    }

    /// The image so far: each pixel the mean of its finite samples (black without any).
    pub fn resolve(&self) -> Image {
        let mut image = Image::new(self.width, self.height);
        for (p, (sum, &kept)) in image
            .pixels
            .iter_mut()
            .zip(self.sums.iter().zip(&self.kept))
        {
            if kept > 0 {
                *p = (*sum / f64::from(kept)).as_vec3();
            }
        }
        image
    }

    /// Adds the samples of pixel `i` of another film: its sum, finite and taken counts.
    #[inline]
    pub fn add_pixel(&mut self, i: usize, sum: DVec3, kept: u32, done: u32) {
        self.sums[i] += sum;
        self.kept[i] += kept;
        self.done[i] += done;
    }

    /// Adds the film of the sample range that follows this one (a later shard), so that
    /// the range grows to `self.samples.start .. other.samples.end`. Sums are added per
    /// pixel, earlier range first; see [`merge`] for how that compares with one process.
    pub fn merge(&mut self, other: &Film) {
        assert_eq!(
            (self.width, self.height, self.samples.end),
            (other.width, other.height, other.samples.start),
            "films of one image and adjacent sample ranges"
        );
        for i in 0..self.sums.len() {
            self.add_pixel(i, other.sums[i], other.kept[i], other.done[i]);
        }
        self.samples.end = other.samples.end;
    }

    /// The film cut into `tile_size`-square tiles (smaller at the right and bottom
    /// edges), row by row.
    pub fn tiles(&self, tile_size: u32) -> Vec<FilmTile> {
        tile_rects(self.width, self.height, tile_size)
            .into_iter()
            .map(|rect| {
                let mut tile = FilmTile {
                    rect,
                    sums: Vec::new(),
                    kept: Vec::new(),
                    done: Vec::new(),
                };
                for row in self.rows(rect) {
                    tile.sums.extend_from_slice(&self.sums[row.clone()]);
                    tile.kept.extend_from_slice(&self.kept[row.clone()]);
                    tile.done.extend_from_slice(&self.done[row]);
                }
                tile
            })
            .collect()
    }

    /// Puts a tile's pixels back in their place.
    pub fn write_tile(&mut self, tile: &FilmTile) {
        let w = tile.rect.2 as usize;
        for (r, row) in self.rows(tile.rect).enumerate() {
            let src = r * w..(r + 1) * w;
            self.sums[row.clone()].copy_from_slice(&tile.sums[src.clone()]);
            self.kept[row.clone()].copy_from_slice(&tile.kept[src.clone()]);
            self.done[row].copy_from_slice(&tile.done[src]);
        }
    }

    /// The index ranges of the rows of a rectangle in the pixel arrays.
    fn rows(&self, (x0, y0, w, h): (u32, u32, u32, u32)) -> impl Iterator<Item = Range<usize>> {
        let width = self.width as usize;
        (y0 as usize..(y0 + h) as usize)
            .map(move |y| y * width + x0 as usize..y * width + (x0 + w) as usize)
    }
}

/// The sample indices of shard `i` of `n` of a render of `spp` samples per pixel:
/// `floor(i·spp/n) .. floor((i+1)·spp/n)`. The shards of one `n` are disjoint, cover
/// `0..spp` in order, and differ in size by at most one sample.
pub fn shard_samples(spp: u32, (i, n): (u32, u32)) -> Range<u32> {
    let at = |k: u32| (u64::from(k) * u64::from(spp) / u64::from(n)) as u32;
    at(i)..at(i + 1)
}

/// The tiles of a `width × height` image as (x0, y0, w, h), row by row.
pub fn tile_rects(width: u32, height: u32, tile_size: u32) -> Vec<(u32, u32, u32, u32)> {
    let mut tiles = Vec::new();
    for y0 in (0..height).step_by(tile_size as usize) {
        for x0 in (0..width).step_by(tile_size as usize) {
            tiles.push((
                x0,
                y0,
                tile_size.min(width - x0),
                tile_size.min(height - y0),
            ));
        }
    }
    tiles
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_tile_the_samples_in_order() {
        for spp in [0, 1, 2, 7, 10, 64, 1_000_000] {
            for n in [1, 2, 3, 4, 7, 10, 16, 100] {
                let ranges: Vec<_> = (0..n).map(|i| shard_samples(spp, (i, n))).collect();
                assert_eq!(ranges[0].start, 0);
                assert_eq!(ranges[n as usize - 1].end, spp);
                assert!(ranges.windows(2).all(|w| w[0].end == w[1].start));
                let (lo, hi) = (spp / n, spp.div_ceil(n));
                assert!(ranges.iter().all(|r| (lo..=hi).contains(&(r.len() as u32))));
            }
        }
    }

    #[test]
    fn tiles_written_back_rebuild_the_film() {
        let mut film = Film::new(37, 21, 0..4);
        for (i, s) in film.sums.iter_mut().enumerate() {
            *s = DVec3::splat(i as f64);
        }
        film.done
            .iter_mut()
            .enumerate()
            .for_each(|(i, d)| *d = i as u32 % 5);
        let tiles = film.tiles(16);
        assert_eq!(tiles.len(), 3 * 2);
        let mut rebuilt = Film::new(37, 21, 0..4);
        for tile in &tiles {
            rebuilt.write_tile(tile);
        }
        assert_eq!(rebuilt, film);
    }
}
