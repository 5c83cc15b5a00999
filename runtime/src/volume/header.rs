//! What a volume's header must satisfy before any sample is read, whatever its format, and
//! reading a header alone (`vrsc build` checks the scene's volume files this way).
//!
//! Voxel spacing: a grid whose voxels are absurdly large or small (1e20 mm, 1e-30 mm) is a
//! corrupt or mis-scaled header, and its world coordinates would overflow or underflow `f32`
//! in the renderer's matrices. Each axis's spacing must lie in [`MIN_SPACING`, `MAX_SPACING`]
//! (millimetres, or the file's own unit), and the axes may differ by at most [`MAX_ANISOTROPY`].

use super::{LoadError, LoadErrorKind, SampleSink, Samples, VolumeInfo, spacing_of, stream};
use std::path::Path;

/// The smallest voxel spacing accepted: 1 nm in millimetres (beyond any microscope volume).
pub(crate) const MIN_SPACING: f32 = 1e-6;
/// The largest voxel spacing accepted: 1 km in millimetres.
pub(crate) const MAX_SPACING: f32 = 1e6;
/// The largest ratio between the spacings of two axes.
pub(crate) const MAX_ANISOTROPY: f32 = 1e4;

/// Checks the voxel spacing of a header's grid.
pub(super) fn check_spacing(info: &VolumeInfo) -> Result<(), LoadErrorKind> {
    let axes = [info.grid_to_world.x_axis, info.grid_to_world.y_axis, info.grid_to_world.z_axis];
    // In f64: the squares of a spacing of 1e20 overflow f32.
    let lengths = axes.map(|a| a.truncate().as_dvec3().length());
    let allowed = f64::from(MIN_SPACING)..=f64::from(MAX_SPACING);
    if let Some(bad) = lengths.iter().find(|l| !allowed.contains(*l)) {
        return Err(LoadErrorKind::Header(format!(
            "voxel spacing {:e} is outside {MIN_SPACING:e} to {MAX_SPACING:e} (spacings {}); the header's \
             voxel sizes or transform are corrupt or in the wrong unit",
            *bad as f32,
            lengths.map(|l| format!("{:e}", l as f32)).join(" x ")
        )));
    }
    let spacing = spacing_of(&info.grid_to_world);
    let (lo, hi) = spacing.iter().fold((f32::MAX, 0.0f32), |(lo, hi), &s| (lo.min(s), hi.max(s)));
    if hi / lo > MAX_ANISOTROPY {
        return Err(LoadErrorKind::Header(format!(
            "voxel spacings {} differ by more than a factor of {MAX_ANISOTROPY:e}",
            spacing.map(|l| format!("{l:e}")).join(" x ")
        )));
    }
    Ok(())
}

/// A sink that checks the header a loader hands it before passing anything on.
pub(super) struct Checked<'a> {
    pub(super) inner: &'a mut dyn SampleSink,
}

impl SampleSink for Checked<'_> {
    fn begin(&mut self, info: &VolumeInfo) -> Result<(), LoadErrorKind> {
        check_spacing(info)?;
        self.inner.begin(info)
    }

    fn reserve(&mut self, voxels: usize) -> Result<(), LoadErrorKind> {
        self.inner.reserve(voxels)
    }

    fn samples(&mut self, chunk: &Samples) -> Result<(), LoadErrorKind> {
        self.inner.samples(chunk)
    }
}

/// Reads and validates the header of the volume at `path` (a file, or a DICOM folder's slice
/// headers) without reading its samples: the shape, placement and scaling a load would give.
/// Errors the samples alone can reveal (a short or corrupt data section) are left to the load.
pub fn header(path: &Path) -> Result<VolumeInfo, LoadError> {
    /// Stops the stream at `begin`, after the loader and [`Checked`] accepted the header.
    struct Stop(Option<VolumeInfo>);
    impl SampleSink for Stop {
        fn begin(&mut self, info: &VolumeInfo) -> Result<(), LoadErrorKind> {
            self.0 = Some(*info);
            Err(LoadErrorKind::Header(String::from("(stopped after the header)")))
        }
        fn samples(&mut self, _: &Samples) -> Result<(), LoadErrorKind> {
            Ok(())
        }
    }
    let mut stop = Stop(None);
    match stream(path, &mut |_, _| {}, &mut stop) {
        Ok(info) => Ok(info),
        Err(e) => stop.0.ok_or(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Mat4, Vec3};

    fn info(spacing: [f32; 3]) -> VolumeInfo {
        VolumeInfo {
            dims: [16, 16, 16],
            grid_to_world: Mat4::from_scale(Vec3::from(spacing)),
            scaling: super::super::Scaling::IDENTITY,
        }
    }

    #[test]
    fn absurd_spacings_are_header_errors() {
        assert!(check_spacing(&info([1.0, 0.5, 2.5])).is_ok());
        assert!(check_spacing(&info([1e-3, 1e-3, 1e-3])).is_ok(), "micrometre voxels");
        for spacing in [[1e20; 3], [1e-30; 3], [1.0, 1.0, f32::INFINITY], [1.0, f32::NAN, 1.0], [0.0, 1.0, 1.0]] {
            let e = check_spacing(&info(spacing)).expect_err("refused").to_string();
            assert!(e.starts_with("voxel spacing"), "{e}");
        }
        let e = check_spacing(&info([1e-5, 1.0, 1.0])).expect_err("too anisotropic").to_string();
        assert!(e.contains("differ by more than"), "{e}");
    }

    #[test]
    fn a_header_is_read_without_its_samples() {
        let dir = tempfile::tempdir().unwrap();
        let mhd = dir.path().join("v.mhd");
        // A spacing of 1e7 mm is refused from the header alone.
        std::fs::write(&mhd, "ObjectType = Image\nNDims = 3\nDimSize = 4 3 2\nElementType = MET_SHORT\nElementSpacing = 1e7 1e7 1e7\nElementDataFile = v.raw\n").unwrap();
        std::fs::write(dir.path().join("v.raw"), [0u8; 48]).unwrap();
        let e = header(&mhd).expect_err("absurd spacing").to_string();
        assert!(e.contains("voxel spacing"), "{e}");
        std::fs::write(&mhd, "ObjectType = Image\nNDims = 3\nDimSize = 4 3 2\nElementType = MET_SHORT\nElementSpacing = 1 1 2\nElementDataFile = v.raw\n").unwrap();
        assert_eq!(header(&mhd).expect("a good header").dims, [4, 3, 2]);
    }
}
