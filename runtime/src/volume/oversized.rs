//! Headers that claim absurd sizes, in every format: a grid beyond [`super::MAX_VOXELS`]
//! (100000^3 voxels), or more sample bytes than the file holds (raw data shorter than the claim,
//! compressed data that could not expand to it), give an error value before the sink is told
//! the grid, so neither a copy in memory nor a GPU texture is ever allocated for the claim.

use std::path::Path;

use super::dicom::tests::{Storage, axial};
use super::tests::{gzip, write, zlib};
use super::{LoadErrorKind, SampleSink, Samples, VolumeInfo, stream};

/// A sink that records whether a loader announced the grid or handed it samples.
#[derive(Default)]
struct Spy {
    begun: bool,
    samples: usize,
}

impl SampleSink for Spy {
    fn begin(&mut self, _: &VolumeInfo) -> Result<(), LoadErrorKind> {
        self.begun = true;
        Ok(())
    }

    fn reserve(&mut self, voxels: usize) -> Result<(), LoadErrorKind> {
        panic!("reserve({voxels}) for a claim that cannot be true");
    }

    fn samples(&mut self, chunk: &Samples) -> Result<(), LoadErrorKind> {
        self.samples += chunk.len();
        Ok(())
    }
}

/// Streams `path` and expects an error before the grid was announced; returns its message.
fn refused(path: &Path) -> String {
    let mut spy = Spy::default();
    let error = stream(path, &mut |_, _| {}, &mut spy).expect_err("an absurd header is an error");
    assert!(!spy.begun && spy.samples == 0, "{}: the sink was told the grid", path.display());
    assert!(!error.is_io(), "a content error, not an I/O one: {error}");
    error.kind.to_string()
}

fn nrrd(sizes: &str, encoding: &str, data: &[u8]) -> Vec<u8> {
    let mut bytes =
        format!("NRRD0004\ntype: short\ndimension: 3\nsizes: {sizes}\nencoding: {encoding}\nendian: little\n\n")
            .into_bytes();
    bytes.extend_from_slice(data);
    bytes
}

fn mha(sizes: &str, compressed: bool, data: &[u8]) -> Vec<u8> {
    let mut bytes = format!(
        "ObjectType = Image\nNDims = 3\nDimSize = {sizes}\nElementType = MET_SHORT\nCompressedData = {}\n\
         ElementDataFile = LOCAL\n",
        if compressed { "True" } else { "False" }
    )
    .into_bytes();
    bytes.extend_from_slice(data);
    bytes
}

#[test]
fn nrrd_claims_are_refused_before_the_grid_is_announced() {
    let dir = tempfile::tempdir().unwrap();
    let data = [0u8; 64];
    let huge = refused(&write(&dir, "huge.nrrd", &nrrd("100000 100000 100000", "raw", &data)));
    assert!(huge.starts_with("too large: 100000 x 100000 x 100000"), "{huge}");
    let short = refused(&write(&dir, "short.nrrd", &nrrd("1000 1000 1000", "raw", &data)));
    assert_eq!(short, "header says 2000000000 bytes of data, file has 64");
    let packed = gzip(&[0u8; 4096]);
    let gz = refused(&write(&dir, "small.nrrd", &nrrd("1000 1000 1000", "gzip", &packed)));
    assert_eq!(
        gz,
        format!("header says 2000000000 bytes of data, more than {} compressed bytes can hold", packed.len())
    );
    // A detached header whose data file is too short.
    std::fs::write(dir.path().join("v.raw"), data).unwrap();
    let detached =
        "NRRD0004\ntype: short\ndimension: 3\nsizes: 512 512 512\nencoding: raw\nendian: little\ndata file: v.raw\n\n";
    let message = refused(&write(&dir, "detached.nhdr", detached.as_bytes()));
    assert_eq!(message, "header says 268435456 bytes of data, file has 64");
}

#[test]
fn metaimage_claims_are_refused_before_the_grid_is_announced() {
    let dir = tempfile::tempdir().unwrap();
    let data = [0u8; 64];
    let huge = refused(&write(&dir, "huge.mha", &mha("100000 100000 100000", false, &data)));
    assert!(huge.starts_with("too large: "), "{huge}");
    let short = refused(&write(&dir, "short.mha", &mha("1000 1000 1000", false, &data)));
    assert_eq!(short, "header says 2000000000 bytes of data, file has 64");
    let packed = zlib(&[0u8; 4096]);
    let zipped = refused(&write(&dir, "small.mha", &mha("1000 1000 1000", true, &packed)));
    assert!(zipped.contains("more than") && zipped.contains("compressed bytes can hold"), "{zipped}");
    // A detached MetaImage header (`.mhd`) and its short data file.
    std::fs::write(dir.path().join("v.raw"), data).unwrap();
    let header =
        "ObjectType = Image\nNDims = 3\nDimSize = 1000 1000 1000\nElementType = MET_SHORT\nElementDataFile = v.raw\n";
    let mhd = refused(&write(&dir, "v.mhd", header.as_bytes()));
    assert_eq!(mhd, "header says 2000000000 bytes of data, file has 64");
}

#[test]
fn dicom_claims_are_refused_before_the_grid_is_announced() {
    // Rows and Columns say 60000 x 60000 (3.6e9 voxels) for one slice of 12 values.
    let dir = tempfile::tempdir().unwrap();
    let mut slices = axial(2, Storage::Uncompressed);
    for slice in &mut slices {
        (slice.columns, slice.rows) = (60000, 60000);
    }
    super::dicom::tests::write_shuffled(dir.path(), &slices);
    let huge = refused(dir.path());
    assert!(huge.starts_with("too large: 60000 x 60000 x 2"), "{huge}");
    // 30000 x 30000 x 2 (1.8e9 voxels, under the limit) in files of a few hundred bytes: the
    // error names a file.
    let dir = tempfile::tempdir().unwrap();
    for slice in &mut slices {
        (slice.columns, slice.rows) = (30000, 30000);
    }
    super::dicom::tests::write_shuffled(dir.path(), &slices);
    let message = refused(dir.path());
    assert!(message.contains("IM") && message.contains("header says 900000000 bytes of data"), "{message}");
}
