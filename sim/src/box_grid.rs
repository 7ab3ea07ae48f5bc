//! A uniform grid over axis-aligned boxes: which of many boxes may overlap a query box,
//! without testing every one.
//!
//! Each box is filed under every cell of side `cell` it touches; a query looks only at the
//! boxes filed under the cells its own box touches. Two boxes that share a point share the
//! cell of that point, so no overlapping box is missed; the caller tests the candidates
//! exactly, and gets the same answer as testing all of them. Boxes spanning more than
//! [`MAX_CELLS`] cells (a fast body's sweep, an unbounded region) are kept in a list every
//! query looks at. Entries live in one sorted vector, with a map from each cell to its run of
//! entries; both are cleared and refilled, so a grid rebuilt every tick allocates nothing once
//! it has grown to its size.

use std::collections::HashMap;
use std::hash::BuildHasherDefault;

/// Hashes a cell key (a `u64`) with one multiply; fixed, so runs are repeatable.
#[derive(Debug, Default, Clone, Copy)]
struct CellHasher(u64);

impl std::hash::Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write_u64(&mut self, key: u64) {
        let mixed = (self.0 ^ key).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        self.0 = mixed ^ (mixed >> 29);
    }

    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }
}

/// Cells a box may span before it is kept aside and looked at by every query.
pub const MAX_CELLS: u64 = 64;

/// Cell coordinates beyond this are treated as spanning too many cells.
const MAX_COORD: i64 = 1 << 20;

enum Span {
    Cells([i64; 3], [i64; 3]),
    /// More than [`MAX_CELLS`], not finite, or inverted.
    Wide,
}

/// See the module docs.
#[derive(Debug, Clone)]
pub struct BoxGrid {
    cell: f32,
    /// (cell key, box) pairs, sorted by key.
    entries: Vec<(u64, u32)>,
    /// Where each cell's run of `entries` starts and ends.
    runs: HashMap<u64, (u32, u32), BuildHasherDefault<CellHasher>>,
    /// Boxes spanning too many cells.
    large: Vec<u32>,
}

impl BoxGrid {
    /// An empty grid of cells `cell` metres on a side (at least a millimetre).
    pub fn new(cell: f32) -> Self {
        Self {
            cell: if cell.is_finite() {
                cell.max(1e-3)
            } else {
                1.0
            },
            entries: Vec::new(),
            runs: HashMap::default(),
            large: Vec::new(),
        }
    }

    /// Forgets every box, keeping the memory.
    pub fn clear(&mut self) {
        self.entries.clear();
        self.runs.clear();
        self.large.clear();
    }

    /// The cells a box spans.
    fn span(&self, min: [f32; 3], max: [f32; 3]) -> Span {
        let mut lo = [0i64; 3];
        let mut hi = [0i64; 3];
        let mut cells = 1u64;
        let limit = MAX_COORD as f32;
        for k in 0..3 {
            if min[k] > max[k] {
                // Inverted: no cell stands for it, so it is looked at (or looks) everywhere.
                return Span::Wide;
            }
            let (a, b) = ((min[k] / self.cell).floor(), (max[k] / self.cell).floor());
            // NaN fails both comparisons and lands here too.
            if !(a.abs() < limit && b.abs() < limit) {
                return Span::Wide;
            }
            (lo[k], hi[k]) = (a as i64, b as i64);
            cells = cells.saturating_mul((hi[k] - lo[k] + 1) as u64);
        }
        if cells <= MAX_CELLS {
            Span::Cells(lo, hi)
        } else {
            Span::Wide
        }
    }

    fn key(cell: [i64; 3]) -> u64 {
        let part = |c: i64| (c + MAX_COORD) as u64 & ((1 << 21) - 1);
        part(cell[0]) << 42 | part(cell[1]) << 21 | part(cell[2])
    }

    /// Files box number `index` (`min`..`max`). Call [`Self::seal`] before querying.
    pub fn insert(&mut self, index: u32, min: [f32; 3], max: [f32; 3]) {
        let (lo, hi) = match self.span(min, max) {
            Span::Cells(lo, hi) => (lo, hi),
            Span::Wide => return self.large.push(index),
        };
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    self.entries.push((Self::key([x, y, z]), index));
                }
            }
        }
    }

    /// Sorts what was inserted, for queries.
    pub fn seal(&mut self) {
        self.entries.sort_unstable();
        self.runs.clear();
        let mut start = 0;
        for pair in self.entries.chunk_by(|a, b| a.0 == b.0) {
            let end = start + pair.len();
            self.runs.insert(pair[0].0, (start as u32, end as u32));
            start = end;
        }
    }

    /// Calls `visit` with every box that may overlap `min`..`max` (some more than once), until
    /// it returns `true`; returns whether one did.
    pub fn any(&self, min: [f32; 3], max: [f32; 3], mut visit: impl FnMut(u32) -> bool) -> bool {
        if self.large.iter().any(|&i| visit(i)) {
            return true;
        }
        if self.entries.is_empty() {
            return false;
        }
        let (lo, hi) = match self.span(min, max) {
            Span::Cells(lo, hi) => (lo, hi),
            // The query spans too many cells: look at every box.
            Span::Wide => return self.entries.iter().any(|&(_, i)| visit(i)),
        };
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    let Some(&(start, end)) = self.runs.get(&Self::key([x, y, z])) else {
                        continue;
                    };
                    for &(_, i) in &self.entries[start as usize..end as usize] {
                        if visit(i) {
                            return true;
                        }
                    }
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn overlaps(a: ([f32; 3], [f32; 3]), b: ([f32; 3], [f32; 3])) -> bool {
        (0..3).all(|k| a.0[k] <= b.1[k] && b.0[k] <= a.1[k])
    }

    #[test]
    fn finds_exactly_what_testing_every_box_finds() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut boxes = Vec::new();
        for i in 0..500 {
            let centre = [next() * 80.0 - 40.0, next() * 80.0 - 40.0, next() * 20.0];
            // Mostly small, some long (kept aside), one unbounded, some touching at a face.
            let half = if i % 50 == 0 { 200.0 } else { next() * 3.0 };
            let mut b = (centre.map(|c| c - half), centre.map(|c| c + half));
            if i == 7 {
                b = (
                    [f32::NEG_INFINITY; 3],
                    [-1000.0, f32::INFINITY, f32::INFINITY],
                );
            }
            if i % 9 == 0 {
                b.1[0] = 4.0;
            }
            boxes.push(b);
        }
        let mut grid = BoxGrid::new(4.0);
        for (i, b) in boxes.iter().enumerate() {
            grid.insert(i as u32, b.0, b.1);
        }
        grid.seal();
        for _ in 0..2000 {
            let centre = [
                next() * 100.0 - 50.0,
                next() * 100.0 - 50.0,
                next() * 30.0 - 5.0,
            ];
            let half = next() * 5.0;
            let mut q = (centre.map(|c| c - half), centre.map(|c| c + half));
            if next() < 0.05 {
                q.0[0] = 4.0;
            }
            let mut found = vec![false; boxes.len()];
            grid.any(q.0, q.1, |i| {
                found[i as usize] |= overlaps(boxes[i as usize], q);
                false
            });
            for (i, b) in boxes.iter().enumerate() {
                assert_eq!(found[i], overlaps(*b, q), "box {i} {b:?} against {q:?}");
            }
        }
    }
}
