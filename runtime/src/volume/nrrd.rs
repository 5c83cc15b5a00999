//! NRRD files: attached (`.nrrd`) and detached (`.nhdr` + data file) headers, raw and gzip
//! encodings.
//!
//! The header is read line by line and every field the data depends on is validated before the
//! data is touched. Fields that do not affect a scalar 3D volume (`kinds`, `centers`, `units`,
//! `content`, key/value pairs, ...) are ignored.

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

/// Loads a `.nrrd` or `.nhdr` file.
pub(super) fn load(
    path: &Path,
    progress: &mut dyn FnMut(u64, u64),
    sink: &mut dyn SampleSink,
) -> Result<VolumeInfo, LoadErrorKind> {
    text_header::load(path, progress, |reader| parse(path, reader), sink)
}

/// Where the samples of a `.nrrd` or `.nhdr` file lie; `None` for gzip data.
pub(super) fn locate(path: &Path) -> Result<Option<RawData>, LoadErrorKind> {
    text_header::locate(path, |reader| parse(path, reader))
}

/// Reads and validates the header of the file at `path`; returns it with its length in bytes.
fn parse(path: &Path, reader: &mut dyn BufRead) -> Result<(TextHeader, u64), LoadErrorKind> {
    let (fields, header_len) = read_fields(reader, &SYNTAX)?;
    let header = header(&fields)?;
    if header.data_file.is_none() && path.extension().is_some_and(|e| e.eq_ignore_ascii_case("nhdr")) {
        return Err(LoadErrorKind::Header(
            "missing field `data file` (a detached .nhdr header names its data file)".into(),
        ));
    }
    Ok((header, header_len))
}

/// NRRD's header: the magic line, then `field: value` lines up to the blank line that ends an
/// attached header (or the end of a detached one), `key:=value` pairs skipped. Fields are
/// stored by normalized name (lowercase, no spaces, so `data file` and `datafile` are one).
const SYNTAX: Syntax = Syntax {
    magic: Some("NRRD000"),
    separator: ": ",
    metadata: Some(":="),
    key: |key| key.replace(' ', "").to_ascii_lowercase(),
    blank_ends: true,
    last: None,
    shape: "`field: value`",
    not_format: "not a NRRD file: it does not start with `NRRD000`",
};

/// Validates the fields the data and its placement depend on.
fn header(fields: &HashMap<String, String>) -> Result<TextHeader, LoadErrorKind> {
    let get = |key: &str| fields.get(key).map(String::as_str);
    let require =
        |key: &str, name: &str| get(key).ok_or_else(|| LoadErrorKind::Header(format!("missing field `{name}`")));
    let dimension = require("dimension", "dimension")?;
    let dimension: usize =
        dimension.parse().map_err(|_| LoadErrorKind::Header(format!("`dimension` `{dimension}` is not a number")))?;
    let sizes: Vec<u64> = parse_numbers("sizes", require("sizes", "sizes")?)?;
    if sizes.len() != dimension {
        return Err(LoadErrorKind::Header(format!(
            "`sizes` has {} numbers but `dimension` is {dimension}",
            sizes.len()
        )));
    }
    let axes = spatial_axes(&sizes)?;
    let dims = check_dims("sizes", axes.map(|a| sizes[a]))?;
    let ty = scalar_type(require("type", "type")?)?;
    let encoding = match require("encoding", "encoding")? {
        "raw" => Encoding::Raw,
        "gzip" | "gz" => Encoding::Gzip,
        other => {
            return Err(LoadErrorKind::Header(format!("unsupported `encoding` `{other}`; supported: raw, gzip")));
        }
    };
    let big_endian = match (ty.size(), get("endian")) {
        (1, _) => false,
        (_, Some("little")) => false,
        (_, Some("big")) => true,
        (_, Some(other)) => {
            return Err(LoadErrorKind::Header(format!("`endian` is `{other}`, expected `little` or `big`")));
        }
        (_, None) => return Err(LoadErrorKind::Header("missing field `endian`".into())),
    };
    let byte_skip = match get("byteskip").map(str::parse::<i64>) {
        None => Some(0),
        Some(Ok(-1)) if encoding == Encoding::Raw => None,
        Some(Ok(n)) if n >= 0 => Some(n as u64),
        Some(_) => {
            return Err(LoadErrorKind::Header(format!(
                "`byte skip` `{}` is not a byte count (or -1 for raw data at the end of the file)",
                get("byteskip").unwrap_or_default()
            )));
        }
    };
    let line_skip = match get("lineskip") {
        None => 0,
        Some(v) => v.parse().map_err(|_| LoadErrorKind::Header(format!("`line skip` `{v}` is not a count")))?,
    };
    let data_file = get("datafile").map(data_file).transpose()?;
    // For gzip, `byte skip` counts bytes of the decompressed data, as NRRD specifies.
    let (skip, decoded_skip) = match encoding {
        Encoding::Raw => (byte_skip, 0),
        Encoding::Gzip | Encoding::Zlib => (Some(0), byte_skip.unwrap_or_default()),
    };
    let voxels = dims.iter().map(|&d| u64::from(d)).product();
    Ok(TextHeader {
        dims,
        grid_to_world: grid_to_world(fields, &sizes, axes)?,
        data_file,
        data: Placement { layout: Layout { ty, big_endian, voxels }, encoding, skip, decoded_skip },
        line_skip,
        past_end: |skip| LoadErrorKind::Header(format!("`byte skip` {skip} is past the end of the data")),
    })
}

/// The indices of the three spatial axes among `sizes`: all of a 3D volume, or the last three
/// of a 4D one whose first axis has one sample (a one-component "vector" volume).
fn spatial_axes(sizes: &[u64]) -> Result<[usize; 3], LoadErrorKind> {
    match sizes {
        [_, _, _] => Ok([0, 1, 2]),
        [1, _, _, _] => Ok([1, 2, 3]),
        _ => Err(LoadErrorKind::Header(format!(
            "not a 3D volume: `dimension` is {} with `sizes` {:?} (3D, or 4D with a first axis of size 1, is supported)",
            sizes.len(),
            sizes
        ))),
    }
}

/// The sample type of a NRRD `type` (all of its spellings).
fn scalar_type(name: &str) -> Result<ScalarType, LoadErrorKind> {
    Ok(match name {
        "signed char" | "int8" | "int8_t" => ScalarType::I8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => ScalarType::U8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => ScalarType::I16,
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => ScalarType::U16,
        "int" | "signed int" | "int32" | "int32_t" => ScalarType::I32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => ScalarType::U32,
        "float" => ScalarType::F32,
        "double" => ScalarType::F64,
        other => {
            return Err(LoadErrorKind::Header(format!(
                "unsupported `type` `{other}`; supported: int8, uint8, int16, uint16, int32, uint32, float, double"
            )));
        }
    })
}

/// The `data file` field as one file name; the multi-file forms are refused.
fn data_file(value: &str) -> Result<String, LoadErrorKind> {
    if value.starts_with("LIST") || value.contains('%') {
        Err(LoadErrorKind::Header(format!("`data file` `{value}`: data split over several files is not supported")))
    } else {
        Ok(value.to_string())
    }
}

/// The voxel-to-world matrix: `space directions` and `space origin` when given (converted from
/// the header's `space` to RAS), else `spacings` along the axes, else unit voxels.
fn grid_to_world(fields: &HashMap<String, String>, sizes: &[u64], axes: [usize; 3]) -> Result<Mat4, LoadErrorKind> {
    let origin = match fields.get("spaceorigin") {
        Some(value) => match parse_vectors(value).as_deref() {
            Ok([Some(v)]) => vec3("space origin", v)?,
            _ => return Err(LoadErrorKind::Header(format!("`space origin` `{value}` is not one vector `(x,y,z)`"))),
        },
        None => Vec3::ZERO,
    };
    let matrix = if let Some(value) = fields.get("spacedirections") {
        let bad = |why: &str| LoadErrorKind::Header(format!("`space directions` `{value}`: {why}"));
        let vectors = parse_vectors(value).map_err(|why| bad(&why))?;
        if vectors.len() != sizes.len() {
            return Err(bad(&format!("{} entries for {} axes", vectors.len(), sizes.len())));
        }
        let axis = |a: usize| match &vectors[a] {
            Some(v) => vec3("space directions", v),
            None => Err(bad(&format!("axis {a} is `none`"))),
        };
        affine([axis(axes[0])?, axis(axes[1])?, axis(axes[2])?], origin)
    } else if let Some(value) = fields.get("spacings") {
        let spacings: Vec<f64> = parse_numbers("spacings", value)?;
        let spacing = |a: usize| match spacings.get(a) {
            Some(&s) if s.is_finite() && s != 0.0 => Ok(s as f32),
            _ => Err(LoadErrorKind::Header(format!("`spacings` `{value}`: axis {a} has no usable spacing"))),
        };
        let [x, y, z] = [spacing(axes[0])?, spacing(axes[1])?, spacing(axes[2])?];
        affine([Vec3::X * x, Vec3::Y * y, Vec3::Z * z], origin)
    } else {
        affine([Vec3::X, Vec3::Y, Vec3::Z], origin)
    };
    if !is_usable(&matrix) {
        return Err(LoadErrorKind::Header("the voxel axes (`space directions` or `spacings`) are degenerate".into()));
    }
    Ok(to_ras(fields.get("space").map(String::as_str), matrix))
}

/// Converts a matrix from the header's `space` into RAS: LPS and LAS flip axes; RAS and the
/// frames that are not anatomical (`scanner-xyz`, `3D-right-handed`, ...) stay as they are.
fn to_ras(space: Option<&str>, matrix: Mat4) -> Mat4 {
    let space = space.unwrap_or_default().to_ascii_lowercase();
    match space.strip_suffix("-time").unwrap_or(&space) {
        "left-posterior-superior" | "lps" => lps_to_ras(matrix),
        "left-anterior-superior" | "las" => Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)) * matrix,
        _ => matrix,
    }
}

/// A 3-vector from parsed components, refusing other lengths and non-finite numbers.
fn vec3(field: &str, v: &[f64]) -> Result<Vec3, LoadErrorKind> {
    match v {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vec3::new(*x as f32, *y as f32, *z as f32)),
        [_, _, _] => Err(LoadErrorKind::Header(format!("`{field}` has a component that is not a finite number"))),
        _ => Err(LoadErrorKind::Header(format!(
            "`{field}` has {}-component vectors; only 3D space is supported",
            v.len()
        ))),
    }
}

/// Parses NRRD vectors: `(1,0,0) (0, 1, 0) none`, with `None` for `none`.
fn parse_vectors(value: &str) -> Result<Vec<Option<Vec<f64>>>, String> {
    let mut vectors = Vec::new();
    let mut rest = value.trim_start();
    while !rest.is_empty() {
        if let Some(after) = rest.strip_prefix("none") {
            vectors.push(None);
            rest = after.trim_start();
            continue;
        }
        let inner = rest.strip_prefix('(').ok_or_else(|| format!("expected `(` or `none` at `{rest}`"))?;
        let end = inner.find(')').ok_or("a `(` is not closed")?;
        let components = inner[..end]
            .split(',')
            .map(|c| c.trim().parse::<f64>().map_err(|_| format!("`{}` is not a number", c.trim())))
            .collect::<Result<Vec<_>, _>>()?;
        vectors.push(Some(components));
        rest = inner[end + 1..].trim_start();
    }
    Ok(vectors)
}

#[cfg(test)]
mod tests {
    use glam::Vec4;

    use super::super::tests::{assert_mat_eq, gzip, load_err, load_quiet, shorts_f32, shorts_le, write};
    use super::*;

    /// An attached NRRD file: `header` lines (after the magic), a blank line, then `data`.
    fn attached(header: &str, data: &[u8]) -> Vec<u8> {
        let mut bytes = format!("NRRD0004\n# a comment\n{}\n\n", header.trim_end()).into_bytes();
        bytes.extend_from_slice(data);
        bytes
    }

    #[test]
    fn streaming_gives_the_range_and_info_of_a_load_without_keeping_samples() {
        let dir = tempfile::tempdir().unwrap();
        let header = "type: short\ndimension: 3\nsizes: 3 2 2\nendian: little\nencoding: gzip\nspacings: 1 2 3\n";
        let path = write(&dir, "v.nrrd", &attached(header, &gzip(&shorts_le())));
        let loaded = load_quiet(&path).unwrap();
        let mut range = super::super::RangeSink::default();
        let info = super::super::stream(&path, &mut |_, _| {}, &mut range).unwrap();
        assert_eq!(range.range(), loaded.range);
        assert_eq!(range.range(), [-5.0, 300.0]);
        assert_eq!((info.dims, info.grid_to_world, info.scaling), (loaded.dims, loaded.grid_to_world, loaded.scaling));
        assert!(matches!(loaded.samples, super::super::Samples::I16(_)), "shorts stay shorts: {loaded:?}");
    }

    #[test]
    fn raw_little_endian_with_space_directions() {
        let dir = tempfile::tempdir().unwrap();
        let header = "type: short\ndimension: 3\nspace: left-posterior-superior\nsizes: 3 2 2\n\
                      space directions: (0.5,0,0) (0, 2,0) (0,0,3)\nkinds: domain domain domain\n\
                      endian: little\nencoding: raw\nspace origin: (10,20,30)\nkey:=value: with: colons\n";
        let path = write(&dir, "v.nrrd", &attached(header, &shorts_le()));
        let v = load_quiet(&path).unwrap();
        assert_eq!(v.dims, [3, 2, 2]);
        assert_eq!(v.values(), shorts_f32());
        assert_eq!(v.range, [-5.0, 300.0]);
        assert_eq!(v.spacing, [0.5, 2.0, 3.0]);
        // LPS -> RAS negates x and y.
        assert_mat_eq(
            v.grid_to_world,
            Mat4::from_cols(
                Vec4::new(-0.5, 0.0, 0.0, 0.0),
                Vec4::new(0.0, -2.0, 0.0, 0.0),
                Vec4::new(0.0, 0.0, 3.0, 0.0),
                Vec4::new(-10.0, -20.0, 30.0, 1.0),
            ),
        );
    }

    #[test]
    fn gzip_big_endian_with_spacings() {
        let dir = tempfile::tempdir().unwrap();
        let values: Vec<f32> = (0..12).map(|i| i as f32 - 3.5).collect();
        let data: Vec<u8> = values.iter().flat_map(|v| v.to_be_bytes()).collect();
        let header = "type: float\ndimension: 3\nsizes: 2 3 2\nspacings: 1.5 2 2.5\nendian: big\nencoding: gzip";
        let mut calls = Vec::new();
        let path = write(&dir, "v.nrrd", &attached(header, &gzip(&data)));
        let v = super::super::load(&path, &mut |d, t| calls.push((d, t))).unwrap();
        assert_eq!(v.dims, [2, 3, 2]);
        assert_eq!(v.values(), values);
        assert_mat_eq(v.grid_to_world, Mat4::from_scale(Vec3::new(1.5, 2.0, 2.5)));
        let len = std::fs::metadata(&path).unwrap().len();
        assert_eq!(calls.last(), Some(&(len, len)));
    }

    #[test]
    fn detached_header_with_skips() {
        let dir = tempfile::tempdir().unwrap();
        let values: Vec<u16> = (0..12).map(|i| 1000 * i).collect();
        let mut data = b"a text line\nXYZ".to_vec();
        data.extend(values.iter().flat_map(|v| v.to_be_bytes()));
        write(&dir, "data.raw", &data);
        let header = "NRRD0005\ntype: unsigned short\ndimension: 3\nsizes: 3 2 2\nendian: big\nencoding: raw\n\
                      data file: data.raw\nline skip: 1\nbyte skip: 3\n";
        let mut calls = Vec::new();
        let v = super::super::load(&write(&dir, "v.nhdr", header.as_bytes()), &mut |d, t| calls.push((d, t))).unwrap();
        assert_eq!(v.values(), values.iter().map(|&v| f32::from(v)).collect::<Vec<_>>());
        // Progress is about the data file only.
        assert_eq!(calls, vec![(data.len() as u64, data.len() as u64)]);
        assert_mat_eq(v.grid_to_world, Mat4::IDENTITY);

        // byte skip -1: the data is at the end of the file.
        let header = header.replace("line skip: 1\nbyte skip: 3", "byte skip: -1");
        assert_eq!(load_quiet(&write(&dir, "w.nhdr", header.as_bytes())).unwrap().values(), v.values());
    }

    #[test]
    fn detached_gzip_and_4d_with_a_single_component() {
        let dir = tempfile::tempdir().unwrap();
        write(&dir, "data.raw.gz", &gzip(&shorts_le()));
        let header = "NRRD0004\ntype: int16\ndimension: 4\nsizes: 1 3 2 2\nendian: little\nencoding: gz\n\
                      space: RAS\nspace directions: none (1,0,0) (0,1,0) (0,0,2)\ndatafile: data.raw.gz\n";
        let v = load_quiet(&write(&dir, "v.nhdr", header.as_bytes())).unwrap();
        assert_eq!(v.dims, [3, 2, 2]);
        assert_eq!(v.values(), shorts_f32());
        assert_mat_eq(v.grid_to_world, Mat4::from_scale(Vec3::new(1.0, 1.0, 2.0)));
    }

    #[test]
    fn data_file_errors() {
        let dir = tempfile::tempdir().unwrap();
        let header = "NRRD0004\ntype: short\ndimension: 3\nsizes: 3 2 2\nendian: little\nencoding: raw\n\
                      data file: missing.raw\n";
        let (io, message) = load_err(&dir, "v.nhdr", header.as_bytes());
        assert!(io);
        assert!(message.starts_with("cannot read the data file `"), "{message}");
        assert!(message.contains("missing.raw"), "{message}");

        let header = header.replace("data file: missing.raw\n", "");
        let (io, message) = load_err(&dir, "v.nhdr", header.as_bytes());
        assert!(!io);
        assert_eq!(message, "missing field `data file` (a detached .nhdr header names its data file)");

        write(&dir, "short.raw", &shorts_le()[..20]);
        let header = format!("{header}data file: short.raw\n");
        assert_eq!(load_err(&dir, "v.nhdr", header.as_bytes()).1, "header says 24 bytes of data, file has 20");
    }

    #[test]
    fn size_mismatch_and_truncation() {
        let dir = tempfile::tempdir().unwrap();
        let raw = "type: short\ndimension: 3\nsizes: 3 2 2\nendian: little\nencoding: raw";
        let data = shorts_le();
        assert_eq!(
            load_err(&dir, "v.nrrd", &attached(raw, &data[..23])).1,
            "header says 24 bytes of data, file has 23"
        );
        let mut long = data.clone();
        long.extend_from_slice(&[0, 0]);
        assert_eq!(load_err(&dir, "v.nrrd", &attached(raw, &long)).1, "header says 24 bytes of data, file has 26");

        let gz = raw.replace("raw", "gzip");
        let (io, message) = load_err(&dir, "v.nrrd", &attached(&gz, &gzip(&data[..22])));
        assert!(!io);
        assert_eq!(message, "header says 24 bytes of data, the decompressed data has 22");
        let compressed = gzip(&data);
        for cut in [compressed.len() - 3, compressed.len() / 2, 4] {
            let (io, message) = load_err(&dir, "v.nrrd", &attached(&gz, &compressed[..cut]));
            assert!(!io, "{message}");
        }
    }

    #[test]
    fn header_errors() {
        let dir = tempfile::tempdir().unwrap();
        let good = "type: short\ndimension: 3\nsizes: 3 2 2\nendian: little\nencoding: raw";
        let message = |header: String| load_err(&dir, "v.nrrd", &attached(&header, &shorts_le())).1;
        assert_eq!(
            message(good.replace("short", "long double")),
            "unsupported `type` `long double`; supported: int8, uint8, int16, uint16, int32, uint32, float, double"
        );
        assert!(message(good.replace("sizes: 3 2 2", "sizes: 100000 100000 100000")).starts_with("too large: "));
        assert!(message(good.replace("sizes: 3 2 2", "sizes: 3 0 2")).contains("zero size"));
        assert!(message(good.replace("sizes: 3 2 2", "sizes: 3 2 x")).contains("`x` is not a number"));
        let two_d = message(good.replace("dimension: 3\nsizes: 3 2 2", "dimension: 2\nsizes: 6 2"));
        assert!(two_d.starts_with("not a 3D volume: `dimension` is 2"), "{two_d}");
        let four_d = message(good.replace("dimension: 3\nsizes: 3 2 2", "dimension: 4\nsizes: 3 2 2 1"));
        assert!(four_d.starts_with("not a 3D volume"), "{four_d}");
        assert_eq!(message(good.replace("dimension: 3", "dimension: 4")), "`sizes` has 3 numbers but `dimension` is 4");
        assert_eq!(message(good.replace("endian: little\n", "")), "missing field `endian`");
        assert_eq!(message(good.replace("type: short\n", "")), "missing field `type`");
        assert_eq!(
            message(good.replace("encoding: raw", "encoding: bzip2")),
            "unsupported `encoding` `bzip2`; supported: raw, gzip"
        );
        let dirs = message(format!("{good}\nspace directions: (1,0,0) (0,1,0)"));
        assert!(dirs.contains("2 entries for 3 axes"), "{dirs}");
        let dirs = message(format!("{good}\nspace directions: (1,0,0) (0,1,0) (0,0,0)"));
        assert!(dirs.contains("degenerate"), "{dirs}");
        assert!(message(format!("{good}\nbyte skip: -2")).contains("`byte skip` `-2`"));
        assert!(message(format!("{good}\nbyte skip: 100")).contains("`byte skip` 100 is past the end"));
        assert!(message(format!("{good}\nthis line has no separator")).contains("is not `field: value`"));
        let (io, not_nrrd) = load_err(&dir, "v.nrrd", b"\x89PNG\r\n\x1a\n binary");
        assert!(!io);
        assert_eq!(not_nrrd, "not a NRRD file: it does not start with `NRRD000`");
    }

    #[test]
    fn vectors_parse() {
        let parsed = parse_vectors("none (1, 2,3)  (4,5,6)").unwrap();
        assert_eq!(parsed, vec![None, Some(vec![1.0, 2.0, 3.0]), Some(vec![4.0, 5.0, 6.0])]);
        assert!(parse_vectors("(1,2,3").is_err());
        assert!(parse_vectors("[1,2,3]").is_err());
        assert!(parse_vectors("(1,a,3)").is_err());
    }
}
