//! The automatic value window: percentiles of a volume's data values, from a histogram, so a
//! few extreme voxels (metal in a CT, a hot pixel in an MR) do not stretch the window.

use super::{LoadErrorKind, SampleSink, Samples, Scaling, Volume, VolumeInfo};

/// The percentiles the automatic window spans.
pub(crate) const AUTO_PERCENTILES: [f64; 2] = [0.5, 99.5];

/// Bins of the histogram over the value range: fine enough for a window within 0.025% of the
/// range.
const BINS: usize = 4096;

/// A histogram of data values over a known range, filled from stored samples.
#[derive(Clone, Debug)]
pub(crate) struct Histogram {
    range: [f32; 2],
    scaling: Scaling,
    bins: Vec<u64>,
}

impl Histogram {
    /// An empty histogram over `range` (data units) of samples stored with `scaling`.
    pub(crate) fn new(range: [f32; 2], scaling: Scaling) -> Histogram {
        Histogram { range, scaling, bins: vec![0; BINS] }
    }

    /// Counts one stored sample (non-finite ones are not counted).
    pub(crate) fn add(&mut self, stored: f32) {
        let value = self.scaling.apply(stored);
        if !value.is_finite() {
            return;
        }
        let [lo, hi] = self.range;
        let t = if hi > lo { (value - lo) / (hi - lo) } else { 0.0 };
        let bin = ((t * BINS as f32) as usize).min(BINS - 1);
        self.bins[bin] += 1;
    }

    /// The value below which `percent` of the counted values lie (interpolated in its bin); the
    /// range's low end for an empty histogram.
    pub(crate) fn percentile(&self, percent: f64) -> f32 {
        let total: u64 = self.bins.iter().sum();
        let [lo, hi] = self.range;
        if total == 0 {
            return lo;
        }
        let target = (percent / 100.0).clamp(0.0, 1.0) * total as f64;
        let mut below = 0u64;
        for (bin, &count) in self.bins.iter().enumerate() {
            if count > 0 && (below + count) as f64 >= target {
                let within = ((target - below as f64) / count as f64).clamp(0.0, 1.0);
                let t = (bin as f64 + within) / BINS as f64;
                return lo + (hi - lo) * t as f32;
            }
            below += count;
        }
        hi
    }

    /// The window from [`AUTO_PERCENTILES`]; the whole range when they coincide (a volume of
    /// one or two values).
    pub(crate) fn auto_window(&self) -> [f32; 2] {
        let [a, b] = AUTO_PERCENTILES.map(|p| self.percentile(p));
        if b > a { [a, b] } else { self.range }
    }
}

/// The automatic window of a volume in memory: the one its source gives it (`own_window`), else
/// `Histogram::auto_window`.
pub fn auto_window(volume: &Volume) -> [f32; 2] {
    if let Some(window) = volume.own_window {
        return window;
    }
    let mut histogram = Histogram::new(volume.range, volume.scaling);
    volume.samples.for_each(0..volume.samples.len(), |s| histogram.add(s));
    histogram.auto_window()
}

/// Fills the histogram from a loader (the pass after the range pass of a streamed file).
impl SampleSink for Histogram {
    fn begin(&mut self, info: &VolumeInfo) -> Result<(), LoadErrorKind> {
        self.scaling = info.scaling;
        Ok(())
    }

    fn samples(&mut self, chunk: &Samples) -> Result<(), LoadErrorKind> {
        chunk.for_each(0..chunk.len(), |s| self.add(s));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use glam::Mat4;

    use super::*;

    #[test]
    fn one_outlier_does_not_move_the_automatic_window() {
        // A CT-like volume: air, soft tissue and bone, plus one 30000 HU voxel.
        let mut values: Vec<f32> = (0..10_000).map(|i| [-1000.0, 40.0, 700.0][i % 3] + (i % 7) as f32).collect();
        let without = auto_window(&Volume::new([10_000, 1, 1], Mat4::IDENTITY, values.clone()));
        values[5] = 30_000.0;
        let with = auto_window(&Volume::new([10_000, 1, 1], Mat4::IDENTITY, values));
        assert!((without[0] + 1000.0).abs() < 2.0 && (without[1] - 706.0).abs() < 2.0, "{without:?}");
        // The histogram's bins are 7.6 HU wide over the stretched range.
        assert!((with[0] - without[0]).abs() < 10.0 && (with[1] - without[1]).abs() < 10.0, "{with:?} vs {without:?}");
    }

    #[test]
    fn percentiles_interpolate_and_degenerate_volumes_keep_their_range() {
        let ramp = Volume::new([1000, 1, 1], Mat4::IDENTITY, (0..1000).map(|i| i as f32).collect());
        let mut h = Histogram::new(ramp.range, ramp.scaling);
        ramp.samples.for_each(0..1000, |s| h.add(s));
        assert!((h.percentile(50.0) - 500.0).abs() < 1.0, "{}", h.percentile(50.0));
        assert!((h.percentile(0.5) - 5.0).abs() < 1.0);
        let constant = Volume::new([4, 1, 1], Mat4::IDENTITY, vec![3.0; 4]);
        assert_eq!(auto_window(&constant), [3.0, 3.0]);
        let mut empty = Histogram::new([1.0, 2.0], Scaling::IDENTITY);
        empty.add(f32::NAN);
        assert_eq!(empty.percentile(50.0), 1.0);
    }
}
