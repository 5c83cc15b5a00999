//! NIfTI-1 single files (`.nii`, `.nii.gz`).
//!
//! The `nifti` crate parses the header (including its byte-order detection); the data is read
//! here, in chunks, so the header is validated before anything is allocated and progress can be
//! reported.

use std::io::{BufReader, Read};
use std::path::Path;

use flate2::bufread::GzDecoder;
use glam::{DMat3, DQuat, Mat4, Vec3};
use nifti::{Endianness, NiftiError, NiftiHeader};

use super::{
    DataSource, Layout, LoadErrorKind, ProgressReader, RawData, SampleSink, ScalarType, Scaling, VolumeInfo, affine,
    check_claim, check_dims, is_usable, open, read_samples, skip_bytes,
};

/// Bytes in a NIfTI-1 header; the extensions (if any) and the data follow it.
const HEADER_BYTES: u64 = 348;

/// Loads a `.nii` (or, with `gz`, a `.nii.gz`) file.
pub(super) fn load(
    path: &Path,
    gz: bool,
    progress: &mut dyn FnMut(u64, u64),
    sink: &mut dyn SampleSink,
) -> Result<VolumeInfo, LoadErrorKind> {
    let (file, len) = open(path, false)?;
    let info = {
        let buffered = BufReader::new(ProgressReader::new(file, len, progress));
        let mut reader: Box<dyn Read + '_> = if gz { Box::new(GzDecoder::new(buffered)) } else { Box::new(buffered) };
        read(&mut reader, gz, len, sink)?
    };
    progress(len, len);
    Ok(info)
}

/// Where the samples of a `.nii` file lie: the header validated as [`read`] does, and the
/// file checked to hold exactly the samples after `vox_offset`.
pub(super) fn locate(path: &Path) -> Result<RawData, LoadErrorKind> {
    let (file, len) = open(path, false)?;
    let source = DataSource { file: None, compressed: false, available: None };
    let header = NiftiHeader::from_reader(BufReader::new(file)).map_err(|e| header_error(e, &source))?;
    let (dims, layout) = layout(&header)?;
    let offset = data_offset(&header)?;
    let Some(available) = len.checked_sub(offset) else {
        return Err(LoadErrorKind::Header(format!(
            "the file ends before its data, which `vox_offset` places at byte {offset}"
        )));
    };
    if available != layout.bytes() {
        return Err(source.mismatch(layout.bytes(), available));
    }
    let info = VolumeInfo { dims, grid_to_world: grid_to_world(&header), scaling: scaling(&header) };
    Ok(RawData { file: path.to_path_buf(), offset, sample: layout.ty, big_endian: layout.big_endian, info })
}

/// Reads a NIfTI-1 stream: header, extensions (skipped) and data. `len` is the file's length,
/// which bounds the data of an uncompressed file.
fn read(reader: &mut dyn Read, gz: bool, len: u64, sink: &mut dyn SampleSink) -> Result<VolumeInfo, LoadErrorKind> {
    let source = DataSource { file: None, compressed: gz, available: None };
    let header = NiftiHeader::from_reader(&mut *reader).map_err(|e| header_error(e, &source))?;
    let (dims, layout) = layout(&header)?;
    let offset = data_offset(&header)?;
    let skipped = skip_bytes(reader, offset - HEADER_BYTES).map_err(|e| source.read_error(e))?;
    if skipped < offset - HEADER_BYTES {
        return Err(LoadErrorKind::Header(format!(
            "the file ends before its data, which `vox_offset` places at byte {offset}"
        )));
    }
    let source = DataSource { available: (!gz).then(|| len.saturating_sub(offset)), ..source };
    // The whole compressed file bounds a `.nii.gz`'s data; the rest after the offset a `.nii`'s.
    check_claim(layout.bytes(), if gz { len } else { len.saturating_sub(offset) }, gz)?;
    let info = VolumeInfo { dims, grid_to_world: grid_to_world(&header), scaling: scaling(&header) };
    sink.begin(&info)?;
    read_samples(reader, layout, &source, sink)?;
    Ok(info)
}

/// Turns the `nifti` crate's header errors into messages for users.
fn header_error(error: NiftiError, source: &DataSource) -> LoadErrorKind {
    match error {
        NiftiError::Io(e) if e.kind() == std::io::ErrorKind::UnexpectedEof && !source.compressed => {
            LoadErrorKind::Header(format!("too short for a NIfTI-1 header ({HEADER_BYTES} bytes)"))
        }
        NiftiError::Io(e) => source.read_error(e),
        NiftiError::InvalidFormat => LoadErrorKind::Header(
            "not a NIfTI-1 file: no `n+1` magic at byte 344 (NIfTI-2 and Analyze 7.5 are not supported)".into(),
        ),
        other => LoadErrorKind::Header(format!("bad NIfTI-1 header: {other}")),
    }
}

/// The volume's dimensions and sample layout, refusing anything but single-file 3D scalar
/// volumes of a supported type.
fn layout(header: &NiftiHeader) -> Result<([u32; 3], Layout), LoadErrorKind> {
    if &header.magic == nifti::header::MAGIC_CODE_NI1 {
        return Err(LoadErrorKind::Header(
            "this is the header of a .hdr/.img pair (magic `ni1`); only single .nii files are supported".into(),
        ));
    }
    let rank = header.dim[0];
    if !(3..=7).contains(&rank) {
        return Err(LoadErrorKind::Header(format!("not a 3D volume: `dim[0]` is {rank}")));
    }
    // Axes beyond the third are fine as long as they hold one sample (e.g. a 4D file of one volume).
    if let Some(axis) = (4..=usize::from(rank)).find(|&axis| header.dim[axis] > 1) {
        return Err(LoadErrorKind::Header(format!(
            "not a 3D volume: `dim[{axis}]` is {} (time series and vector volumes are not supported)",
            header.dim[axis]
        )));
    }
    let dims = check_dims("dim", [1, 2, 3].map(|axis| u64::from(header.dim[axis])))?;
    let ty = scalar_type(header.datatype)?;
    let voxels = dims.iter().map(|&d| u64::from(d)).product();
    Ok((dims, Layout { ty, big_endian: header.endianness == Endianness::Big, voxels }))
}

/// The sample type of a NIfTI `datatype` code, naming unsupported codes in the error.
fn scalar_type(code: i16) -> Result<ScalarType, LoadErrorKind> {
    let ty = match code {
        2 => ScalarType::U8,
        4 => ScalarType::I16,
        8 => ScalarType::I32,
        16 => ScalarType::F32,
        64 => ScalarType::F64,
        256 => ScalarType::I8,
        512 => ScalarType::U16,
        768 => ScalarType::U32,
        _ => {
            let name = match code {
                1 => "binary",
                32 => "complex64",
                128 => "RGB24",
                1024 => "int64",
                1280 => "uint64",
                1536 => "float128",
                1792 => "complex128",
                2048 => "complex256",
                2304 => "RGBA32",
                _ => "unknown",
            };
            return Err(LoadErrorKind::Header(format!(
                "unsupported `datatype` {code} ({name}); supported: uint8, int8, uint16, int16, uint32, int32, \
                 float32, float64"
            )));
        }
    };
    Ok(ty)
}

/// The byte offset of the data, from `vox_offset`.
fn data_offset(header: &NiftiHeader) -> Result<u64, LoadErrorKind> {
    let offset = header.vox_offset;
    if offset.is_finite() && offset >= HEADER_BYTES as f32 && offset.fract() == 0.0 {
        Ok(offset as u64)
    } else {
        Err(LoadErrorKind::Header(format!("`vox_offset` {offset} is not a byte offset of at least {HEADER_BYTES}")))
    }
}

/// `scl_slope` and `scl_inter`; a slope of 0 (or not a number) means "no scaling", as the
/// NIfTI-1 standard says.
fn scaling(header: &NiftiHeader) -> Scaling {
    let slope = header.scl_slope;
    let intercept = if header.scl_inter.is_finite() { header.scl_inter } else { 0.0 };
    if slope.is_finite() && slope != 0.0 { Scaling { slope, intercept } } else { Scaling::IDENTITY }
}

/// The voxel-to-world matrix by NIfTI-1's three methods, in order of preference: the sform
/// (`sform_code > 0`), the qform (`qform_code > 0`), else just `pixdim` scaling. A transform that
/// is not finite and invertible is skipped, so a broken sform still leaves a usable volume.
fn grid_to_world(header: &NiftiHeader) -> Mat4 {
    let sform = (header.sform_code > 0).then(|| sform(header)).filter(is_usable);
    let qform = || (header.qform_code > 0).then(|| qform(header)).flatten().filter(is_usable);
    sform.or_else(qform).unwrap_or_else(|| {
        let [dx, dy, dz] = [1, 2, 3].map(|axis| pixdim(header, axis));
        Mat4::from_scale(Vec3::new(dx, dy, dz))
    })
}

/// `pixdim[axis]` as a voxel size: positive, with 1 standing in for a missing (zero, negative
/// or non-finite) value.
fn pixdim(header: &NiftiHeader, axis: usize) -> f32 {
    let d = header.pixdim[axis].abs();
    if d.is_finite() && d > 0.0 { d } else { 1.0 }
}

/// The sform: the rows `srow_x`, `srow_y`, `srow_z` of an affine matrix.
fn sform(header: &NiftiHeader) -> Mat4 {
    let [x, y, z] = [header.srow_x, header.srow_y, header.srow_z];
    let column = |c: usize| Vec3::new(x[c], y[c], z[c]);
    affine([column(0), column(1), column(2)], column(3))
}

/// The qform: a rotation from the quaternion (b, c, d), voxel sizes from `pixdim` (with
/// `pixdim[0] < 0` flipping k) and the offset `qoffset_*`.
fn qform(header: &NiftiHeader) -> Option<Mat4> {
    // In f64, so that a unit rotation keeps the voxel sizes exact in f32.
    let [b, c, d] = [header.quatern_b, header.quatern_c, header.quatern_d].map(f64::from);
    let a2 = 1.0 - (b * b + c * c + d * d);
    // A tiny a^2 is rounding noise around a 180 degree rotation (a = 0), as nifti1.h prescribes.
    let a = if a2 < 1e-7 { 0.0 } else { a2.sqrt() };
    let q = DQuat::from_xyzw(b, c, d, a);
    if !q.is_finite() || q.length() == 0.0 {
        return None;
    }
    let rotation = DMat3::from_quat(q.normalize()).as_mat3();
    let qfac = if header.pixdim[0] < 0.0 { -1.0 } else { 1.0 };
    let axes = [
        rotation.x_axis * pixdim(header, 1),
        rotation.y_axis * pixdim(header, 2),
        rotation.z_axis * (pixdim(header, 3) * qfac),
    ];
    Some(affine(axes, Vec3::new(header.quatern_x, header.quatern_y, header.quatern_z)))
}

#[cfg(test)]
mod tests {
    use glam::Vec4;

    use super::super::tests::{assert_mat_eq, gzip, load_quiet, write};
    use super::*;

    /// The fields of a hand-written NIfTI-1 header that the tests vary.
    struct TestHeader {
        dim: [i16; 8],
        datatype: i16,
        bitpix: i16,
        pixdim: [f32; 4],
        scl: [f32; 2],
        qform_code: i16,
        /// quatern_b, c, d, qoffset_x, y, z
        quatern: [f32; 6],
        sform_code: i16,
        srow: [[f32; 4]; 3],
        big_endian: bool,
    }

    impl Default for TestHeader {
        fn default() -> Self {
            TestHeader {
                dim: [3, 3, 2, 2, 1, 1, 1, 1],
                datatype: 4,
                bitpix: 16,
                pixdim: [1.0; 4],
                scl: [0.0, 0.0],
                qform_code: 0,
                quatern: [0.0; 6],
                sform_code: 0,
                srow: [[0.0; 4]; 3],
                big_endian: false,
            }
        }
    }

    impl TestHeader {
        /// The 348 header bytes, the 4 extension bytes (no extensions) and `data`.
        fn file(&self, data: &[u8]) -> Vec<u8> {
            let mut h = vec![0u8; 348];
            let be = self.big_endian;
            let mut put = |offset: usize, bytes: &[u8]| h[offset..offset + bytes.len()].copy_from_slice(bytes);
            let i16b = |v: i16| if be { v.to_be_bytes() } else { v.to_le_bytes() };
            let f32b = |v: f32| if be { v.to_be_bytes() } else { v.to_le_bytes() };
            put(0, &if be { 348i32.to_be_bytes() } else { 348i32.to_le_bytes() });
            for (i, &d) in self.dim.iter().enumerate() {
                put(40 + 2 * i, &i16b(d));
            }
            put(70, &i16b(self.datatype));
            put(72, &i16b(self.bitpix));
            for (i, &p) in self.pixdim.iter().enumerate() {
                put(76 + 4 * i, &f32b(p));
            }
            put(108, &f32b(352.0));
            put(112, &f32b(self.scl[0]));
            put(116, &f32b(self.scl[1]));
            put(252, &i16b(self.qform_code));
            put(254, &i16b(self.sform_code));
            for (i, &q) in self.quatern.iter().enumerate() {
                put(256 + 4 * i, &f32b(q));
            }
            for (r, row) in self.srow.iter().enumerate() {
                for (c, &v) in row.iter().enumerate() {
                    put(280 + 16 * r + 4 * c, &f32b(v));
                }
            }
            put(344, b"n+1\0");
            h.extend_from_slice(&[0, 0, 0, 0]);
            h.extend_from_slice(data);
            h
        }
    }

    fn i16_data(values: &[i16], big_endian: bool) -> Vec<u8> {
        values.iter().flat_map(|v| if big_endian { v.to_be_bytes() } else { v.to_le_bytes() }).collect()
    }

    const VALUES: [i16; 12] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, -11];

    #[test]
    fn nii_with_scaling_and_sform() {
        let dir = tempfile::tempdir().unwrap();
        let header = TestHeader {
            scl: [2.0, 1.0],
            sform_code: 1,
            srow: [[0.0, 0.0, 3.0, 10.0], [-2.0, 0.0, 0.0, 20.0], [0.0, 1.5, 0.0, 30.0]],
            qform_code: 1,
            quatern: [0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
            ..TestHeader::default()
        };
        let path = write(&dir, "v.nii", &header.file(&i16_data(&VALUES, false)));
        let mut calls = Vec::new();
        let v = super::super::load(&path, &mut |done, total| calls.push((done, total))).unwrap();
        assert_eq!(v.dims, [3, 2, 2]);
        let expected: Vec<f32> = VALUES.iter().map(|&x| f32::from(x) * 2.0 + 1.0).collect();
        assert_eq!(v.values(), expected);
        assert_eq!(v.range, [-21.0, 21.0]);
        assert_mat_eq(
            v.grid_to_world,
            Mat4::from_cols(
                Vec4::new(0.0, -2.0, 0.0, 0.0),
                Vec4::new(0.0, 0.0, 1.5, 0.0),
                Vec4::new(3.0, 0.0, 0.0, 0.0),
                Vec4::new(10.0, 20.0, 30.0, 1.0),
            ),
        );
        assert_eq!(v.spacing, [2.0, 1.5, 3.0]);
        let len = std::fs::metadata(&path).unwrap().len();
        assert_eq!(calls.last(), Some(&(len, len)));
    }

    #[test]
    fn nii_gz_big_endian_float_with_qform() {
        let dir = tempfile::tempdir().unwrap();
        let half = std::f32::consts::FRAC_1_SQRT_2;
        let header = TestHeader {
            datatype: 16,
            bitpix: 32,
            // qfac -1 flips k.
            pixdim: [-1.0, 2.0, 3.0, 4.0],
            qform_code: 1,
            // 90 degrees about z: (b, c, d) = (0, 0, sin 45).
            quatern: [0.0, 0.0, half, 5.0, 6.0, 7.0],
            big_endian: true,
            ..TestHeader::default()
        };
        let values: Vec<f32> = (0..12).map(|i| i as f32 * 0.5).collect();
        let data: Vec<u8> = values.iter().flat_map(|v| v.to_be_bytes()).collect();
        let path = write(&dir, "v.nii.gz", &gzip(&header.file(&data)));
        let v = load_quiet(&path).unwrap();
        assert_eq!(v.values(), values);
        assert_mat_eq(
            v.grid_to_world,
            Mat4::from_cols(
                Vec4::new(0.0, 2.0, 0.0, 0.0),
                Vec4::new(-3.0, 0.0, 0.0, 0.0),
                Vec4::new(0.0, 0.0, -4.0, 0.0),
                Vec4::new(5.0, 6.0, 7.0, 1.0),
            ),
        );
        assert_eq!(v.spacing, [2.0, 3.0, 4.0]);
    }

    #[test]
    fn nii_without_transforms_uses_pixdim() {
        let dir = tempfile::tempdir().unwrap();
        let header =
            TestHeader { pixdim: [1.0, 0.5, 0.0, 2.0], dim: [4, 3, 2, 2, 1, 1, 1, 1], ..TestHeader::default() };
        let path = write(&dir, "v.nii", &header.file(&i16_data(&VALUES, false)));
        let v = load_quiet(&path).unwrap();
        assert_mat_eq(v.grid_to_world, Mat4::from_scale(Vec3::new(0.5, 1.0, 2.0)));
        // A singular sform falls back to pixdim as well.
        let header = TestHeader { sform_code: 2, ..header };
        let path = write(&dir, "w.nii", &header.file(&i16_data(&VALUES, false)));
        assert_mat_eq(load_quiet(&path).unwrap().grid_to_world, Mat4::from_scale(Vec3::new(0.5, 1.0, 2.0)));
    }

    /// [`super::super::tests::load_err`] in a directory of its own.
    fn load_err(name: &str, bytes: &[u8]) -> (bool, String) {
        super::super::tests::load_err(&tempfile::tempdir().unwrap(), name, bytes)
    }

    #[test]
    fn nii_data_length_must_match() {
        let data = i16_data(&VALUES, false);
        let file = TestHeader::default().file(&data);
        let (io, message) = load_err("v.nii", &file[..file.len() - 4]);
        assert!(!io);
        assert_eq!(message, "header says 24 bytes of data, file has 20");
        let mut long = file.clone();
        long.push(0);
        assert_eq!(load_err("v.nii", &long).1, "header says 24 bytes of data, file has 25");
        let (io, message) = load_err("v.nii.gz", &gzip(&file[..file.len() - 2]));
        assert!(!io);
        assert_eq!(message, "header says 24 bytes of data, the decompressed data has 22");
    }

    /// A small compressed file whose header claims 1040^3 voxels (2.2 GB) is refused before
    /// anything is allocated: its few compressed bytes cannot expand to the claim. A claim they
    /// could hold is kept as it is decompressed, and ends in an error at the end of its data.
    #[test]
    fn a_small_gzip_claiming_a_huge_volume_is_an_error() {
        let header = TestHeader { dim: [3, 1040, 1040, 1040, 1, 1, 1, 1], ..TestHeader::default() };
        let file = gzip(&header.file(&[0u8; 4096]));
        let (io, message) = load_err("v.nii.gz", &file);
        assert!(!io);
        let expected =
            format!("header says 2249728000 bytes of data, more than {} compressed bytes can hold", file.len());
        assert_eq!(message, expected);
        let header = TestHeader { dim: [3, 16, 16, 16, 1, 1, 1, 1], ..TestHeader::default() };
        let (_, message) = load_err("v.nii.gz", &gzip(&header.file(&[0u8; 4096])));
        assert_eq!(message, "header says 8192 bytes of data, the decompressed data has 4096");
    }

    /// An uncompressed `.nii` whose header claims more than the file holds.
    #[test]
    fn a_small_nii_claiming_a_huge_volume_is_an_error() {
        let header = TestHeader { dim: [3, 1000, 1000, 1000, 1, 1, 1, 1], ..TestHeader::default() };
        let (io, message) = load_err("v.nii", &header.file(&[0u8; 64]));
        assert!(!io);
        assert_eq!(message, "header says 2000000000 bytes of data, file has 64");
        let header = TestHeader { dim: [3, 100, 100, 100, 1, 1, 1, 1], ..TestHeader::default() };
        assert!(load_err("v.nii", &header.file(&[0u8; 64])).1.starts_with("header says 2000000 bytes"));
    }

    #[test]
    fn truncated_gzip_is_content_error() {
        let gz = gzip(&TestHeader::default().file(&i16_data(&VALUES, false)));
        for cut in [gz.len() - 4, gz.len() / 2, 5] {
            let (io, message) = load_err("v.nii.gz", &gz[..cut]);
            assert!(!io, "{message}");
        }
        let (io, message) = load_err("v.nii.gz", b"not gzip at all");
        assert!(!io);
        assert!(message.starts_with("corrupt or truncated compressed data: "), "{message}");
    }

    #[test]
    fn nii_header_errors() {
        let data = i16_data(&VALUES, false);
        let message = |header: TestHeader| load_err("v.nii", &header.file(&data)).1;
        let four_d = message(TestHeader { dim: [4, 3, 2, 1, 2, 1, 1, 1], ..TestHeader::default() });
        assert!(four_d.contains("`dim[4]` is 2"), "{four_d}");
        let two_d = message(TestHeader { dim: [2, 3, 4, 1, 1, 1, 1, 1], ..TestHeader::default() });
        assert_eq!(two_d, "not a 3D volume: `dim[0]` is 2");
        let rgb = message(TestHeader { datatype: 128, ..TestHeader::default() });
        assert!(rgb.starts_with("unsupported `datatype` 128 (RGB24)"), "{rgb}");
        let unknown = message(TestHeader { datatype: 3, ..TestHeader::default() });
        assert!(unknown.starts_with("unsupported `datatype` 3 (unknown)"), "{unknown}");
        let huge = message(TestHeader { dim: [3, 32767, 32767, 32767, 1, 1, 1, 1], ..TestHeader::default() });
        assert!(huge.starts_with("too large: 32767 x 32767 x 32767"), "{huge}");
        let zero = message(TestHeader { dim: [3, 3, 0, 2, 1, 1, 1, 1], ..TestHeader::default() });
        assert!(zero.contains("zero size"), "{zero}");
        // A 4D file holding one volume is a 3D volume.
        let dir = tempfile::tempdir().unwrap();
        let one = TestHeader { dim: [4, 3, 2, 2, 1, 1, 1, 1], ..TestHeader::default() };
        assert_eq!(load_quiet(&write(&dir, "v.nii", &one.file(&data))).unwrap().dims, [3, 2, 2]);
    }

    #[test]
    fn not_nifti() {
        assert_eq!(load_err("v.nii", b"hello").1, "too short for a NIfTI-1 header (348 bytes)");
        let (io, message) = load_err("v.nii", &[1u8; 400]);
        assert!(!io);
        assert!(message.starts_with("not a NIfTI-1 file"), "{message}");
        let mut pair = TestHeader::default().file(&[]);
        pair[344..348].copy_from_slice(b"ni1\0");
        assert!(load_err("v.nii", &pair).1.contains(".hdr/.img pair"));
    }
}
