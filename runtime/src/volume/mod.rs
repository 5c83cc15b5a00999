//! Volumes on the CPU: loading NIfTI-1, NRRD and MetaImage files and DICOM series, and
//! generating phantoms.
//!
//! Every loader validates the header before it reads or allocates the data, so a hostile or
//! broken file costs at most the memory its actual data needs, and every problem is reported as
//! a [`LoadError`] that names the file and the header field at fault.
//!
//! World space is RAS+ millimetres (NIfTI's convention): headers in LPS (MetaImage, NRRD with
//! `space: left-posterior-superior`) have their x and y axes negated, so that volumes loaded from
//! different formats line up.

mod dicom;
mod feed;
mod header;
pub(crate) mod histogram;
mod mhd;
mod nifti;
mod nrrd;
#[cfg(test)]
mod oversized;
pub mod phantom;
mod raw;
mod samples;
mod text_header;

use std::fmt;
use std::fs::File;
use std::io::{self, BufRead, Read};
use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3, Vec4};

pub(crate) use feed::stream_feed;
pub use feed::{Feeds, VolumeFeed};
pub use header::header;
pub(crate) use histogram::Histogram;
pub use histogram::auto_window;
pub use phantom::{UnknownPhantom, phantom};
pub use samples::{Samples, Scaling};

/// Streams a volume's finite value range: the sink of a first pass over a file when the volume
/// is not kept.
#[derive(Debug, Default)]
pub(crate) struct RangeSink {
    scaling: Option<Scaling>,
    stored: Option<[f32; 2]>,
}

impl RangeSink {
    /// The finite range in data units (`[0, 0]` without finite samples), as [`Volume::range`].
    pub(crate) fn range(&self) -> [f32; 2] {
        self.scaling.unwrap_or(Scaling::IDENTITY).range(self.stored)
    }
}

impl SampleSink for RangeSink {
    fn begin(&mut self, info: &VolumeInfo) -> Result<(), LoadErrorKind> {
        self.scaling = Some(info.scaling);
        Ok(())
    }

    fn samples(&mut self, chunk: &Samples) -> Result<(), LoadErrorKind> {
        if let Some([lo, hi]) = chunk.finite_range() {
            let [a, b] = self.stored.unwrap_or([lo, hi]);
            self.stored = Some([a.min(lo), b.max(hi)]);
        }
        Ok(())
    }
}

/// The most voxels a volume may have: 2^31 (4 GiB as 16-bit samples, 4 GiB on the GPU as half
/// floats).
pub(crate) const MAX_VOXELS: u64 = 1 << 31;

/// A scalar volume in memory: the samples as the file stores them, and how they map to data
/// units (the file's value scaling).
///
/// Nothing here holds a second copy of the samples: data values are computed from the stored
/// ones where they are needed (the GPU upload, the occupancy grid, percentiles), a chunk at a
/// time.
#[derive(Clone, PartialEq)]
pub struct Volume {
    /// Samples per axis; x varies fastest in `samples`.
    pub dims: [u32; 3],
    /// World units (mm) per voxel along each axis.
    pub spacing: [f32; 3],
    /// Voxel index (i, j, k) of a voxel centre -> world position (mm, RAS+), from the header.
    pub grid_to_world: Mat4,
    /// The stored samples, `dims[0] * dims[1] * dims[2]` of them, x fastest, then y, then z.
    pub(crate) samples: Samples,
    /// Stored samples to data units (NIfTI `scl_slope`/`scl_inter`, DICOM rescale).
    pub(crate) scaling: Scaling,
    /// Minimum and maximum of the finite samples in data units (`[0, 0]` when there are none).
    pub range: [f32; 2],
    /// The window the source gives its own values, taken instead of the automatic one (the
    /// percentiles' window, [`auto_window`]): a phantom's whole range, since it has no outliers
    /// to leave out and clamping its densest values would flatten them (their gradients, hence
    /// their shading, vanish where the texture saturates).
    pub(crate) own_window: Option<[f32; 2]>,
}

impl Volume {
    /// Builds a volume from samples in data units, deriving `spacing` from the lengths of the
    /// voxel axes in `grid_to_world` and `range` from the data.
    pub fn new(dims: [u32; 3], grid_to_world: Mat4, data: Vec<f32>) -> Volume {
        Volume::from_samples(dims, grid_to_world, Samples::F32(data), Scaling::IDENTITY)
    }

    /// Builds a volume from stored samples and their scaling to data units.
    pub(crate) fn from_samples(dims: [u32; 3], grid_to_world: Mat4, samples: Samples, scaling: Scaling) -> Volume {
        let range = scaling.range(samples.finite_range());
        Volume { dims, spacing: spacing_of(&grid_to_world), grid_to_world, samples, scaling, range, own_window: None }
    }

    /// The data value of voxel `index` (x fastest); `None` beyond the end.
    pub(crate) fn value(&self, index: usize) -> Option<f32> {
        self.samples.get(index).map(|s| self.scaling.apply(s))
    }

    /// Every value in data units: a full `f32` copy, for tests and small volumes; loading and
    /// rendering never make one.
    pub fn values(&self) -> Vec<f32> {
        let mut out = Vec::with_capacity(self.samples.len());
        self.samples.for_each(0..self.samples.len(), |s| out.push(self.scaling.apply(s)));
        out
    }

    #[cfg(test)]
    /// Values mapped to [0, 1] by `window` (lo, hi, data units), or by `range` when `None`;
    /// clamped; NaN -> 0.
    ///
    /// This is what the GPU samples: the transfer function's table spans the same window. A
    /// window with `hi <= lo` is a threshold: values above `lo` become 1.
    pub(crate) fn normalized(&self, window: Option<[f32; 2]>) -> Vec<f32> {
        let mut out = Vec::with_capacity(self.samples.len());
        self.for_each_normalized(window, 0..self.samples.len(), |t| out.push(t));
        out
    }

    /// Calls `f` with the normalized value (`Volume::normalized`) of each voxel in `voxels`,
    /// in order, without a copy of the volume.
    pub fn for_each_normalized(&self, window: Option<[f32; 2]>, voxels: Range<usize>, f: impl FnMut(f32)) {
        let window = Window::new(window.unwrap_or(self.range), self.scaling);
        let mut f = f;
        self.samples.for_each(voxels, |s| f(window.apply(s)));
    }

    #[cfg(test)]
    /// Appends the normalized values of the voxels in `voxels` to `out` as IEEE half floats, for
    /// an `R16Float` texture upload (half the memory of `f32`, and filterable on every backend).
    pub(crate) fn normalized_f16_into(&self, window: Option<[f32; 2]>, voxels: Range<usize>, out: &mut Vec<half::f16>) {
        out.reserve(voxels.len());
        self.for_each_normalized(window, voxels, |t| out.push(half::f16::from_f32(t)));
    }

    /// The number of voxels, `dims[0] * dims[1] * dims[2]`.
    pub fn voxel_count(&self) -> u64 {
        self.dims.iter().map(|&d| u64::from(d)).product()
    }

    #[cfg(test)]
    /// Bytes the volume takes on the GPU at 2 bytes per voxel (see [`Volume::normalized_f16_into`]).
    pub(crate) fn gpu_bytes(&self) -> u64 {
        self.voxel_count() * 2
    }
}

/// Prints the shape, not the (possibly gigabytes of) samples.
impl fmt::Debug for Volume {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Volume")
            .field("dims", &self.dims)
            .field("spacing", &self.spacing)
            .field("grid_to_world", &self.grid_to_world)
            .field(
                "samples",
                &format_args!("[{} samples of {} bytes]", self.samples.len(), self.samples.sample_bytes()),
            )
            .field("scaling", &self.scaling)
            .field("range", &self.range)
            .finish()
    }
}

/// A value window over stored samples, precomputed so normalizing a sample is one
/// multiply-add: `(stored * slope + intercept - lo) / (hi - lo)`, clamped to [0, 1], NaN -> 0
/// (see [`Volume::normalized`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Window {
    /// `slope / (hi - lo)` and `(intercept - lo) / (hi - lo)`; `None` for a degenerate window
    /// (a threshold at `lo`).
    linear: Option<(f32, f32)>,
    lo: f32,
    scaling: Scaling,
}

impl Window {
    /// The window `[lo, hi]` (data units) over samples stored with `scaling`.
    pub(crate) fn new([lo, hi]: [f32; 2], scaling: Scaling) -> Window {
        let linear = (hi > lo).then(|| {
            let scale = 1.0 / (hi - lo);
            (scaling.slope * scale, (scaling.intercept - lo) * scale)
        });
        Window { linear, lo, scaling }
    }

    /// The normalized value of a stored sample.
    pub(crate) fn apply(self, stored: f32) -> f32 {
        let t = match self.linear {
            Some((a, b)) => stored * a + b,
            None if self.scaling.apply(stored) > self.lo => 1.0,
            None => 0.0,
        };
        if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) }
    }
}

/// The length of each voxel axis (the first three columns of the matrix); 1 where that length
/// is not a usable positive number, so the spacing is always safe to divide by.
fn spacing_of(grid_to_world: &Mat4) -> [f32; 3] {
    let axis = |v: Vec4| {
        let len = v.truncate().length();
        if len.is_finite() && len > 0.0 { len } else { 1.0 }
    };
    [axis(grid_to_world.x_axis), axis(grid_to_world.y_axis), axis(grid_to_world.z_axis)]
}

/// A grid-to-world matrix from three voxel axes (world vectors per voxel step) and the world
/// position of voxel (0, 0, 0).
fn affine(axes: [Vec3; 3], origin: Vec3) -> Mat4 {
    Mat4::from_cols(axes[0].extend(0.0), axes[1].extend(0.0), axes[2].extend(0.0), origin.extend(1.0))
}

/// Converts a matrix into LPS+ world space (DICOM, ITK) into RAS+ by negating world x and y.
fn lps_to_ras(m: Mat4) -> Mat4 {
    Mat4::from_scale(Vec3::new(-1.0, -1.0, 1.0)) * m
}

/// Whether a grid-to-world matrix is finite and invertible, so it can place a volume.
fn is_usable(m: &Mat4) -> bool {
    let det = glam::Mat3::from_mat4(*m).determinant();
    m.is_finite() && det.is_finite() && det != 0.0
}

/// Why a volume could not be loaded, and from which file.
#[derive(Debug)]
pub struct LoadError {
    /// The path given to [`load`].
    pub path: PathBuf,
    /// What went wrong.
    pub kind: LoadErrorKind,
}

impl LoadError {
    #[cfg(test)]
    /// True for a file that is missing or unreadable, false for a file whose content is wrong
    /// or unsupported.
    pub(crate) fn is_io(&self) -> bool {
        matches!(self.kind, LoadErrorKind::Io { .. })
    }
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "`{}`: {}", self.path.display(), self.kind)
    }
}

impl std::error::Error for LoadError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.kind {
            LoadErrorKind::Io { error, .. } => Some(error),
            _ => None,
        }
    }
}

/// The problem behind a [`LoadError`]; its `Display` is a sentence for users.
#[derive(Debug)]
#[non_exhaustive]
pub enum LoadErrorKind {
    /// A file could not be opened or read: the volume file itself (`file: None`) or the data file
    /// its header names.
    Io {
        /// The data file, or `None` for the volume file itself.
        file: Option<PathBuf>,
        /// What the operating system said.
        error: io::Error,
    },
    /// The file name does not end in one of the supported extensions.
    UnknownFormat,
    /// A header field is missing, malformed or unsupported; the message names the field.
    Header(String),
    /// The header declares more than `MAX_VOXELS` voxels.
    TooLarge {
        /// The declared size along each axis.
        dims: Vec<u64>,
        /// Their product.
        voxels: u128,
    },
    /// The data section's length disagrees with what the header declares.
    SizeMismatch {
        /// Bytes the header declares.
        expected: u64,
        /// Bytes there are.
        found: u64,
        /// Whether the data were compressed (the count is of decompressed bytes).
        compressed: bool,
    },
    /// Compressed data could not be decompressed.
    Corrupt(String),
    /// The samples do not fit in memory.
    OutOfMemory {
        /// The bytes that could not be allocated.
        bytes: u64,
    },
    /// A DICOM series is unusable: a file of it (`file`) or the series as a whole (`None`: several
    /// series in one folder, missing slices, unequal spacing).
    Dicom {
        /// The file at fault, or `None` for the series as a whole.
        file: Option<PathBuf>,
        /// What is wrong.
        message: String,
    },
}

impl fmt::Display for LoadErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LoadErrorKind::Io { file: None, error } => write!(f, "cannot read: {error}"),
            LoadErrorKind::Io { file: Some(file), error } => {
                write!(f, "cannot read the data file `{}`: {error}", file.display())
            }
            LoadErrorKind::UnknownFormat => f.write_str(
                "unknown volume format (expected .nii, .nii.gz, .nrrd, .nhdr, .mhd, .mha or a folder of DICOM files)",
            ),
            LoadErrorKind::Header(message) => f.write_str(message),
            LoadErrorKind::TooLarge { dims, voxels } => {
                let dims: Vec<String> = dims.iter().map(u64::to_string).collect();
                write!(f, "too large: {} = {voxels} voxels (at most {MAX_VOXELS} are supported)", dims.join(" x "))
            }
            LoadErrorKind::SizeMismatch { expected, found, compressed: false } => {
                write!(f, "header says {expected} bytes of data, file has {found}")
            }
            LoadErrorKind::SizeMismatch { expected, found, compressed: true } => {
                write!(f, "header says {expected} bytes of data, the decompressed data has {found}")
            }
            LoadErrorKind::Corrupt(message) => write!(f, "corrupt or truncated compressed data: {message}"),
            LoadErrorKind::OutOfMemory { bytes } => {
                write!(f, "not enough memory for the volume ({} MiB)", bytes >> 20)
            }
            LoadErrorKind::Dicom { file: None, message } => f.write_str(message),
            LoadErrorKind::Dicom { file: Some(file), message } => write!(f, "`{}`: {message}", file.display()),
        }
    }
}

/// Loads a volume: a folder is a DICOM series (one image per file); a file's format is picked
/// by its name: `.nii`, `.nii.gz` (NIfTI-1), `.nrrd`, `.nhdr` (NRRD), `.mhd`, `.mha` (MetaImage).
///
/// `progress(done_bytes, total_bytes)` is called as the file holding the data is read (about
/// every 1% of it; for a DICOM series, after each slice), and once with `done == total` at the
/// end, so a caller can draw a progress bar.
pub fn load(path: &Path, progress: &mut dyn FnMut(u64, u64)) -> Result<Volume, LoadError> {
    let mut collected = Collect::default();
    let info = stream(path, progress, &mut collected)?;
    let samples = collected.samples.unwrap_or(Samples::F32(Vec::new()));
    Ok(Volume::from_samples(info.dims, info.grid_to_world, samples, info.scaling))
}

/// Reads a volume like [`load`], but hands its samples to `sink` a chunk at a time instead of
/// keeping them: a caller that only needs them once (a GPU upload, a histogram) holds no copy
/// of the volume. Returns the volume's shape, placement and scaling.
pub(crate) fn stream(
    path: &Path,
    progress: &mut dyn FnMut(u64, u64),
    sink: &mut dyn SampleSink,
) -> Result<VolumeInfo, LoadError> {
    let name = path.file_name().map(|n| n.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    let sink = &mut header::Checked { inner: sink };
    let result = if path.is_dir() {
        dicom::load(path, progress, sink)
    } else if name.ends_with(".nii.gz") {
        nifti::load(path, true, progress, sink)
    } else if name.ends_with(".nii") {
        nifti::load(path, false, progress, sink)
    } else if name.ends_with(".nrrd") || name.ends_with(".nhdr") {
        nrrd::load(path, progress, sink)
    } else if name.ends_with(".mhd") || name.ends_with(".mha") {
        mhd::load(path, progress, sink)
    } else {
        Err(LoadErrorKind::UnknownFormat)
    };
    result.map_err(|kind| LoadError { path: path.to_path_buf(), kind })
}

/// Where the samples of an uncompressed file lie, so they can be read in place (a
/// memory-mapped brick source) instead of loaded: the header validated as a load would, and
/// the file checked to hold exactly the samples it claims.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct RawData {
    /// The file holding the samples: the volume file, or the data file its header names.
    pub file: PathBuf,
    /// The byte of `file` where the first sample starts (x fastest, then y, then z).
    pub offset: u64,
    /// The stored type of each sample.
    pub sample: ScalarType,
    /// Whether multi-byte samples are big-endian.
    pub big_endian: bool,
    /// The volume's shape, placement and scaling.
    pub info: VolumeInfo,
}

impl RawData {
    /// Bytes of the samples in `file`.
    pub(crate) fn bytes(&self) -> u64 {
        self.info.dims.iter().map(|&d| u64::from(d)).product::<u64>() * self.sample.size()
    }
}

/// Where the samples of the volume file at `path` lie when they are stored uncompressed (NRRD
/// `encoding: raw`, MetaImage without `CompressedData`, `.nii`): `None` for compressed data and
/// DICOM series, which must be loaded. Errors are a load's: a header it refuses, or a data
/// section shorter or longer than the header claims.
pub(crate) fn raw_layout(path: &Path) -> Result<Option<RawData>, LoadError> {
    let name = path.file_name().map(|n| n.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    let located = if path.is_dir() || name.ends_with(".nii.gz") {
        Ok(None)
    } else if name.ends_with(".nii") {
        nifti::locate(path).map(Some)
    } else if name.ends_with(".nrrd") || name.ends_with(".nhdr") {
        nrrd::locate(path)
    } else if name.ends_with(".mhd") || name.ends_with(".mha") {
        mhd::locate(path)
    } else {
        Err(LoadErrorKind::UnknownFormat)
    };
    let checked = located.and_then(|raw| {
        raw.as_ref().map(|r| header::check_spacing(&r.info)).transpose()?;
        Ok(raw)
    });
    checked.map_err(|kind| LoadError { path: path.to_path_buf(), kind })
}

/// A volume's shape, placement and value scaling: everything but its samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeInfo {
    /// Samples per axis.
    pub dims: [u32; 3],
    /// Voxel index to world (mm, RAS+).
    pub grid_to_world: Mat4,
    /// Stored samples to data units.
    pub scaling: Scaling,
}

/// Receives a volume's stored samples as a loader reads them (`stream`).
pub trait SampleSink {
    /// Called once, after the header is validated and before any sample.
    fn begin(&mut self, info: &VolumeInfo) -> Result<(), LoadErrorKind>;

    /// The file holds exactly the `voxels` samples its header declares (an uncompressed file of
    /// the right length): a sink may allocate for all of them now.
    fn reserve(&mut self, voxels: usize) -> Result<(), LoadErrorKind> {
        let _ = voxels;
        Ok(())
    }

    /// The next stored samples in voxel order (x fastest, then y, then z), in the file's type
    /// (the same type for every chunk of a volume).
    fn samples(&mut self, chunk: &Samples) -> Result<(), LoadErrorKind>;
}

/// The sink of [`load`]: keeps every sample in the file's type, growing with the data actually
/// read (so a small compressed file claiming a huge volume costs only what it holds) unless the
/// loader says the size is known.
#[derive(Default)]
struct Collect {
    voxels: usize,
    reserve: usize,
    samples: Option<Samples>,
}

impl SampleSink for Collect {
    fn begin(&mut self, info: &VolumeInfo) -> Result<(), LoadErrorKind> {
        self.voxels = info.dims.iter().map(|&d| d as usize).product();
        self.reserve = self.voxels.min(1 << 22);
        Ok(())
    }

    fn reserve(&mut self, voxels: usize) -> Result<(), LoadErrorKind> {
        self.reserve = voxels.min(self.voxels);
        Ok(())
    }

    fn samples(&mut self, chunk: &Samples) -> Result<(), LoadErrorKind> {
        let out_of_memory = |_| LoadErrorKind::OutOfMemory { bytes: (self.voxels * chunk.sample_bytes()) as u64 };
        let samples = match &mut self.samples {
            Some(samples) => samples,
            None => self.samples.insert(Samples::empty_like(chunk, self.reserve).map_err(out_of_memory)?),
        };
        samples.reserve_up_to(chunk.len(), self.voxels).map_err(out_of_memory)?;
        samples.append(chunk).map_err(LoadErrorKind::Header)
    }
}

/// The sample types the loaders accept; `f64` is kept as `f32`, the others as they are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ScalarType {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    F32,
    F64,
}

impl ScalarType {
    /// Bytes per sample.
    pub(crate) fn size(self) -> u64 {
        match self {
            ScalarType::U8 | ScalarType::I8 => 1,
            ScalarType::U16 | ScalarType::I16 => 2,
            ScalarType::U32 | ScalarType::I32 | ScalarType::F32 => 4,
            ScalarType::F64 => 8,
        }
    }
}

/// The voxel counts of a header's size field as `u32`s, refusing zero sizes and volumes beyond
/// [`MAX_VOXELS`] before anything is allocated. `field` names the header field for the message.
fn check_dims(field: &str, sizes: [u64; 3]) -> Result<[u32; 3], LoadErrorKind> {
    if sizes.contains(&0) {
        let [x, y, z] = sizes;
        return Err(LoadErrorKind::Header(format!("`{field}` has a zero size: {x} x {y} x {z}")));
    }
    let voxels = sizes.iter().map(|&s| u128::from(s)).product::<u128>();
    match sizes.map(u32::try_from) {
        [Ok(x), Ok(y), Ok(z)] if voxels <= u128::from(MAX_VOXELS) => Ok([x, y, z]),
        _ => Err(LoadErrorKind::TooLarge { dims: sizes.to_vec(), voxels }),
    }
}

/// The most one stored byte can expand to in any encoding the loaders read: deflate's limit
/// (about 1032 : 1, zlib's technical note), above RLE's (64 : 1) and JPEG's.
const MAX_EXPANSION: u64 = 1032;

/// Refuses a header that claims more sample bytes (`claimed`) than the `stored` bytes holding
/// them can give, before any sink allocates for the claim: raw data must hold them all, and
/// compressed data expands at most [`MAX_EXPANSION`] times. A header whose claim passes is
/// still checked exactly as its data is read.
fn check_claim(claimed: u64, stored: u64, compressed: bool) -> Result<(), LoadErrorKind> {
    if !compressed && claimed > stored {
        return Err(LoadErrorKind::SizeMismatch { expected: claimed, found: stored, compressed: false });
    }
    if compressed && claimed > stored.saturating_mul(MAX_EXPANSION) {
        return Err(LoadErrorKind::Header(format!(
            "header says {claimed} bytes of data, more than {stored} compressed bytes can hold"
        )));
    }
    Ok(())
}

/// How the samples are stored.
#[derive(Clone, Copy, Debug)]
struct Layout {
    ty: ScalarType,
    big_endian: bool,
    voxels: u64,
}

impl Layout {
    fn bytes(&self) -> u64 {
        self.voxels * self.ty.size()
    }
}

/// What a loader knows about the stream it reads samples from, for sizing and error messages.
struct DataSource<'a> {
    /// The data file when it is not the file given to [`load`].
    file: Option<&'a Path>,
    /// Whether the stream is decompressed (its length is unknown until it is read).
    compressed: bool,
    /// The bytes the stream holds, when known without reading it (uncompressed files).
    available: Option<u64>,
}

impl DataSource<'_> {
    /// A read error as a load error: decompressors report bad or truncated input as
    /// `InvalidInput`, `InvalidData` or `UnexpectedEof`, which is the file's content at fault,
    /// not the file system.
    fn read_error(&self, error: io::Error) -> LoadErrorKind {
        use io::ErrorKind::{InvalidData, InvalidInput, UnexpectedEof};
        if self.compressed && matches!(error.kind(), InvalidData | InvalidInput | UnexpectedEof) {
            LoadErrorKind::Corrupt(error.to_string())
        } else {
            LoadErrorKind::Io { file: self.file.map(Path::to_path_buf), error }
        }
    }

    fn mismatch(&self, expected: u64, found: u64) -> LoadErrorKind {
        LoadErrorKind::SizeMismatch { expected, found, compressed: self.compressed }
    }
}

/// Bytes read and converted at a time: bounds the extra memory to one chunk whatever the volume.
const CHUNK_BYTES: usize = 1 << 20;

/// Reads exactly the samples `layout` describes from `reader` (positioned at the first sample)
/// into `sink`, a chunk at a time, and checks that nothing follows them.
fn read_samples(
    reader: &mut dyn Read,
    layout: Layout,
    source: &DataSource,
    sink: &mut dyn SampleSink,
) -> Result<(), LoadErrorKind> {
    let expected = layout.bytes();
    if let Some(available) = source.available {
        if available != expected {
            return Err(source.mismatch(expected, available));
        }
        sink.reserve(usize::try_from(layout.voxels).unwrap_or(usize::MAX))?;
    }
    let sample_bytes = layout.ty.size() as usize;
    let out_of_memory = |_| LoadErrorKind::OutOfMemory { bytes: CHUNK_BYTES as u64 };
    let mut chunk = Samples::with_capacity(layout.ty, CHUNK_BYTES / sample_bytes).map_err(out_of_memory)?;
    let mut buf = vec![0u8; CHUNK_BYTES];
    let mut remaining = expected;
    while remaining > 0 {
        let want = usize::try_from(remaining).map_or(CHUNK_BYTES, |r| r.min(CHUNK_BYTES));
        let got = read_full(reader, &mut buf[..want]).map_err(|e| source.read_error(e))?;
        if got < want {
            return Err(source.mismatch(expected, expected - remaining + got as u64));
        }
        chunk.clear();
        chunk.extend_decoded(layout.ty, &buf[..want], layout.big_endian);
        sink.samples(&chunk)?;
        remaining -= want as u64;
    }
    let extra = io::copy(reader, &mut io::sink()).map_err(|e| source.read_error(e))?;
    if extra > 0 {
        return Err(source.mismatch(expected, expected + extra));
    }
    Ok(())
}

/// Fills `buf` as far as the stream allows; returns how many bytes were read (less than
/// `buf.len()` only at the end of the stream).
fn read_full(reader: &mut dyn Read, buf: &mut [u8]) -> io::Result<usize> {
    let mut filled = 0;
    while filled < buf.len() {
        match reader.read(&mut buf[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(filled)
}

/// Skips `n` bytes of `reader`; returns how many there were (less than `n` at the end).
fn skip_bytes(reader: &mut dyn Read, n: u64) -> io::Result<u64> {
    io::copy(&mut reader.take(n), &mut io::sink())
}

/// Opens a file and returns it with its length; `data_file` is true for a data file named by a
/// header, so that an error names it.
fn open(path: &Path, data_file: bool) -> Result<(File, u64), LoadErrorKind> {
    let io_error = |error| LoadErrorKind::Io { file: data_file.then(|| path.to_path_buf()), error };
    let file = File::open(path).map_err(io_error)?;
    let len = file.metadata().map_err(io_error)?.len();
    Ok((file, len))
}

/// Counts the bytes read from the file holding the data and reports them to a progress callback
/// about every 1% (and at least every 256 KiB read), which is often enough for a smooth bar and
/// rare enough to cost nothing. The first report comes after the first step, so reading a small
/// detached header reports nothing before its data file's progress starts.
struct ProgressReader<'p, R> {
    inner: R,
    done: u64,
    total: u64,
    next_report: u64,
    progress: &'p mut dyn FnMut(u64, u64),
}

impl<'p, R> ProgressReader<'p, R> {
    fn new(inner: R, total: u64, progress: &'p mut dyn FnMut(u64, u64)) -> Self {
        let mut reader = ProgressReader { inner, done: 0, total, next_report: 0, progress };
        reader.next_report = reader.step();
        reader
    }

    fn step(&self) -> u64 {
        (self.total / 100).max(256 << 10)
    }
}

impl<R: Read> Read for ProgressReader<'_, R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.done += n as u64;
        if n > 0 && self.done >= self.next_report {
            (self.progress)(self.done.min(self.total), self.total);
            self.next_report = self.done + self.step();
        }
        Ok(n)
    }
}

/// Reads one header line of a text header (NRRD, MetaImage) that may be followed by binary
/// data: at most `MAX_LINE` bytes, so a binary file given by mistake is refused quickly.
/// Returns `None` at the end of the stream, else the line without its line ending and the
/// number of bytes consumed.
fn read_header_line(reader: &mut dyn BufRead) -> Result<Option<(String, u64)>, LoadErrorKind> {
    const MAX_LINE: u64 = 64 << 10;
    let mut line = Vec::new();
    let mut limited: io::Take<&mut dyn BufRead> = Read::take(reader, MAX_LINE + 1);
    let n = limited.read_until(b'\n', &mut line).map_err(|error| LoadErrorKind::Io { file: None, error })?;
    if n == 0 {
        return Ok(None);
    }
    if n as u64 > MAX_LINE {
        return Err(LoadErrorKind::Header("a header line is longer than 64 KiB: is this really a header?".into()));
    }
    while line.last().is_some_and(|&b| b == b'\n' || b == b'\r') {
        line.pop();
    }
    let text = String::from_utf8(line)
        .map_err(|_| LoadErrorKind::Header("the header is not text (a line is not UTF-8)".into()))?;
    Ok(Some((text, n as u64)))
}

/// The most header lines accepted; a real header has a few dozen.
const MAX_HEADER_LINES: usize = 10_000;

/// Parses whitespace-separated numbers of a header field, naming the field when one is not a
/// number.
fn parse_numbers<T: std::str::FromStr>(field: &str, value: &str) -> Result<Vec<T>, LoadErrorKind> {
    value
        .split_whitespace()
        .map(|word| word.parse().map_err(|_| LoadErrorKind::Header(format!("`{field}`: `{word}` is not a number"))))
        .collect()
}

/// A data file named by a header, relative to the header's directory unless absolute.
fn sibling(header: &Path, name: &str) -> PathBuf {
    let name = Path::new(name);
    if name.is_absolute() { name.to_path_buf() } else { header.parent().unwrap_or(Path::new("")).join(name) }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Loads without a progress callback.
    pub(crate) fn load_quiet(path: &Path) -> Result<Volume, LoadError> {
        load(path, &mut |_, _| {})
    }

    /// Asserts that two matrices agree to 1e-5.
    pub(crate) fn assert_mat_eq(a: Mat4, b: Mat4) {
        assert!(a.abs_diff_eq(b, 1e-5), "{a:?}\n!=\n{b:?}");
    }

    /// Writes `bytes` to the file `name` in `dir` and returns its path.
    pub(crate) fn write(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> PathBuf {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    /// Writes `bytes` as `name` in `dir` and loads it, expecting an error: whether it is an I/O
    /// error, and its message without the path.
    pub(crate) fn load_err(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> (bool, String) {
        let e = load_quiet(&write(dir, name, bytes)).unwrap_err();
        (e.is_io(), e.kind.to_string())
    }

    /// `bytes` gzip-compressed (`.nii.gz`, NRRD `encoding: gzip`).
    pub(crate) fn gzip(bytes: &[u8]) -> Vec<u8> {
        let mut encoder = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        io::Write::write_all(&mut encoder, bytes).unwrap();
        encoder.finish().unwrap()
    }

    /// `bytes` zlib-compressed (MetaImage `CompressedData = True`).
    pub(crate) fn zlib(bytes: &[u8]) -> Vec<u8> {
        let mut encoder = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        io::Write::write_all(&mut encoder, bytes).unwrap();
        encoder.finish().unwrap()
    }

    /// The samples of the NRRD and MetaImage tests' 3 x 2 x 2 volume of `short`s: negative ones
    /// and ones beyond a byte show that sign and byte order survive.
    pub(crate) const SHORTS: [i16; 12] = [-5, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 300];

    /// [`SHORTS`] as little-endian bytes.
    pub(crate) fn shorts_le() -> Vec<u8> {
        SHORTS.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    /// [`SHORTS`] as the loaders return them.
    pub(crate) fn shorts_f32() -> Vec<f32> {
        SHORTS.iter().map(|&v| f32::from(v)).collect()
    }

    fn volume(data: Vec<f32>) -> Volume {
        let n = data.len() as u32;
        Volume::new([n, 1, 1], Mat4::IDENTITY, data)
    }

    #[test]
    fn range_ignores_non_finite_values() {
        let v = volume(vec![3.0, f32::NAN, -2.0, f32::INFINITY, 5.0]);
        assert_eq!(v.range, [-2.0, 5.0]);
        assert_eq!(volume(vec![f32::NAN]).range, [0.0, 0.0]);
    }

    #[test]
    fn normalized_maps_range_or_window_and_clamps() {
        let v = volume(vec![0.0, 5.0, 10.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY]);
        assert_eq!(v.normalized(None), vec![0.0, 0.5, 1.0, 0.0, 1.0, 0.0]);
        assert_eq!(v.normalized(Some([5.0, 7.5])), vec![0.0, 0.0, 1.0, 0.0, 1.0, 0.0]);
        // A degenerate window thresholds.
        assert_eq!(v.normalized(Some([5.0, 5.0]))[..3], [0.0, 0.0, 1.0]);
        let mut halves = Vec::new();
        v.normalized_f16_into(None, 1..3, &mut halves);
        assert_eq!(halves, [half::f16::from_f32(0.5), half::f16::ONE]);
        assert_eq!(v.voxel_count(), 6);
        assert_eq!(v.gpu_bytes(), 12);
    }

    #[test]
    fn constant_volume_normalizes_to_zero() {
        assert_eq!(volume(vec![4.0; 3]).normalized(None), vec![0.0; 3]);
    }

    #[test]
    fn spacing_comes_from_the_matrix_axes() {
        let m = affine([Vec3::new(0.0, 2.0, 0.0), Vec3::new(-3.0, 0.0, 0.0), Vec3::ZERO], Vec3::ONE);
        assert_eq!(spacing_of(&m), [2.0, 3.0, 1.0]);
    }

    #[test]
    fn check_dims_refuses_zero_and_huge() {
        assert_eq!(check_dims("sizes", [2, 3, 4]).ok(), Some([2, 3, 4]));
        let zero = check_dims("sizes", [2, 0, 4]).unwrap_err().to_string();
        assert!(zero.contains("`sizes` has a zero size"), "{zero}");
        let huge = check_dims("sizes", [100_000, 100_000, 100_000]).unwrap_err().to_string();
        assert!(huge.starts_with("too large: 100000 x 100000 x 100000 = 1000000000000000 voxels"), "{huge}");
        assert!(check_dims("sizes", [1 << 11, 1 << 10, 1 << 10]).is_ok());
        assert!(check_dims("sizes", [1 << 11, 1 << 10, (1 << 10) + 1]).is_err());
        assert!(check_dims("sizes", [u64::MAX, 1, 1]).is_err());
    }

    #[test]
    fn decode_all_types_both_endians() {
        let mut out = Vec::new();
        let mut decode = |ty: ScalarType, bytes: &[u8], big_endian: bool, bytes_per_sample: usize| {
            let mut samples = Samples::with_capacity(ty, 0).unwrap();
            samples.extend_decoded(ty, bytes, big_endian);
            assert_eq!(samples.sample_bytes(), bytes_per_sample, "{ty:?} is stored in its own type");
            out.extend(samples.to_f32());
        };
        decode(ScalarType::I8, &[0xff, 0x02], false, 1);
        decode(ScalarType::U16, &[0x01, 0x02], true, 2);
        decode(ScalarType::I16, &(-300i16).to_le_bytes(), false, 2);
        decode(ScalarType::U32, &70000u32.to_be_bytes(), true, 4);
        decode(ScalarType::I32, &(-70000i32).to_le_bytes(), false, 4);
        decode(ScalarType::F32, &1.5f32.to_be_bytes(), true, 4);
        decode(ScalarType::F64, &(-2.25f64).to_le_bytes(), false, 4);
        decode(ScalarType::U8, &[200], false, 1);
        assert_eq!(out, vec![-1.0, 2.0, 258.0, -300.0, 70000.0, -70000.0, 1.5, -2.25, 200.0]);
    }

    #[test]
    fn scaling_maps_stored_samples_to_data_units() {
        // Stored 0..=4, slope -2, intercept 10: data 10, 8, ..., 2.
        let v = Volume::from_samples(
            [5, 1, 1],
            Mat4::IDENTITY,
            Samples::I16(vec![0, 1, 2, 3, 4]),
            Scaling { slope: -2.0, intercept: 10.0 },
        );
        assert_eq!(v.range, [2.0, 10.0]);
        assert_eq!(v.values(), [10.0, 8.0, 6.0, 4.0, 2.0]);
        assert_eq!(v.value(1), Some(8.0));
        assert_eq!(v.normalized(Some([4.0, 8.0])), [1.0, 1.0, 0.5, 0.0, 0.0]);
        assert_eq!(v.normalized(Some([6.0, 6.0])), [1.0, 1.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn reserve_up_to_never_passes_the_limit() {
        let mut samples = Samples::with_capacity(ScalarType::I16, 4).unwrap();
        samples.reserve_up_to(4, 10).unwrap();
        samples.extend_decoded(ScalarType::I16, &[0; 8], false);
        samples.reserve_up_to(4, 10).unwrap();
        let Samples::I16(v) = &samples else { panic!("i16 samples") };
        assert_eq!(v.capacity(), 8);
        samples.extend_decoded(ScalarType::I16, &[0; 8], false);
        samples.reserve_up_to(2, 10).unwrap();
        let Samples::I16(v) = &samples else { panic!("i16 samples") };
        assert_eq!(v.capacity(), 10, "doubling stops at the limit");
    }

    #[test]
    fn unknown_extension_is_not_io() {
        let e = load_quiet(Path::new("/nonexistent/volume.dcm")).unwrap_err();
        assert!(!e.is_io());
        assert!(e.to_string().starts_with("`/nonexistent/volume.dcm`: unknown volume format"), "{e}");
    }

    #[test]
    fn missing_files_are_io_errors() {
        for name in ["a.nii", "a.nii.gz", "a.nrrd", "a.nhdr", "a.mhd", "a.mha"] {
            let path = Path::new("/nonexistent/dir").join(name);
            let e = load_quiet(&path).unwrap_err();
            assert!(e.is_io(), "{name}: {e}");
            assert!(e.to_string().contains("cannot read"), "{e}");
            assert!(std::error::Error::source(&e).is_some());
        }
    }

    #[test]
    fn progress_is_reported_in_steps() {
        let data = vec![7u8; 3 << 20];
        let mut calls = Vec::new();
        let mut progress = |done, total| calls.push((done, total));
        let mut reader = ProgressReader::new(&data[..], data.len() as u64, &mut progress);
        let n = io::copy(&mut reader, &mut io::sink()).unwrap();
        assert_eq!(n, data.len() as u64);
        assert!(calls.first().is_some_and(|&(done, _)| done >= 256 << 10));
        assert!(calls.len() > 5 && calls.len() < 200, "{}", calls.len());
        assert!(calls.windows(2).all(|w| w[0].0 <= w[1].0));
        assert!(calls.iter().all(|&(done, total)| total == data.len() as u64 && done <= total));
    }
}
