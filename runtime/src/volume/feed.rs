//! Volumes an application holds in memory (an array of a Python session, a simulation's
//! output) rather than in files. A scene names such a volume in a `[[volume]]` table as usual;
//! the renderer is given a [`VolumeFeed`] under that name ([`crate::RenderOptions::feeds`]) and
//! streams it into its texture exactly as it streams a file: the same header checks, the same
//! sink, a slab at a time, so the samples are read where the application keeps them and never
//! copied whole.

use super::{LoadErrorKind, SampleSink, VolumeInfo, header};
use std::collections::BTreeMap;
use std::fmt;
use std::sync::Arc;

/// A volume in the application's memory.
pub trait VolumeFeed: Send + Sync {
    /// Its grid, placement and value scaling.
    fn info(&self) -> VolumeInfo;

    /// Hands every sample to `sink.samples` in voxel order (x fastest, then y, then z), in
    /// chunks of one sample type. `begin` has been called already.
    fn stream(&self, sink: &mut dyn SampleSink) -> Result<(), LoadErrorKind>;

    /// A number that changes whenever the samples or the grid change: a renderer loads the
    /// volume again when it differs from the one it loaded.
    fn version(&self) -> u64;
}

/// Streams `feed` into `sink` after the checks every file's header passes.
pub(crate) fn stream_feed(feed: &dyn VolumeFeed, sink: &mut dyn SampleSink) -> Result<VolumeInfo, LoadErrorKind> {
    let info = feed.info();
    let voxels: u64 = info.dims.iter().map(|&d| u64::from(d)).product();
    if voxels > super::MAX_VOXELS {
        let dims = info.dims.iter().map(|&d| u64::from(d)).collect();
        return Err(LoadErrorKind::TooLarge { dims, voxels: u128::from(voxels) });
    }
    let sink = &mut header::Checked { inner: sink };
    sink.begin(&info)?;
    feed.stream(sink)?;
    Ok(info)
}

/// The feeds of a scene's volumes, by the volume's name in the scene.
#[derive(Clone, Default)]
pub struct Feeds(BTreeMap<String, Arc<dyn VolumeFeed>>);

impl Feeds {
    pub(crate) fn new() -> Feeds {
        Feeds::default()
    }

    /// Feeds volume `name` from `feed` (replacing an earlier feed of that name).
    pub fn insert(&mut self, name: impl Into<String>, feed: Arc<dyn VolumeFeed>) {
        self.0.insert(name.into(), feed);
    }

    pub(crate) fn get(&self, name: &str) -> Option<&Arc<dyn VolumeFeed>> {
        self.0.get(name)
    }
}

/// Names and versions, not samples.
impl fmt::Debug for Feeds {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_map().entries(self.0.iter().map(|(name, feed)| (name, feed.version()))).finish()
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Samples, Scaling};
    use super::*;
    use glam::{Mat4, Vec3};

    /// A 2x2x2 grid of the values 0..8 in one chunk.
    struct Ramp {
        spacing: f32,
    }

    impl VolumeFeed for Ramp {
        fn info(&self) -> VolumeInfo {
            VolumeInfo {
                dims: [2, 2, 2],
                grid_to_world: Mat4::from_scale(Vec3::splat(self.spacing)),
                scaling: Scaling::IDENTITY,
            }
        }
        fn stream(&self, sink: &mut dyn SampleSink) -> Result<(), LoadErrorKind> {
            sink.samples(&Samples::F32((0..8).map(|v| v as f32).collect()))
        }
        fn version(&self) -> u64 {
            1
        }
    }

    #[derive(Default)]
    struct Collect(Vec<f32>);
    impl SampleSink for Collect {
        fn begin(&mut self, _: &VolumeInfo) -> Result<(), LoadErrorKind> {
            Ok(())
        }
        fn samples(&mut self, chunk: &Samples) -> Result<(), LoadErrorKind> {
            self.0.extend(chunk.to_f32());
            Ok(())
        }
    }

    #[test]
    fn a_feed_streams_its_samples_after_the_header_checks() {
        let mut sink = Collect::default();
        let info = stream_feed(&Ramp { spacing: 0.5 }, &mut sink).expect("a good feed");
        assert_eq!(info.dims, [2, 2, 2]);
        assert_eq!(sink.0, (0..8).map(|v| v as f32).collect::<Vec<_>>());
        let mut sink = Collect::default();
        let e = stream_feed(&Ramp { spacing: 1e9 }, &mut sink).expect_err("absurd spacing").to_string();
        assert!(e.contains("voxel spacing"), "{e}");
        assert!(sink.0.is_empty(), "no samples after a refused header");
    }
}
