//! What built levels read of a finer brick ([`Summary`]: the sums of its 2x2x2 blocks) and
//! the cache they read it through ([`super::lazy_levels`]): summaries kept by recency of use
//! within a byte budget of host memory, and those it lets go written to a temporary file
//! instead of dropped, so that a small budget re-reads a few bytes from disk where it would
//! otherwise decode and sum the finer brick again (and that brick's finer bricks, when it is
//! built too).
//!
//! The file is made in the temporary directory (`TMPDIR`) on the first eviction and is
//! unlinked at once, so it goes with the process however it ends; it grows to at most
//! [`SPILL_BYTES`] (each summary is written once: summaries never change), after which evicted
//! summaries are dropped as before. Its pages live in the system's page cache, not in the
//! process: they count against no budget and the system reclaims them under pressure.

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::sync::Arc;

use super::{BRICK, BrickData, Coarsening};

/// Edge of a [`Summary`]: one sum for each 2x2x2 block of a brick.
pub(crate) const HALF: u32 = BRICK / 2;

/// A finer brick as the level above reads it: the sum of its voxels (those inside the volume)
/// in each 2x2x2 block (its first voxel, with [`Coarsening::First`]), `HALF`^3 values x
/// fastest; or, for a brick of one value, that value.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Summary {
    Constant(f32),
    Sums(Vec<f32>),
}

impl Summary {
    /// The sums (or first voxels) of brick `fb` of a level of `fine` dims.
    pub(crate) fn of(data: &BrickData, fb: [u32; 3], fine: [u32; 3], coarsening: Coarsening) -> Summary {
        let BrickData::Voxels(_) = data else {
            return match data {
                BrickData::Constant(v) => Summary::Constant(*v),
                BrickData::Voxels(_) => unreachable!("matched above"),
            };
        };
        // Voxels of the brick inside the volume, per axis.
        let inside = [0, 1, 2].map(|a| fine[a].saturating_sub(fb[a] * BRICK).min(BRICK));
        let mut sums = vec![0.0f32; (HALF * HALF * HALF) as usize];
        // Every voxel, or the first of each block.
        let step = match coarsening {
            Coarsening::Mean => 1,
            Coarsening::First => 2,
        };
        for z in (0..inside[2]).step_by(step) {
            for y in (0..inside[1]).step_by(step) {
                let row = ((z / 2 * HALF + y / 2) * HALF) as usize;
                for x in (0..inside[0]).step_by(step) {
                    // Past the apron.
                    sums[row + (x / 2) as usize] += data.voxel([x, y, z]);
                }
            }
        }
        Summary::Sums(sums)
    }
}

/// The most bytes written to the spill file of one volume.
pub(crate) const SPILL_BYTES: u64 = 1 << 30;

/// A summary's key: its level and brick.
type Key = (usize, [u32; 3]);

/// Summaries kept by recency of use within a byte budget, and those evicted kept on disk.
pub(crate) struct SummaryCache {
    pub(crate) budget: u64,
    pub(crate) bytes: u64,
    tick: u64,
    entries: HashMap<Key, (Arc<Summary>, u64)>,
    /// Keys by their last use, oldest first.
    order: BTreeMap<u64, Key>,
    /// Evicted summaries; `None` once the file could not be made or written.
    spill: Option<Spill>,
}

impl SummaryCache {
    /// A cache of at most `budget` bytes of host memory.
    pub(crate) fn new(budget: u64) -> SummaryCache {
        SummaryCache {
            budget,
            bytes: 0,
            tick: 0,
            entries: HashMap::new(),
            order: BTreeMap::new(),
            spill: Some(Spill::default()),
        }
    }

    fn cost(data: &Summary) -> u64 {
        match data {
            Summary::Constant(_) => 64,
            Summary::Sums(v) => v.len() as u64 * 4 + 64,
        }
    }

    /// The summary of `key`, from memory or read back from the spill file.
    pub(crate) fn get(&mut self, key: Key) -> Option<Arc<Summary>> {
        self.tick += 1;
        if let Some((data, used)) = self.entries.get_mut(&key) {
            self.order.remove(used);
            *used = self.tick;
            self.order.insert(self.tick, key);
            return Some(data.clone());
        }
        let read = self.spill.as_mut()?.read(key);
        match read {
            Ok(Some(summary)) => {
                let summary = Arc::new(summary);
                self.insert(key, summary.clone());
                Some(summary)
            }
            Ok(None) => None,
            Err(_) => {
                self.spill = None;
                None
            }
        }
    }

    /// Keeps `data` as the summary of `key`, evicting the least recently used over budget.
    pub(crate) fn insert(&mut self, key: Key, data: Arc<Summary>) {
        self.tick += 1;
        if let Some((old, used)) = self.entries.insert(key, (data.clone(), self.tick)) {
            self.order.remove(&used);
            self.bytes -= Self::cost(&old);
        }
        self.order.insert(self.tick, key);
        self.bytes += Self::cost(&data);
        while self.bytes > self.budget {
            let Some((_, oldest)) = self.order.pop_first() else { break };
            if let Some((gone, _)) = self.entries.remove(&oldest) {
                self.bytes -= Self::cost(&gone);
                if let Some(spill) = &mut self.spill
                    && spill.write(oldest, &gone).is_err()
                {
                    self.spill = None;
                }
            }
        }
    }

    /// Summaries held in memory.
    #[cfg(test)]
    pub(crate) fn in_memory(&self) -> usize {
        self.entries.len()
    }
}

/// Summaries written to an unlinked temporary file, each once.
#[derive(Default)]
struct Spill {
    /// Made on the first write.
    file: Option<File>,
    at: HashMap<Key, Spilled>,
    /// Bytes written so far.
    end: u64,
}

/// Where a spilled summary is.
#[derive(Clone, Copy)]
enum Spilled {
    /// A brick of one value: nothing to write.
    Constant(f32),
    /// `len` sums at byte `offset` of the file.
    Sums { offset: u64, len: usize },
}

impl Spill {
    fn write(&mut self, key: Key, summary: &Summary) -> std::io::Result<()> {
        if self.at.contains_key(&key) {
            return Ok(());
        }
        let spilled = match summary {
            Summary::Constant(v) => Spilled::Constant(*v),
            Summary::Sums(sums) => {
                let bytes: &[u8] = bytemuck::cast_slice(sums);
                if self.end + bytes.len() as u64 > SPILL_BYTES {
                    return Ok(());
                }
                let file = match &mut self.file {
                    Some(file) => file,
                    None => self.file.insert(tempfile::tempfile()?),
                };
                file.seek(SeekFrom::Start(self.end))?;
                file.write_all(bytes)?;
                let at = Spilled::Sums { offset: self.end, len: sums.len() };
                self.end += bytes.len() as u64;
                at
            }
        };
        self.at.insert(key, spilled);
        Ok(())
    }

    fn read(&mut self, key: Key) -> std::io::Result<Option<Summary>> {
        match self.at.get(&key) {
            None => Ok(None),
            Some(Spilled::Constant(v)) => Ok(Some(Summary::Constant(*v))),
            Some(&Spilled::Sums { offset, len }) => {
                let Some(file) = &mut self.file else { return Ok(None) };
                let mut sums = vec![0.0f32; len];
                file.seek(SeekFrom::Start(offset))?;
                file.read_exact(bytemuck::cast_slice_mut(&mut sums))?;
                Ok(Some(Summary::Sums(sums)))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sums(v: f32) -> Arc<Summary> {
        Arc::new(Summary::Sums(vec![v; 32 * 32 * 32]))
    }

    #[test]
    fn the_cache_keeps_to_its_budget_and_reads_back_what_it_let_go() {
        let mut cache = SummaryCache::new(3 * (32 * 32 * 32 * 4 + 64));
        for i in 0..5 {
            cache.insert((0, [i, 0, 0]), sums(i as f32));
            assert!(cache.bytes <= cache.budget);
        }
        assert_eq!(cache.in_memory(), 3);
        // The oldest two were spilled: read back with their values, within the budget.
        assert_eq!(cache.get((0, [0, 0, 0])).as_deref(), Some(&*sums(0.0)));
        assert_eq!(cache.get((0, [1, 0, 0])).as_deref(), Some(&*sums(1.0)));
        assert!(cache.bytes <= cache.budget);
        assert!(cache.get((0, [9, 0, 0])).is_none());
        cache.insert((1, [0, 0, 0]), Arc::new(Summary::Constant(1.0)));
        assert_eq!(cache.in_memory(), 3);
        assert!(cache.get((0, [4, 0, 0])).is_some());
        assert_eq!(cache.get((1, [0, 0, 0])).as_deref(), Some(&Summary::Constant(1.0)));
    }

    #[test]
    fn without_a_spill_file_evicted_summaries_are_gone() {
        let mut cache = SummaryCache::new(32 * 32 * 32 * 4 + 64);
        cache.spill = None;
        cache.insert((0, [0, 0, 0]), sums(0.0));
        cache.insert((0, [1, 0, 0]), sums(1.0));
        assert!(cache.get((0, [0, 0, 0])).is_none());
        assert!(cache.get((0, [1, 0, 0])).is_some());
    }
}
