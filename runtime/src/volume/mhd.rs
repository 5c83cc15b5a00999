//! MetaImage files: `.mhd` headers naming a data file, and `.mha` files with the data after the
//! header (`ElementDataFile = LOCAL`); raw or zlib-compressed (`CompressedData = True`).
//!
//! MetaImage positions are in ITK's LPS space; they are converted to RAS like every volume.

use std::collections::HashMap;
use std::io::BufRead;
use std::path::Path;

use glam::{Mat4, Vec3};

use super::raw::{Encoding, Placement};
use super::text_header::{self, Syntax, TextHeader, read_fields};
use super::{
    Layout, LoadErrorKind, RawData, SampleSink, ScalarType, VolumeInfo, affine, check_dims, is_usable, lps_to_ras,
    parse_numbers,
};

/// Loads a `.mhd` or `.mha` file.
pub(super) fn load(
    path: &Path,
    progress: &mut dyn FnMut(u64, u64),
    sink: &mut dyn SampleSink,
) -> Result<VolumeInfo, LoadErrorKind> {
    text_header::load(path, progress, parse, sink)
}

/// Where the samples of a `.mhd` or `.mha` file lie; `None` for compressed data.
pub(super) fn locate(path: &Path) -> Result<Option<RawData>, LoadErrorKind> {
    text_header::locate(path, parse)
}

/// Reads and validates the header; returns it with its length in bytes.
fn parse(reader: &mut dyn BufRead) -> Result<(TextHeader, u64), LoadErrorKind> {
    let (fields, header_len) = read_fields(reader, &SYNTAX)?;
    Ok((header(&fields)?, header_len))
}

/// MetaImage's `Key = Value` lines, up to and including `ElementDataFile`, which MetaImage
/// requires to be the last field (for `LOCAL` data the data starts right after it); keys are
/// matched in lowercase.
const SYNTAX: Syntax = Syntax {
    magic: None,
    separator: "=",
    metadata: None,
    key: |key| key.trim().to_ascii_lowercase(),
    blank_ends: false,
    last: Some(("elementdatafile", "ElementDataFile")),
    shape: "`Key = Value`",
    not_format: "not a MetaImage file: expected `Key = Value` header lines",
};

/// Validates the fields the data and its placement depend on.
fn header(fields: &HashMap<String, String>) -> Result<TextHeader, LoadErrorKind> {
    let get = |key: &str| fields.get(&key.to_ascii_lowercase()).map(String::as_str);
    let require = |key: &str| get(key).ok_or_else(|| LoadErrorKind::Header(format!("missing field `{key}`")));
    let header_error = |message: String| Err(LoadErrorKind::Header(message));

    if let Some(object) = get("ObjectType")
        && !object.eq_ignore_ascii_case("Image")
    {
        return header_error(format!("`ObjectType` is `{object}`, expected `Image`"));
    }
    let ndims = require("NDims")?;
    let ndims: usize = match ndims.parse() {
        Ok(n @ (3 | 4)) => n,
        _ => return header_error(format!("not a 3D volume: `NDims` is {ndims}")),
    };
    let sizes: Vec<u64> = parse_numbers("DimSize", require("DimSize")?)?;
    let sizes = match sizes[..] {
        [x, y, z] if ndims == 3 => [x, y, z],
        [x, y, z, 1] if ndims == 4 => [x, y, z],
        _ => return header_error(format!("`DimSize` {sizes:?} does not describe a 3D volume (`NDims` {ndims})")),
    };
    let dims = check_dims("DimSize", sizes)?;
    let ty = scalar_type(require("ElementType")?)?;
    if let Some(channels) = get("ElementNumberOfChannels")
        && channels != "1"
    {
        return header_error(format!(
            "`ElementNumberOfChannels` is {channels}; only scalar volumes (1 channel) are supported"
        ));
    }
    if get("BinaryData").is_some_and(|b| b.eq_ignore_ascii_case("false")) {
        return header_error("`BinaryData = False` (text data) is not supported".into());
    }
    let big_endian = boolean(fields, "BinaryDataByteOrderMSB")?.or(boolean(fields, "ElementByteOrderMSB")?);
    let compressed = boolean(fields, "CompressedData")?.unwrap_or(false);
    let skip = match get("HeaderSize").map(str::parse::<i64>) {
        None => Some(0),
        Some(Ok(-1)) if !compressed => None,
        Some(Ok(n)) if n >= 0 => Some(n as u64),
        Some(_) => {
            let value = get("HeaderSize").unwrap_or_default();
            return header_error(format!(
                "`HeaderSize` `{value}` is not a byte count (or -1 for uncompressed data at the end of the file)"
            ));
        }
    };
    let data_file = match require("ElementDataFile")? {
        local if local.eq_ignore_ascii_case("LOCAL") => None,
        list if list.starts_with("LIST") || list.contains('%') => {
            return header_error(format!("`ElementDataFile` `{list}`: data split over several files is not supported"));
        }
        name => Some(name.to_string()),
    };
    // `HeaderSize` describes a separate data file; LOCAL data starts right after the header.
    let skip = if data_file.is_some() { skip } else { Some(0) };
    let voxels = dims.iter().map(|&d| u64::from(d)).product();
    Ok(TextHeader {
        dims,
        grid_to_world: grid_to_world(fields, ndims)?,
        data_file,
        data: Placement {
            layout: Layout { ty, big_endian: big_endian.unwrap_or(false), voxels },
            encoding: if compressed { Encoding::Zlib } else { Encoding::Raw },
            skip,
            decoded_skip: 0,
        },
        line_skip: 0,
        past_end: |skip| LoadErrorKind::Header(format!("`HeaderSize` {skip} is past the end of the data file")),
    })
}

/// A `True`/`False` field, if present.
fn boolean(fields: &HashMap<String, String>, key: &str) -> Result<Option<bool>, LoadErrorKind> {
    match fields.get(&key.to_ascii_lowercase()).map(|v| v.to_ascii_lowercase()) {
        None => Ok(None),
        Some(v) if v == "true" || v == "1" => Ok(Some(true)),
        Some(v) if v == "false" || v == "0" => Ok(Some(false)),
        Some(v) => Err(LoadErrorKind::Header(format!("`{key}` is `{v}`, expected `True` or `False`"))),
    }
}

/// The sample type of an `ElementType`.
fn scalar_type(name: &str) -> Result<ScalarType, LoadErrorKind> {
    Ok(match name {
        "MET_UCHAR" => ScalarType::U8,
        "MET_CHAR" => ScalarType::I8,
        "MET_USHORT" => ScalarType::U16,
        "MET_SHORT" => ScalarType::I16,
        "MET_UINT" => ScalarType::U32,
        "MET_INT" => ScalarType::I32,
        "MET_FLOAT" => ScalarType::F32,
        "MET_DOUBLE" => ScalarType::F64,
        other => {
            return Err(LoadErrorKind::Header(format!(
                "unsupported `ElementType` `{other}`; supported: MET_UCHAR, MET_CHAR, MET_USHORT, MET_SHORT, \
                 MET_UINT, MET_INT, MET_FLOAT, MET_DOUBLE"
            )));
        }
    })
}

/// The first of `keys` that is present, as exactly `count` numbers (or `None`).
fn numbers(fields: &HashMap<String, String>, keys: &[&str], count: usize) -> Result<Option<Vec<f64>>, LoadErrorKind> {
    let Some((key, value)) = keys.iter().find_map(|k| fields.get(&k.to_ascii_lowercase()).map(|v| (k, v))) else {
        return Ok(None);
    };
    let numbers: Vec<f64> = parse_numbers(key, value)?;
    if numbers.len() != count || numbers.iter().any(|n| !n.is_finite()) {
        return Err(LoadErrorKind::Header(format!("`{key}` `{value}`: expected {count} finite numbers")));
    }
    Ok(Some(numbers))
}

/// The voxel-to-world matrix: axis i is column i of `TransformMatrix` (ITK's direction cosines)
/// times `ElementSpacing[i]`, and `Offset` places voxel (0, 0, 0); then LPS -> RAS.
fn grid_to_world(fields: &HashMap<String, String>, ndims: usize) -> Result<Mat4, LoadErrorKind> {
    let spacing = numbers(fields, &["ElementSpacing", "ElementSize"], ndims)?.unwrap_or(vec![1.0; ndims]);
    let offset = numbers(fields, &["Offset", "Origin", "Position"], ndims)?.unwrap_or(vec![0.0; ndims]);
    let directions = numbers(fields, &["TransformMatrix", "Rotation", "Orientation"], ndims * ndims)?;
    let axis = |i: usize| {
        let direction = match &directions {
            Some(m) => Vec3::new(m[ndims * i] as f32, m[ndims * i + 1] as f32, m[ndims * i + 2] as f32),
            None => [Vec3::X, Vec3::Y, Vec3::Z][i],
        };
        direction * spacing[i] as f32
    };
    let origin = Vec3::new(offset[0] as f32, offset[1] as f32, offset[2] as f32);
    let matrix = affine([axis(0), axis(1), axis(2)], origin);
    if !is_usable(&matrix) {
        return Err(LoadErrorKind::Header(
            "the voxel axes (`ElementSpacing` and `TransformMatrix`) are degenerate".into(),
        ));
    }
    Ok(lps_to_ras(matrix))
}

#[cfg(test)]
mod tests {
    use glam::Vec4;

    use super::super::tests::{assert_mat_eq, load_err, load_quiet, shorts_f32, shorts_le, write, zlib};
    use super::*;

    fn mha(header: &str, data: &[u8]) -> Vec<u8> {
        let mut bytes = format!("{header}\nElementDataFile = LOCAL\n").into_bytes();
        bytes.extend_from_slice(data);
        bytes
    }

    const HEADER: &str = "ObjectType = Image\nNDims = 3\nDimSize = 3 2 2\nElementType = MET_SHORT";

    #[test]
    fn mhd_with_raw_file_and_transform() {
        let dir = tempfile::tempdir().unwrap();
        let mut data = b"skipme".to_vec();
        data.extend(shorts_le());
        write(&dir, "v.raw", &data);
        let header = format!(
            "{HEADER}\nBinaryData = True\nBinaryDataByteOrderMSB = False\nTransformMatrix = 0 1 0 -1 0 0 0 0 1\n\
             Offset = 1 2 3\nElementSpacing = 0.5 0.25 2\nAnatomicalOrientation = RAI\nHeaderSize = 6\n\
             ElementDataFile = v.raw\n"
        );
        let v = load_quiet(&write(&dir, "v.mhd", header.as_bytes())).unwrap();
        assert_eq!(v.dims, [3, 2, 2]);
        assert_eq!(v.values(), shorts_f32());
        assert_eq!(v.spacing, [0.5, 0.25, 2.0]);
        // LPS axes (0, 0.5, 0), (-0.25, 0, 0), (0, 0, 2), origin (1, 2, 3); RAS negates x and y.
        assert_mat_eq(
            v.grid_to_world,
            Mat4::from_cols(
                Vec4::new(0.0, -0.5, 0.0, 0.0),
                Vec4::new(0.25, 0.0, 0.0, 0.0),
                Vec4::new(0.0, 0.0, 2.0, 0.0),
                Vec4::new(-1.0, -2.0, 3.0, 1.0),
            ),
        );

        // HeaderSize -1: the data is at the end.
        let header = header.replace("HeaderSize = 6", "HeaderSize = -1");
        assert_eq!(load_quiet(&write(&dir, "w.mhd", header.as_bytes())).unwrap().values(), shorts_f32());
    }

    #[test]
    fn mha_local_big_endian_float() {
        let dir = tempfile::tempdir().unwrap();
        let values: Vec<f32> = (0..12).map(|i| i as f32 * -0.25).collect();
        let data: Vec<u8> = values.iter().flat_map(|v| v.to_be_bytes()).collect();
        let header = HEADER.replace("MET_SHORT", "MET_FLOAT") + "\nBinaryDataByteOrderMSB = True";
        let mut calls = Vec::new();
        let path = write(&dir, "v.mha", &mha(&header, &data));
        let v = super::super::load(&path, &mut |d, t| calls.push((d, t))).unwrap();
        assert_eq!(v.values(), values);
        assert_mat_eq(v.grid_to_world, Mat4::from_scale(Vec3::new(-1.0, -1.0, 1.0)));
        let len = std::fs::metadata(&path).unwrap().len();
        assert_eq!(calls.last(), Some(&(len, len)));
    }

    #[test]
    fn compressed_local_and_separate() {
        let dir = tempfile::tempdir().unwrap();
        let bytes: Vec<u8> = (0..12).map(|i| i * 20).collect();
        let header = HEADER.replace("MET_SHORT", "MET_UCHAR") + "\nCompressedData = True\nCompressedDataSize = 99";
        let v = load_quiet(&write(&dir, "v.mha", &mha(&header, &zlib(&bytes)))).unwrap();
        assert_eq!(v.values(), bytes.iter().map(|&b| f32::from(b)).collect::<Vec<_>>());

        write(&dir, "v.zraw", &zlib(&shorts_le()));
        let header = format!("{HEADER}\nCompressedData = True\nElementDataFile = v.zraw");
        assert_eq!(load_quiet(&write(&dir, "v.mhd", header.as_bytes())).unwrap().values(), shorts_f32());
    }

    #[test]
    fn data_errors() {
        let dir = tempfile::tempdir().unwrap();
        let header = format!("{HEADER}\nElementDataFile = nowhere.raw\n");
        let (io, message) = load_err(&dir, "v.mhd", header.as_bytes());
        assert!(io);
        assert!(message.contains("nowhere.raw"), "{message}");

        assert_eq!(
            load_err(&dir, "v.mha", &mha(HEADER, &shorts_le()[..21])).1,
            "header says 24 bytes of data, file has 21"
        );
        let mut long = shorts_le();
        long.push(1);
        assert_eq!(load_err(&dir, "v.mha", &mha(HEADER, &long)).1, "header says 24 bytes of data, file has 25");

        let compressed = format!("{HEADER}\nCompressedData = True");
        let (io, message) = load_err(&dir, "v.mha", &mha(&compressed, &zlib(&shorts_le()[..20])));
        assert!(!io);
        assert_eq!(message, "header says 24 bytes of data, the decompressed data has 20");
        let z = zlib(&shorts_le());
        for cut in [z.len() - 2, z.len() / 2, 1] {
            let (io, message) = load_err(&dir, "v.mha", &mha(&compressed, &z[..cut]));
            assert!(!io, "{message}");
        }
        let (io, message) = load_err(&dir, "v.mha", &mha(&compressed, b"definitely not zlib"));
        assert!(!io);
        assert!(message.starts_with("corrupt or truncated compressed data: "), "{message}");
    }

    #[test]
    fn header_errors() {
        let dir = tempfile::tempdir().unwrap();
        let message = |header: String| load_err(&dir, "v.mha", &mha(&header, &shorts_le())).1;
        assert_eq!(
            message(HEADER.replace("MET_SHORT", "MET_LONG")),
            "unsupported `ElementType` `MET_LONG`; supported: MET_UCHAR, MET_CHAR, MET_USHORT, MET_SHORT, MET_UINT, \
             MET_INT, MET_FLOAT, MET_DOUBLE"
        );
        assert_eq!(message(HEADER.replace("NDims = 3", "NDims = 2")), "not a 3D volume: `NDims` is 2");
        assert!(message(HEADER.replace("3 2 2", "3 2")).contains("does not describe a 3D volume"));
        assert!(message(HEADER.replace("3 2 2", "0 2 2")).contains("`DimSize` has a zero size"));
        assert!(message(HEADER.replace("3 2 2", "4000000 4000000 4000000")).starts_with("too large: "));
        assert_eq!(message(HEADER.replace("ElementType = MET_SHORT", "")), "missing field `ElementType`");
        assert!(message(HEADER.replace("Image", "Mesh")).contains("`ObjectType` is `Mesh`"));
        assert!(message(format!("{HEADER}\nElementNumberOfChannels = 3")).contains("only scalar volumes"));
        assert!(message(format!("{HEADER}\nElementSpacing = 1 1")).contains("expected 3 finite numbers"));
        assert!(message(format!("{HEADER}\nElementSpacing = 1 0 1")).contains("degenerate"));
        assert!(message(format!("{HEADER}\nBinaryDataByteOrderMSB = maybe")).contains("expected `True` or `False`"));
        let (_, missing) = load_err(&dir, "v.mhd", HEADER.as_bytes());
        assert_eq!(missing, "missing field `ElementDataFile`");
        let (io, binary) = load_err(&dir, "v.mha", &[0u8, 159, 146, 150, 10, 1, 2]);
        assert!(!io);
        assert_eq!(binary, "not a MetaImage file: expected `Key = Value` header lines");
    }

    #[test]
    fn four_dims_with_a_single_frame() {
        let dir = tempfile::tempdir().unwrap();
        let header = "NDims = 4\nDimSize = 3 2 2 1\nElementType = MET_SHORT\nElementSpacing = 1 1 3 1";
        let v = load_quiet(&write(&dir, "v.mha", &mha(header, &shorts_le()))).unwrap();
        assert_eq!(v.dims, [3, 2, 2]);
        assert_eq!(v.spacing, [1.0, 1.0, 3.0]);
    }
}
