//! A [`BrickSource`] over the samples of an uncompressed volume file (NRRD `encoding: raw`,
//! MetaImage without `CompressedData`, `.nii`), memory-mapped and read a brick at a time: a
//! volume larger than memory is never read whole, and opening one costs its header.
//!
//! - Level 0 is read straight from the mapping: each row of a brick's box converted from the
//!   file's sample type and byte order to `f32` data units (with the file's scaling), exactly as
//!   a load would convert it, so the bricks equal [`super::pyramid::PyramidSource`]'s.
//! - The coarser levels are built on demand by box averaging (`lazy_levels`, as for a Zarr
//!   array without a pyramid), the finer bricks kept in a cache of the size the caller gives (see
//!   [`super::lazy_levels::cache_bytes`]).
//! - Memory: the mapping's pages a read touched are handed back to the kernel after the read
//!   (`madvise(MADV_DONTNEED)` on Unix), so reading the whole file (for the coarsest level) does
//!   not leave the process holding it; the page cache keeps them for the next read.
//! - The file's length is checked against its header before it is mapped. A file truncated by
//!   another process while mapped would still fault (SIGBUS): a mapping cannot guard that.

use std::fs::File;
use std::ops::Range;
#[cfg(test)]
use std::path::Path;

use memmap2::{Mmap, MmapOptions};

use super::grid::{GridSource, SourceGrid, spread};
use super::lazy_levels::{box_index, stored_box, sub};
use super::pyramid::cut_brick;
use super::{BrickData, BrickError, BrickSource, levels_for};
use crate::volume::{RawData, ScalarType, Scaling};

/// An uncompressed volume file, memory-mapped and read a brick at a time.
pub(crate) struct MappedSource {
    /// The data file's name (for messages), the pyramid and the world placement; levels 1..
    /// are built from level 0.
    grid: SourceGrid,
    /// The samples, and nothing else of the file.
    map: Mmap,
    sample: ScalarType,
    big_endian: bool,
    scaling: Scaling,
}

impl MappedSource {
    #[cfg(test)]
    /// Maps the samples of the volume file at `path` when they are stored uncompressed;
    /// `None` when they are not (or `path` is a DICOM folder): such a file must be loaded.
    pub(crate) fn open(path: &Path) -> Result<Option<MappedSource>, BrickError> {
        let raw = crate::volume::raw_layout(path).map_err(|e| BrickError(e.to_string()))?;
        raw.map(|raw| MappedSource::new(&raw, 256 << 20)).transpose()
    }

    /// Maps the samples `raw` places, checking first that the file still holds them, and reads a
    /// few bricks for the value range; coarse levels are built through a cache of `cache_bytes`.
    pub(crate) fn new(raw: &RawData, cache_bytes: u64) -> Result<MappedSource, BrickError> {
        let name = raw.file.file_name().map_or_else(|| raw.file.display().to_string(), |n| n.to_string_lossy().into());
        let map = map_samples(raw).map_err(|m| BrickError(format!("{name}: {m}")))?;
        let source = MappedSource {
            grid: SourceGrid::new(name, levels_for(raw.info.dims), raw.info.grid_to_world, cache_bytes),
            map,
            sample: raw.sample,
            big_endian: raw.big_endian,
            scaling: raw.info.scaling,
        };
        let range = source.estimate_range()?;
        source.grid.range.get_or_init(|| range);
        Ok(source)
    }

    /// The source with its coarse levels made by `coarsening` (the mean by default).
    pub(crate) fn coarsened_by(mut self, coarsening: super::Coarsening) -> MappedSource {
        self.grid.lazy.coarsening = coarsening;
        self
    }

    /// The finite range of up to [`super::grid::RANGE_BRICKS_PER_AXIS`]^3 level-0 bricks spread
    /// evenly over the volume (all of them in a small one): the true extremes may lie elsewhere,
    /// but reading every voxel at open would read the whole file.
    fn estimate_range(&self) -> Result<[f32; 2], BrickError> {
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        let [bx, by, bz] = self.grid.levels[0].bricks.map(spread);
        for &z in &bz {
            for &y in &by {
                for &x in &bx {
                    let values = match self.read(0, [x, y, z])? {
                        BrickData::Constant(v) => vec![v],
                        BrickData::Voxels(v) => v,
                    };
                    for v in values.into_iter().filter(|v| v.is_finite()) {
                        lo = lo.min(v);
                        hi = hi.max(v);
                    }
                }
            }
        }
        Ok(if lo <= hi { [lo, hi] } else { [0.0, 0.0] })
    }

    /// Brick `brick` of level 0: the rows of its box converted from the mapping.
    fn read_stored(&self, brick: [u32; 3]) -> Result<BrickData, BrickError> {
        let dims = self.grid.levels[0].dims;
        let (lo, hi) = stored_box(dims, brick);
        let size = sub(hi, lo);
        let sample = self.sample.size() as usize;
        let row_bytes = size[0] as usize * sample;
        let byte = |x: u32, y: u32, z: u32| {
            ((z as usize * dims[1] as usize + y as usize) * dims[0] as usize + x as usize) * sample
        };
        let mut values = Vec::with_capacity(size.iter().map(|&n| n as usize).product());
        for z in lo[2]..hi[2] {
            for y in lo[1]..hi[1] {
                let start = byte(lo[0], y, z);
                let row = self.map.get(start..start + row_bytes).ok_or_else(|| {
                    self.grid.error(format_args!("row {y} of slice {z} lies past the {} mapped bytes", self.map.len()))
                })?;
                decode_row(self.sample, self.big_endian, self.scaling, row, &mut values);
            }
        }
        self.release(byte(lo[0], lo[1], lo[2])..byte(hi[0] - 1, hi[1] - 1, hi[2] - 1) + sample);
        Ok(cut_brick(dims, brick, |p| values[box_index(sub(p, lo), size)]).collapse())
    }

    /// Hands the mapped pages of `bytes` back to the kernel: the process no longer counts them,
    /// and the next read of them finds them in the page cache.
    #[cfg(unix)]
    fn release(&self, bytes: Range<usize>) {
        // SAFETY: the mapping is shared, read-only and of a file: MADV_DONTNEED drops the pages
        // from this process's page tables, and any later access (a concurrent read on another
        // loader thread included) faults them in again with the same bytes from the file. Only
        // private or anonymous mappings lose their content. A failure only means the pages stay.
        let _ =
            unsafe { self.map.unchecked_advise_range(memmap2::UncheckedAdvice::DontNeed, bytes.start, bytes.len()) };
    }

    #[cfg(not(unix))]
    fn release(&self, _: Range<usize>) {}
}

impl GridSource for MappedSource {
    fn grid(&self) -> &SourceGrid {
        &self.grid
    }

    fn read_brick(&self, level: usize, brick: [u32; 3]) -> Result<BrickData, BrickError> {
        match level {
            0 => self.read_stored(brick),
            _ => self.grid.lazy.build(&self.grid.levels, level, brick, &|l, b| self.read(l, b)),
        }
    }
}

/// Maps the bytes of `raw`'s samples, after checking that the file holds them all: a mapping
/// past the end of a file would fault on access rather than fail here.
fn map_samples(raw: &RawData) -> Result<Mmap, String> {
    let file = File::open(&raw.file).map_err(|e| format!("cannot open: {e}"))?;
    let len = file.metadata().map_err(|e| format!("cannot read: {e}"))?.len();
    let bytes = raw.bytes();
    if raw.offset.checked_add(bytes).is_none_or(|end| end > len) {
        return Err(format!(
            "the header places {bytes} bytes of samples at byte {}, but the file has {len} bytes",
            raw.offset
        ));
    }
    let bytes = usize::try_from(bytes).map_err(|_| format!("{bytes} bytes of samples are more than can be mapped"))?;
    // SAFETY: the mapping is read-only and its range lies within the file as it is now. Another
    // process writing the file would change the bytes read (never memory safety: they are
    // copied out as numbers); one truncating it would make a read fault, which no check here
    // can rule out (module docs).
    unsafe { MmapOptions::new().offset(raw.offset).len(bytes).map(&file) }.map_err(|e| format!("cannot map: {e}"))
}

/// Appends the samples of `row` (whole samples of `sample`, in the file's byte order) to `out`
/// in data units: `stored as f32`, then the scaling, as a loaded volume computes its values.
fn decode_row(sample: ScalarType, big_endian: bool, scaling: Scaling, row: &[u8], out: &mut Vec<f32>) {
    fn each<const N: usize>(row: &[u8], out: &mut Vec<f32>, s: Scaling, stored: impl Fn([u8; N]) -> f32) {
        out.extend(row.as_chunks::<N>().0.iter().map(|&b| s.apply(stored(b))));
    }
    let s = scaling;
    match (sample, big_endian) {
        (ScalarType::U8, _) => each(row, out, s, |[b]: [u8; 1]| f32::from(b)),
        (ScalarType::I8, _) => each(row, out, s, |[b]: [u8; 1]| f32::from(b as i8)),
        (ScalarType::U16, false) => each(row, out, s, |b| f32::from(u16::from_le_bytes(b))),
        (ScalarType::U16, true) => each(row, out, s, |b| f32::from(u16::from_be_bytes(b))),
        (ScalarType::I16, false) => each(row, out, s, |b| f32::from(i16::from_le_bytes(b))),
        (ScalarType::I16, true) => each(row, out, s, |b| f32::from(i16::from_be_bytes(b))),
        (ScalarType::U32, false) => each(row, out, s, |b| u32::from_le_bytes(b) as f32),
        (ScalarType::U32, true) => each(row, out, s, |b| u32::from_be_bytes(b) as f32),
        (ScalarType::I32, false) => each(row, out, s, |b| i32::from_le_bytes(b) as f32),
        (ScalarType::I32, true) => each(row, out, s, |b| i32::from_be_bytes(b) as f32),
        (ScalarType::F32, false) => each(row, out, s, f32::from_le_bytes),
        (ScalarType::F32, true) => each(row, out, s, f32::from_be_bytes),
        (ScalarType::F64, false) => each(row, out, s, |b| f64::from_le_bytes(b) as f32),
        (ScalarType::F64, true) => each(row, out, s, |b| f64::from_be_bytes(b) as f32),
    }
}

#[cfg(test)]
mod tests {
    use std::io::Write;
    use std::path::PathBuf;

    use super::*;
    use crate::bricks::pyramid::PyramidSource;

    /// A grid with three levels, odd sizes at level 1 (so averaging meets odd edges) and partial
    /// edge bricks.
    const DIMS: [u32; 3] = [150, 70, 66];

    /// Values of a grid of `dims` (x fastest), each as its bytes.
    fn bytes<const N: usize>(dims: [u32; 3], value: impl Fn([u32; 3]) -> [u8; N]) -> Vec<u8> {
        let mut out = Vec::new();
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    out.extend(value([x, y, z]));
                }
            }
        }
        out
    }

    /// Integers of both signs beyond a byte.
    fn short([x, y, z]: [u32; 3]) -> i16 {
        ((x * 7 + y * 13 + z * 11) % 900) as i16 - 450
    }

    /// Non-integers, so averages round as they do in [`PyramidSource`] or not at all.
    fn float([x, y, z]: [u32; 3]) -> f32 {
        (x as f32 * 0.37 + y as f32 * 1.3 - z as f32 * 0.71).sin() * 1000.0
    }

    fn write(dir: &tempfile::TempDir, name: &str, content: &[u8]) -> PathBuf {
        let path = dir.path().join(name);
        std::fs::write(&path, content).unwrap();
        path
    }

    /// A NRRD header (without the blank line that ends an attached one) for `DIMS`.
    fn nrrd_header(ty: &str, endian: &str, extra: &str) -> String {
        let [x, y, z] = DIMS;
        format!(
            "NRRD0004\ntype: {ty}\ndimension: 3\nsizes: {x} {y} {z}\nendian: {endian}\nencoding: raw\n\
             space: left-posterior-superior\nspace directions: (0.5,0,0) (0,0.7,0) (0,0,2)\n\
             space origin: (1,2,3)\n{extra}"
        )
    }

    /// `header` followed by `data` in one file.
    fn attached(header: &str, data: &[u8]) -> Vec<u8> {
        let mut file = format!("{header}\n").into_bytes();
        file.extend_from_slice(data);
        file
    }

    /// A NIfTI-1 file of `DIMS` with `datatype`, scaling 0.5 x - 10, data after 352 bytes.
    fn nifti(datatype: i16, bitpix: i16, big_endian: bool, data: &[u8]) -> Vec<u8> {
        let mut h = vec![0u8; 348];
        let mut put = |at: usize, b: &[u8]| h[at..at + b.len()].copy_from_slice(b);
        let i16b = |v: i16| if big_endian { v.to_be_bytes() } else { v.to_le_bytes() };
        let f32b = |v: f32| if big_endian { v.to_be_bytes() } else { v.to_le_bytes() };
        put(0, &if big_endian { 348i32.to_be_bytes() } else { 348i32.to_le_bytes() });
        let [x, y, z] = DIMS.map(|d| d as i16);
        for (i, d) in [3, x, y, z, 1, 1, 1, 1].into_iter().enumerate() {
            put(40 + 2 * i, &i16b(d));
        }
        put(70, &i16b(datatype));
        put(72, &i16b(bitpix));
        for (i, p) in [1.0, 0.8, 0.8, 1.5].into_iter().enumerate() {
            put(76 + 4 * i, &f32b(p));
        }
        put(108, &f32b(352.0));
        put(112, &f32b(0.5));
        put(116, &f32b(-10.0));
        put(344, b"n+1\0");
        h.extend_from_slice(&[0; 4]);
        h.extend_from_slice(data);
        h
    }

    /// The file mapped gives the bricks (every level, apron and edge), levels, placement and
    /// range of the same file loaded whole into a [`PyramidSource`].
    fn assert_same_as_loaded(path: &Path) {
        let mapped = MappedSource::open(path).unwrap().expect("uncompressed data is mapped");
        let loaded = crate::volume::load(path, &mut |_, _| {}).unwrap();
        let reference = PyramidSource::from_volume(&loaded, crate::bricks::Coarsening::Mean);
        assert_eq!(mapped.levels(), reference.levels());
        assert_eq!(mapped.levels().len(), 3);
        assert_eq!(mapped.grid_to_world(), reference.grid_to_world());
        // Level 0 has 3 x 2 x 2 bricks: all of them were read for the range.
        assert_eq!(mapped.range(), loaded.range);
        for (l, level) in mapped.levels().iter().enumerate() {
            for z in 0..level.bricks[2] {
                for y in 0..level.bricks[1] {
                    for x in 0..level.bricks[0] {
                        let (a, b) = (mapped.read(l, [x, y, z]).unwrap(), reference.read(l, [x, y, z]).unwrap());
                        assert!(a == b, "{}: level {l} brick {:?} differs", path.display(), [x, y, z]);
                    }
                }
            }
        }
    }

    #[test]
    fn nrrd_int16_and_float_of_either_byte_order_read_as_loaded() {
        let dir = tempfile::tempdir().unwrap();
        let le = bytes(DIMS, |p| short(p).to_le_bytes());
        let path = write(&dir, "le.nrrd", &attached(&nrrd_header("short", "little", ""), &le));
        assert_same_as_loaded(&path);
        let be = bytes(DIMS, |p| short(p).to_be_bytes());
        let path = write(&dir, "be.nrrd", &attached(&nrrd_header("int16", "big", ""), &be));
        assert_same_as_loaded(&path);
        let be = bytes(DIMS, |p| float(p).to_be_bytes());
        let path = write(&dir, "be_float.nrrd", &attached(&nrrd_header("float", "big", ""), &be));
        assert_same_as_loaded(&path);
        let le = bytes(DIMS, |p| f64::from(float(p)).to_le_bytes());
        let path = write(&dir, "le_double.nrrd", &attached(&nrrd_header("double", "little", ""), &le));
        assert_same_as_loaded(&path);
    }

    #[test]
    fn detached_nrrd_with_line_and_byte_skips_reads_as_loaded() {
        let dir = tempfile::tempdir().unwrap();
        let mut data = b"a line to skip\nabc".to_vec();
        data.extend(bytes(DIMS, |p| float(p).to_le_bytes()));
        write(&dir, "v.raw", &data);
        let extra = "data file: v.raw\nline skip: 1\nbyte skip: 3\n";
        let path = write(&dir, "v.nhdr", nrrd_header("float", "little", extra).as_bytes());
        assert_same_as_loaded(&path);
        let raw = crate::volume::raw_layout(&path).unwrap().unwrap();
        assert_eq!((raw.file, raw.offset), (dir.path().join("v.raw"), 18));
        // `byte skip: -1`: the samples end the file, whatever precedes them.
        let mut data = b"anything".to_vec();
        data.extend(bytes(DIMS, |p| short(p).to_be_bytes()));
        let path = write(&dir, "end.nrrd", &attached(&nrrd_header("short", "big", "byte skip: -1\n"), &data));
        assert_same_as_loaded(&path);
    }

    #[test]
    fn metaimage_mhd_and_mha_read_as_loaded() {
        let dir = tempfile::tempdir().unwrap();
        let [x, y, z] = DIMS;
        let header = |ty: &str, msb: &str, file: &str| {
            format!(
                "ObjectType = Image\nNDims = 3\nDimSize = {x} {y} {z}\nElementType = {ty}\n\
                 ElementSpacing = 1 1 2\nOffset = 5 6 7\nBinaryDataByteOrderMSB = {msb}\nElementDataFile = {file}\n"
            )
        };
        write(&dir, "v.raw", &bytes(DIMS, |p| (short(p) as u16).to_be_bytes()));
        let path = write(&dir, "v.mhd", header("MET_USHORT", "True", "v.raw").as_bytes());
        assert_same_as_loaded(&path);
        let mut file = header("MET_INT", "False", "LOCAL").into_bytes();
        file.extend(bytes(DIMS, |p| (i32::from(short(p)) * 1000).to_le_bytes()));
        let path = write(&dir, "v.mha", &file);
        assert_same_as_loaded(&path);
    }

    #[test]
    fn nifti_of_either_byte_order_reads_as_loaded_with_its_scaling() {
        let dir = tempfile::tempdir().unwrap();
        let le = bytes(DIMS, |p| short(p).to_le_bytes());
        assert_same_as_loaded(&write(&dir, "le.nii", &nifti(4, 16, false, &le)));
        let be = bytes(DIMS, |p| float(p).to_be_bytes());
        let path = write(&dir, "be.nii", &nifti(16, 32, true, &be));
        assert_same_as_loaded(&path);
        let raw = crate::volume::raw_layout(&path).unwrap().unwrap();
        assert_eq!((raw.offset, raw.sample, raw.big_endian), (352, ScalarType::F32, true));
        assert_eq!(raw.info.scaling, Scaling { slope: 0.5, intercept: -10.0 });
    }

    #[test]
    fn compressed_files_are_not_mapped() {
        let dir = tempfile::tempdir().unwrap();
        let gz = |b: &[u8]| {
            let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
            e.write_all(b).unwrap();
            e.finish().unwrap()
        };
        let data = bytes(DIMS, |p| short(p).to_le_bytes());
        let header = nrrd_header("short", "little", "").replace("encoding: raw", "encoding: gzip");
        let nrrd = write(&dir, "v.nrrd", &attached(&header, &gz(&data)));
        let nii = write(&dir, "v.nii.gz", &gz(&nifti(4, 16, false, &data)));
        let [x, y, z] = DIMS;
        let mut zlib = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
        zlib.write_all(&data).unwrap();
        let mut mha = format!(
            "NDims = 3\nDimSize = {x} {y} {z}\nElementType = MET_SHORT\nCompressedData = True\nElementDataFile = LOCAL\n"
        )
        .into_bytes();
        mha.extend(zlib.finish().unwrap());
        let mha = write(&dir, "v.mha", &mha);
        for path in [nrrd, nii, mha, dir.path().to_path_buf()] {
            assert!(MappedSource::open(&path).unwrap().is_none(), "{}", path.display());
        }
    }

    #[test]
    fn files_shorter_than_their_headers_claim_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let data = bytes(DIMS, |p| short(p).to_le_bytes());
        let short_data = &data[..data.len() - 1];
        let nrrd = write(&dir, "v.nrrd", &attached(&nrrd_header("short", "little", ""), short_data));
        let e = MappedSource::open(&nrrd).err().expect("a short NRRD is refused").0;
        assert!(e.contains("v.nrrd") && e.contains(&format!("header says {} bytes of data", data.len())), "{e}");
        let nii = write(&dir, "v.nii", &nifti(4, 16, false, short_data));
        let e = MappedSource::open(&nii).err().expect("a short NIfTI is refused").0;
        assert!(e.contains("v.nii") && e.contains("header says"), "{e}");
        let header_only = write(&dir, "h.nii", &nifti(4, 16, false, &[])[..350]);
        let e = MappedSource::open(&header_only).err().expect("data before vox_offset's end").0;
        assert!(e.contains("ends before its data"), "{e}");
        let nhdr = write(&dir, "v.nhdr", nrrd_header("short", "little", "data file: none.raw\n").as_bytes());
        let e = MappedSource::open(&nhdr).err().expect("a missing data file is refused").0;
        assert!(e.contains("none.raw"), "{e}");
        // A file cut after its header was read is caught before it is mapped.
        let path = write(&dir, "cut.nrrd", &attached(&nrrd_header("short", "little", ""), &data));
        let raw = crate::volume::raw_layout(&path).unwrap().unwrap();
        std::fs::OpenOptions::new().write(true).open(&path).unwrap().set_len(raw.offset + 100).unwrap();
        let e = MappedSource::new(&raw, 1 << 20).err().expect("a cut file is refused").0;
        assert!(e.starts_with("cut.nrrd: ") && e.contains("but the file has"), "{e}");
    }

    #[test]
    fn bad_bricks_are_errors_and_the_source_is_send_and_sync() {
        fn check<T: Send + Sync>() {}
        check::<MappedSource>();
        let dir = tempfile::tempdir().unwrap();
        let data = bytes([70, 3, 3], |_| 7u8.to_le_bytes());
        let header = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 70 3 3\nencoding: raw\n";
        let source = MappedSource::open(&write(&dir, "c.nrrd", &attached(header, &data))).unwrap().unwrap();
        assert_eq!(source.read(0, [1, 0, 0]).unwrap(), BrickData::Constant(7.0));
        assert_eq!(source.read(1, [0, 0, 0]).unwrap(), BrickData::Constant(7.0));
        assert!(source.read(0, [2, 0, 0]).unwrap_err().0.starts_with("c.nrrd: brick [2, 0, 0] is outside level 0"));
        assert!(source.read(2, [0, 0, 0]).unwrap_err().0.contains("level 2 does not exist"));
        assert_eq!(source.range(), [7.0, 7.0]);
    }

    /// A field of `/proc/self/status` in KiB (`VmRSS`: all resident memory; `RssFile`: the
    /// resident pages of mapped files).
    #[cfg(target_os = "linux")]
    /// Bytes of `map` resident in this process (its `Rss` in `/proc/self/smaps`: pages of the
    /// mapping in the process's page tables, which `MADV_DONTNEED` releases; the page cache
    /// may keep the file).
    fn resident_bytes(map: &Mmap) -> u64 {
        // The mapping starts at the header's end: its area from the page that holds it.
        let start = map.as_ptr() as usize / 4096 * 4096;
        let smaps = std::fs::read_to_string("/proc/self/smaps").unwrap();
        let mut lines = smaps.lines();
        while let Some(line) = lines.next() {
            let first = line.split('-').next().and_then(|a| usize::from_str_radix(a, 16).ok());
            if first == Some(start) {
                let rss = lines.find(|l| l.starts_with("Rss:")).expect("an Rss line");
                let kib: u64 = rss.split_whitespace().nth(1).unwrap().parse().unwrap();
                return kib * 1024;
            }
        }
        panic!("the mapping at {start:#x} is not in /proc/self/smaps");
    }

    fn status_kib(field: &str) -> u64 {
        let status = std::fs::read_to_string("/proc/self/status").unwrap();
        let line = status.lines().find(|l| l.starts_with(&format!("{field}:"))).unwrap();
        line.split_whitespace().nth(1).unwrap().parse().unwrap()
    }

    /// A 512 x 512 x 256 int16 file (128 MiB): opening it and reading every level-0 brick (every
    /// byte of it) leaves the process's resident memory far below the file's size. The mapping's
    /// own resident pages are counted in `/proc/self/smaps` (the process's `RssFile` also grows
    /// with the code other tests running alongside fault in); its heap by `RssAnon`, with slack
    /// for those tests.
    #[cfg(target_os = "linux")]
    #[test]
    fn reading_a_large_file_keeps_resident_memory_bounded() {
        let dims = [512u32, 512, 256];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.nrrd");
        let value = |[x, y, z]: [u32; 3]| ((x + 2 * y + 3 * z) % 3000) as i16;
        {
            let mut file = std::io::BufWriter::new(File::create(&path).unwrap());
            let header = "NRRD0004\ntype: short\ndimension: 3\nsizes: 512 512 256\nendian: little\nencoding: raw\n\n";
            file.write_all(header.as_bytes()).unwrap();
            for z in 0..dims[2] {
                file.write_all(&bytes([dims[0], dims[1], 1], |[x, y, _]| value([x, y, z]).to_le_bytes())).unwrap();
            }
            file.flush().unwrap();
        }
        let file_mib = std::fs::metadata(&path).unwrap().len() >> 20;
        let rss = status_kib("RssAnon");
        let source = MappedSource::open(&path).unwrap().unwrap();
        let level = source.levels()[0];
        for z in 0..level.bricks[2] {
            for y in 0..level.bricks[1] {
                for x in 0..level.bricks[0] {
                    let brick = source.read(0, [x, y, z]).unwrap();
                    let centre = [x, y, z].map(|b| b * 64 + 32);
                    assert_eq!(brick.at([32 + crate::bricks::APRON; 3]), f32::from(value(centre)));
                }
            }
        }
        let rss = status_kib("RssAnon").saturating_sub(rss) >> 10;
        let mapped = resident_bytes(&source.map) >> 20;
        println!(
            "read {} bricks of a {file_mib} MiB file: RssAnon +{rss} MiB, mapping resident {mapped} MiB",
            level.brick_count()
        );
        assert!(mapped < 24, "the mapped pages stayed resident: +{mapped} MiB of a {file_mib} MiB file");
        assert!(rss < file_mib / 2, "resident memory grew by {rss} MiB reading a {file_mib} MiB file");
    }
}
