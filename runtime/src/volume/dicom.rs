//! DICOM series: a folder holding the slices of one series, one image per file.
//!
//! Each file's header is read first (up to the pixel data), so a folder with several series,
//! missing slices or unequal spacing is refused before any pixel data is decoded. Slices are
//! ordered by their position along the slice normal (the cross product of the image's row and
//! column directions), never by file name or instance number, which scanners and anonymizers
//! do not keep consistent. Rescale slope and intercept are applied to every slice.
//!
//! Pixel data is decoded by `dicom-pixeldata` with its pure-Rust codecs: uncompressed (implicit
//! and explicit VR, little and big endian), deflated, RLE Lossless and the JPEG family that
//! `jpeg-decoder` reads (baseline, extended, lossless). JPEG 2000 and JPEG-LS need C libraries
//! and are refused with the transfer syntax's name.
//!
//! DICOM's patient space is LPS+; the grid-to-world matrix is converted to RAS+ like every
//! volume's.

use std::fs;
use std::path::{Path, PathBuf};

use dicom_dictionary_std::tags;
use dicom_object::Tag;
use dicom_object::{DefaultDicomObject, OpenFileOptions};
use dicom_pixeldata::{DecodedPixelData, PixelDecoder, PixelRepresentation};
use dicom_transfer_syntax_registry::{TransferSyntaxIndex, TransferSyntaxRegistry};
use glam::{DVec3, Mat4};

use super::{LoadErrorKind, SampleSink, Samples, Scaling, VolumeInfo, affine, check_claim, check_dims, lps_to_ras};

/// Relative tolerance of slice spacing: gaps that differ from the series' spacing by more than
/// this fraction are missing slices or unequal spacing.
const SPACING_TOLERANCE: f64 = 0.01;

/// Reads the series in the folder `dir` into `sink`, slice by slice.
pub(super) fn load(
    dir: &Path,
    progress: &mut dyn FnMut(u64, u64),
    sink: &mut dyn SampleSink,
) -> Result<VolumeInfo, LoadErrorKind> {
    let files = list_files(dir)?;
    let headers = files.iter().map(|file| SliceHeader::read(file)).collect::<Result<Vec<_>, _>>()?;
    one_series(&headers)?;
    let geometry = Geometry::of(&headers)?;
    let slices = geometry.ordered(&headers)?;
    let dims = check_dims("the series", [u64::from(geometry.columns), u64::from(geometry.rows), slices.len() as u64])?;
    let per_slice = geometry.columns as usize * geometry.rows as usize;
    // Before anything is allocated for the grid: every file must be able to hold its pixels (a
    // byte each at least, compressed or not).
    for slice in &slices {
        check_claim(per_slice as u64, slice.bytes, true).map_err(|e| file_error(&slice.file, e.to_string()))?;
    }
    let total: u64 = slices.iter().map(|s| s.bytes).sum();
    // One rescale for the whole series keeps the stored samples (2 bytes a voxel for CT);
    // slices rescaled differently are converted to data units one by one.
    let uniform = slices.iter().all(|s| s.rescale == slices[0].rescale);
    let [slope, intercept] = if uniform { slices[0].rescale.map(|v| v as f32) } else { [1.0, 0.0] };
    let info =
        VolumeInfo { dims, grid_to_world: geometry.grid_to_world(&slices), scaling: Scaling { slope, intercept } };
    sink.begin(&info)?;
    sink.reserve(per_slice * slices.len())?;
    let mut series_type = None;
    let mut done = 0;
    for slice in &slices {
        let object = dicom_object::open_file(&slice.file)
            .map_err(|e| file_error(&slice.file, format!("not a readable DICOM file: {}", chain(&e))))?;
        let decoded = decode(&object, &slice.file)?;
        let stored = if uniform { StoredType::of(&decoded, &slice.file)? } else { StoredType::F32 };
        if *series_type.get_or_insert(stored) != stored {
            return Err(file_error(
                &slice.file,
                "its sample type (Bits Allocated, Bits Stored, Pixel Representation) differs from the other slices'"
                    .into(),
            ));
        }
        let samples = stored.decode(&decoded).map_err(|message| file_error(&slice.file, message))?;
        if samples.len() != per_slice {
            return Err(file_error(
                &slice.file,
                format!(
                    "the pixel data holds {} values, expected {} x {}",
                    samples.len(),
                    geometry.columns,
                    geometry.rows
                ),
            ));
        }
        sink.samples(&samples)?;
        done += slice.bytes;
        progress(done, total);
    }
    progress(total, total);
    Ok(info)
}

/// How a slice's samples are kept: as stored (a uniform rescale), or in data units.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum StoredType {
    U8,
    I8,
    U16 {
        bits: u16,
    },
    I16 {
        bits: u16,
    },
    U32,
    I32,
    /// Rescaled to data units as `f32` (slices of one series with different rescales).
    F32,
}

impl StoredType {
    /// The stored type of a decoded slice from Bits Allocated, Bits Stored and Pixel
    /// Representation.
    fn of(decoded: &DecodedPixelData, file: &Path) -> Result<StoredType, LoadErrorKind> {
        let signed = decoded.pixel_representation() == PixelRepresentation::Signed;
        let bits = decoded.bits_stored();
        Ok(match (decoded.bits_allocated(), signed) {
            (8, false) => StoredType::U8,
            (8, true) => StoredType::I8,
            (16, false) => StoredType::U16 { bits },
            (16, true) => StoredType::I16 { bits },
            (32, false) => StoredType::U32,
            (32, true) => StoredType::I32,
            (other, _) => {
                return Err(file_error(file, format!("{other} bits allocated per sample; 8, 16 or 32 are supported")));
            }
        })
    }

    /// The slice's samples in this type.
    fn decode(self, decoded: &DecodedPixelData) -> Result<Samples, String> {
        let data = decoded.frame_data(0).map_err(|e| chain(&e))?;
        let words = || data.as_chunks::<2>().0.iter().map(|&b| u16::from_le_bytes(b));
        let dwords = || data.as_chunks::<4>().0.iter().map(|&b| u32::from_le_bytes(b));
        Ok(match self {
            StoredType::U8 => Samples::U8(data.to_vec()),
            StoredType::I8 => Samples::I8(data.iter().map(|&b| b as i8).collect()),
            StoredType::U16 { bits } => {
                let mask = if bits >= 16 { u16::MAX } else { (1u16 << bits) - 1 };
                Samples::U16(words().map(|w| w & mask).collect())
            }
            StoredType::I16 { bits } => {
                // Sign-extend from Bits Stored: shift the sign bit to the top and back.
                let shift = 16 - bits.clamp(1, 16);
                Samples::I16(words().map(|w| ((w as i16) << shift) >> shift).collect())
            }
            StoredType::U32 => Samples::U32(dwords().collect()),
            StoredType::I32 => Samples::I32(dwords().map(|d| d as i32).collect()),
            StoredType::F32 => Samples::F32(decoded.to_vec_frame::<f32>(0).map_err(|e| chain(&e))?),
        })
    }
}

/// The files of the folder that may be DICOM: every regular file except hidden ones and the
/// media directory (`DICOMDIR`), sorted by name so errors are deterministic.
fn list_files(dir: &Path) -> Result<Vec<PathBuf>, LoadErrorKind> {
    let io = |error| LoadErrorKind::Io { file: None, error };
    let mut files = Vec::new();
    for entry in fs::read_dir(dir).map_err(io)? {
        let entry = entry.map_err(io)?;
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if name.starts_with('.') || name.eq_ignore_ascii_case("DICOMDIR") || !entry.path().is_file() {
            continue;
        }
        files.push(entry.path());
    }
    files.sort();
    if files.is_empty() {
        return Err(LoadErrorKind::Dicom { file: None, message: "the folder holds no DICOM files".into() });
    }
    Ok(files)
}

/// An error about one file of the series.
fn file_error(file: &Path, message: String) -> LoadErrorKind {
    LoadErrorKind::Dicom { file: Some(file.to_path_buf()), message }
}

/// An error of the DICOM crates with its causes, for a message.
fn chain(error: &dyn std::error::Error) -> String {
    let mut message = error.to_string();
    let mut source = error.source();
    while let Some(cause) = source {
        let text = cause.to_string();
        if !message.contains(&text) {
            message = format!("{message}: {text}");
        }
        source = cause.source();
    }
    message
}

/// What the header of one slice says about where it is and how it is stored.
#[derive(Clone, Debug)]
struct SliceHeader {
    file: PathBuf,
    /// Size of the file, for progress.
    bytes: u64,
    series: String,
    rows: u32,
    columns: u32,
    /// Image Orientation (Patient): the row direction (along a row, increasing column index),
    /// then the column direction (down a column), LPS.
    orientation: [DVec3; 2],
    /// Image Position (Patient): the centre of the first voxel, LPS mm.
    position: DVec3,
    /// Pixel Spacing: between rows, then between columns (mm).
    pixel_spacing: [f64; 2],
    /// Slice Thickness or Spacing Between Slices, for a series of one slice.
    thickness: Option<f64>,
    /// Rescale Slope and Intercept (1 and 0 when absent).
    rescale: [f64; 2],
}

impl SliceHeader {
    /// Reads the header of `file` up to (not including) its pixel data.
    fn read(file: &Path) -> Result<SliceHeader, LoadErrorKind> {
        let object = OpenFileOptions::new()
            .read_until(tags::PIXEL_DATA)
            .open_file(file)
            .map_err(|e| file_error(file, format!("not a readable DICOM file: {}", chain(&e))))?;
        let header = Header { object: &object, file };
        let frames = header.optional_int(tags::NUMBER_OF_FRAMES, "Number of Frames")?.unwrap_or(1);
        if frames != 1 {
            return Err(file_error(
                file,
                format!("a multi-frame image ({frames} frames); only series of one image per file are supported"),
            ));
        }
        let samples = header.optional_int(tags::SAMPLES_PER_PIXEL, "Samples per Pixel")?.unwrap_or(1);
        if samples != 1 {
            return Err(file_error(file, format!("{samples} samples per pixel; only grey-scale images are supported")));
        }
        let orientation = header.floats(tags::IMAGE_ORIENTATION_PATIENT, "Image Orientation (Patient)", 6)?;
        let row = DVec3::new(orientation[0], orientation[1], orientation[2]);
        let column = DVec3::new(orientation[3], orientation[4], orientation[5]);
        if row.length() < 0.5 || column.length() < 0.5 || row.cross(column).length() < 0.5 {
            return Err(file_error(file, "`Image Orientation (Patient)` is not two perpendicular unit vectors".into()));
        }
        let position = header.floats(tags::IMAGE_POSITION_PATIENT, "Image Position (Patient)", 3)?;
        let spacing = header.floats(tags::PIXEL_SPACING, "Pixel Spacing", 2)?;
        if spacing.iter().any(|&s| s <= 0.0) {
            return Err(file_error(file, format!("`Pixel Spacing` {spacing:?} is not two positive sizes")));
        }
        let thickness = header
            .optional_float(tags::SPACING_BETWEEN_SLICES)
            .or_else(|| header.optional_float(tags::SLICE_THICKNESS))
            .filter(|&t| t > 0.0);
        Ok(SliceHeader {
            file: file.to_path_buf(),
            bytes: fs::metadata(file).map(|m| m.len()).unwrap_or(0),
            series: header.string(tags::SERIES_INSTANCE_UID, "Series Instance UID")?,
            rows: header.int(tags::ROWS, "Rows")?,
            columns: header.int(tags::COLUMNS, "Columns")?,
            orientation: [row.normalize(), column.normalize()],
            position: DVec3::new(position[0], position[1], position[2]),
            pixel_spacing: [spacing[0], spacing[1]],
            thickness,
            rescale: [
                header.optional_float(tags::RESCALE_SLOPE).filter(|&s| s != 0.0).unwrap_or(1.0),
                header.optional_float(tags::RESCALE_INTERCEPT).unwrap_or(0.0),
            ],
        })
    }
}

/// Typed access to the attributes of one file's header, with errors naming the file and the
/// attribute.
struct Header<'a> {
    object: &'a DefaultDicomObject,
    file: &'a Path,
}

impl Header<'_> {
    fn element(&self, tag: Tag) -> Option<&dicom_object::mem::InMemElement> {
        self.object.element_opt(tag).ok().flatten()
    }

    fn missing(&self, name: &str) -> LoadErrorKind {
        file_error(self.file, format!("missing attribute `{name}`"))
    }

    fn bad(&self, name: &str, why: impl std::fmt::Display) -> LoadErrorKind {
        file_error(self.file, format!("attribute `{name}`: {why}"))
    }

    fn string(&self, tag: Tag, name: &str) -> Result<String, LoadErrorKind> {
        let element = self.element(tag).ok_or_else(|| self.missing(name))?;
        let text = element.to_str().map_err(|e| self.bad(name, e))?;
        Ok(text.trim_end_matches(['\0', ' ']).to_string())
    }

    fn int(&self, tag: Tag, name: &str) -> Result<u32, LoadErrorKind> {
        self.optional_int(tag, name)?.ok_or_else(|| self.missing(name))
    }

    fn optional_int(&self, tag: Tag, name: &str) -> Result<Option<u32>, LoadErrorKind> {
        self.element(tag).map(|e| e.to_int::<u32>().map_err(|e| self.bad(name, e))).transpose()
    }

    fn floats(&self, tag: Tag, name: &str, count: usize) -> Result<Vec<f64>, LoadErrorKind> {
        let element = self.element(tag).ok_or_else(|| self.missing(name))?;
        let values = element.to_multi_float64().map_err(|e| self.bad(name, e))?;
        if values.len() != count || values.iter().any(|v| !v.is_finite()) {
            return Err(self.bad(name, format!("expected {count} finite numbers, found {values:?}")));
        }
        Ok(values)
    }

    fn optional_float(&self, tag: Tag) -> Option<f64> {
        self.element(tag).and_then(|e| e.to_float64().ok()).filter(|v| v.is_finite())
    }
}

/// Refuses a folder whose files belong to more than one series, naming one file of each.
fn one_series(headers: &[SliceHeader]) -> Result<(), LoadErrorKind> {
    let mut series: Vec<(&str, &Path, usize)> = Vec::new();
    for h in headers {
        match series.iter_mut().find(|(uid, _, _)| *uid == h.series) {
            Some(entry) => entry.2 += 1,
            None => series.push((&h.series, &h.file, 1)),
        }
    }
    if series.len() == 1 {
        return Ok(());
    }
    let list: Vec<String> =
        series.iter().map(|(uid, file, count)| format!("`{uid}` ({count} files, e.g. `{}`)", file.display())).collect();
    Err(LoadErrorKind::Dicom {
        file: None,
        message: format!(
            "the folder holds {} series: {}; put each series in a folder of its own",
            series.len(),
            list.join(", ")
        ),
    })
}

/// The in-plane geometry every slice of the series must share.
struct Geometry {
    rows: u32,
    columns: u32,
    orientation: [DVec3; 2],
    pixel_spacing: [f64; 2],
}

impl Geometry {
    /// The first slice's geometry, after checking that every other slice agrees.
    fn of(headers: &[SliceHeader]) -> Result<Geometry, LoadErrorKind> {
        let first = &headers[0];
        for h in &headers[1..] {
            let differs =
                |what: &str| file_error(&h.file, format!("its {what} differs from that of `{}`", first.file.display()));
            if (h.rows, h.columns) != (first.rows, first.columns) {
                return Err(differs("image size"));
            }
            let same_axes = h.orientation.iter().zip(&first.orientation).all(|(a, b)| a.abs_diff_eq(*b, 1e-4));
            if !same_axes {
                return Err(differs("`Image Orientation (Patient)`"));
            }
            let same_spacing = h.pixel_spacing.iter().zip(&first.pixel_spacing).all(|(a, b)| (a - b).abs() < 1e-4);
            if !same_spacing {
                return Err(differs("`Pixel Spacing`"));
            }
        }
        Ok(Geometry {
            rows: first.rows,
            columns: first.columns,
            orientation: first.orientation,
            pixel_spacing: first.pixel_spacing,
        })
    }

    /// The slice normal: row direction x column direction.
    fn normal(&self) -> DVec3 {
        self.orientation[0].cross(self.orientation[1]).normalize()
    }

    /// The slices ordered by position along the normal, after checking that they are evenly
    /// spaced: a gap of about a whole number of spacings is reported as missing slices, any
    /// other difference as unequal spacing, two slices at one position as duplicates.
    fn ordered<'h>(&self, headers: &'h [SliceHeader]) -> Result<Vec<&'h SliceHeader>, LoadErrorKind> {
        let normal = self.normal();
        let mut slices: Vec<(f64, &SliceHeader)> = headers.iter().map(|h| (h.position.dot(normal), h)).collect();
        slices.sort_by(|a, b| a.0.total_cmp(&b.0));
        let gaps: Vec<f64> = slices.windows(2).map(|w| w[1].0 - w[0].0).collect();
        if let Some(spacing) = median(&gaps) {
            for (pair, &gap) in slices.windows(2).zip(&gaps) {
                let (a, b) = (pair[0].1, pair[1].1);
                let names = format!("`{}` and `{}`", a.file.display(), b.file.display());
                if gap < 1e-3 {
                    return Err(LoadErrorKind::Dicom {
                        file: None,
                        message: format!(
                            "{names} are at the same position ({:.3} mm along the slice normal)",
                            pair[0].0
                        ),
                    });
                }
                if (gap - spacing).abs() <= SPACING_TOLERANCE * spacing {
                    continue;
                }
                let ratio = gap / spacing;
                let message = if ratio > 1.5 && (ratio - ratio.round()).abs() <= SPACING_TOLERANCE * ratio {
                    format!(
                        "{} slice(s) missing between {names}: they are {gap:.3} mm apart, the other slices {spacing:.3} mm",
                        ratio.round() as u64 - 1
                    )
                } else {
                    format!("unequal slice spacing: {names} are {gap:.3} mm apart, the other slices {spacing:.3} mm")
                };
                return Err(LoadErrorKind::Dicom { file: None, message });
            }
        }
        Ok(slices.into_iter().map(|(_, h)| h).collect())
    }

    /// Voxel (column, row, slice) to RAS+ world: the row direction times the column spacing,
    /// the column direction times the row spacing, and the step from the first slice's position
    /// to the last's per slice (so a tilted gantry's shear is kept); one slice steps along the
    /// normal by its thickness.
    fn grid_to_world(&self, slices: &[&SliceHeader]) -> Mat4 {
        let first = slices[0];
        let last = slices[slices.len() - 1];
        let step = if slices.len() > 1 {
            (last.position - first.position) / (slices.len() - 1) as f64
        } else {
            self.normal() * first.thickness.unwrap_or(1.0)
        };
        let axes = [self.orientation[0] * self.pixel_spacing[1], self.orientation[1] * self.pixel_spacing[0], step];
        lps_to_ras(affine(axes.map(|a| a.as_vec3()), first.position.as_vec3()))
    }
}

/// The median of `values`; `None` when there are none.
fn median(values: &[f64]) -> Option<f64> {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted.get(sorted.len() / 2).copied()
}

/// Decodes the pixel data of one slice (native or encapsulated), naming the transfer syntax when
/// it cannot.
fn decode<'o>(object: &'o DefaultDicomObject, file: &Path) -> Result<DecodedPixelData<'o>, LoadErrorKind> {
    let syntax = object.meta().transfer_syntax().trim_end_matches('\0').to_string();
    object.decode_pixel_data().map_err(|e| {
        let name = TransferSyntaxRegistry
            .get(&syntax)
            .map_or_else(|| syntax.clone(), |ts| format!("{} ({syntax})", ts.name()));
        file_error(file, format!("cannot decode the pixel data of transfer syntax {name}: {}", chain(&e)))
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use dicom_core::value::{PixelFragmentSequence, PrimitiveValue, Value};
    use dicom_core::{DataElement, VR};
    use dicom_dictionary_std::uids;
    use dicom_object::{FileMetaTableBuilder, InMemDicomObject};
    use glam::{Vec3, Vec4};

    use super::super::tests::{assert_mat_eq, load_quiet};
    use super::*;

    /// How a test slice is stored.
    #[derive(Clone, Copy, PartialEq)]
    pub(crate) enum Storage {
        /// 16-bit signed, explicit VR little endian.
        Uncompressed,
        /// 16-bit signed, RLE Lossless (encoded by [`rle`]).
        Rle,
        /// 8-bit unsigned, JPEG baseline (lossy), transcoded by `dicom-pixeldata`.
        JpegBaseline,
    }

    /// One slice file of a test series.
    #[derive(Clone)]
    pub(crate) struct TestSlice {
        pub(crate) series: &'static str,
        pub(crate) columns: u16,
        pub(crate) rows: u16,
        pub(crate) orientation: [f64; 6],
        pub(crate) position: [f64; 3],
        pub(crate) pixel_spacing: [f64; 2],
        pub(crate) rescale: [f64; 2],
        pub(crate) instance: u32,
        /// Stored values (before rescale), `columns * rows`, row by row.
        pub(crate) values: Vec<i16>,
        pub(crate) storage: Storage,
    }

    fn text(s: String) -> PrimitiveValue {
        PrimitiveValue::from(s)
    }

    fn numbers(values: &[f64]) -> PrimitiveValue {
        text(values.iter().map(f64::to_string).collect::<Vec<_>>().join("\\"))
    }

    impl TestSlice {
        /// Writes the slice as `dir/name`.
        pub(crate) fn write(&self, dir: &Path, name: &str) {
            let eight_bit = self.storage == Storage::JpegBaseline;
            let (bits, signed) = if eight_bit { (8u16, 0u16) } else { (16, 1) };
            let instance_uid = format!("1.2.826.0.1.3680043.2.1125.{}.{}", self.series.len(), self.instance);
            let element = |tag, vr, value: PrimitiveValue| DataElement::new(tag, vr, value);
            let mut object = InMemDicomObject::from_element_iter([
                element(tags::SOP_CLASS_UID, VR::UI, uids::CT_IMAGE_STORAGE.into()),
                element(tags::SOP_INSTANCE_UID, VR::UI, text(instance_uid.clone())),
                element(tags::MODALITY, VR::CS, "CT".into()),
                element(tags::SERIES_INSTANCE_UID, VR::UI, self.series.into()),
                element(tags::INSTANCE_NUMBER, VR::IS, text(self.instance.to_string())),
                element(tags::IMAGE_POSITION_PATIENT, VR::DS, numbers(&self.position)),
                element(tags::IMAGE_ORIENTATION_PATIENT, VR::DS, numbers(&self.orientation)),
                element(tags::PIXEL_SPACING, VR::DS, numbers(&self.pixel_spacing)),
                element(tags::SLICE_THICKNESS, VR::DS, "2".into()),
                element(tags::RESCALE_INTERCEPT, VR::DS, numbers(&self.rescale[1..])),
                element(tags::RESCALE_SLOPE, VR::DS, numbers(&self.rescale[..1])),
                element(tags::SAMPLES_PER_PIXEL, VR::US, PrimitiveValue::from(1u16)),
                element(tags::PHOTOMETRIC_INTERPRETATION, VR::CS, "MONOCHROME2".into()),
                element(tags::ROWS, VR::US, PrimitiveValue::from(self.rows)),
                element(tags::COLUMNS, VR::US, PrimitiveValue::from(self.columns)),
                element(tags::BITS_ALLOCATED, VR::US, PrimitiveValue::from(bits)),
                element(tags::BITS_STORED, VR::US, PrimitiveValue::from(bits)),
                element(tags::HIGH_BIT, VR::US, PrimitiveValue::from(bits - 1)),
                element(tags::PIXEL_REPRESENTATION, VR::US, PrimitiveValue::from(signed)),
            ]);
            let syntax = match self.storage {
                Storage::Rle => {
                    let fragments = PixelFragmentSequence::new_fragments(vec![rle(&self.values)]);
                    object.put(DataElement::new(tags::PIXEL_DATA, VR::OB, Value::from(fragments)));
                    uids::RLE_LOSSLESS
                }
                Storage::Uncompressed => {
                    let words: Vec<u16> = self.values.iter().map(|&v| v as u16).collect();
                    object.put(element(tags::PIXEL_DATA, VR::OW, PrimitiveValue::U16(words.into())));
                    uids::EXPLICIT_VR_LITTLE_ENDIAN
                }
                Storage::JpegBaseline => {
                    let bytes: Vec<u8> = self.values.iter().map(|&v| v.clamp(0, 255) as u8).collect();
                    object.put(element(tags::PIXEL_DATA, VR::OB, PrimitiveValue::U8(bytes.into())));
                    uids::EXPLICIT_VR_LITTLE_ENDIAN
                }
            };
            let meta = FileMetaTableBuilder::new()
                .transfer_syntax(syntax)
                .media_storage_sop_class_uid(uids::CT_IMAGE_STORAGE)
                .media_storage_sop_instance_uid(instance_uid);
            let mut file = object.with_meta(meta).unwrap();
            if self.storage == Storage::JpegBaseline {
                use dicom_pixeldata::Transcode;
                file.transcode(&dicom_transfer_syntax_registry::entries::JPEG_BASELINE.erased()).unwrap();
            }
            file.write_to_file(dir.join(name)).unwrap();
        }
    }

    /// RLE Lossless pixel data of one 16-bit frame: two segments (high bytes, then low bytes),
    /// each PackBits-coded with replicate runs for repeated bytes and literal runs otherwise.
    pub(crate) fn rle(values: &[i16]) -> Vec<u8> {
        let high: Vec<u8> = values.iter().map(|v| v.to_be_bytes()[0]).collect();
        let low: Vec<u8> = values.iter().map(|v| v.to_be_bytes()[1]).collect();
        let segments = [packbits(&high), packbits(&low)];
        let mut header = [0u32; 16];
        header[0] = 2;
        header[1] = 64;
        header[2] = 64 + segments[0].len() as u32;
        let mut out: Vec<u8> = header.iter().flat_map(|h| h.to_le_bytes()).collect();
        out.extend(segments.concat());
        out
    }

    fn packbits(bytes: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut i = 0;
        while i < bytes.len() {
            let run = bytes[i..].iter().take(128).take_while(|&&b| b == bytes[i]).count();
            if run >= 3 {
                out.extend([(257 - run) as u8, bytes[i]]);
                i += run;
            } else {
                let mut end = i;
                while end < bytes.len() && end - i < 128 && !bytes[end..].starts_with(&[bytes[end]; 3]) {
                    end += 1;
                }
                let end = end.max(i + 1);
                out.push((end - i - 1) as u8);
                out.extend(&bytes[i..end]);
                i = end;
            }
        }
        if out.len() % 2 == 1 {
            out.push(0x80); // a no-op, pads the segment to an even length
        }
        out
    }

    /// Stored values of slice `k` of the test series: distinct per voxel, negative ones, some
    /// repeats (so RLE has runs).
    fn values(k: usize, columns: u16, rows: u16) -> Vec<i16> {
        let n = usize::from(columns) * usize::from(rows);
        (0..n).map(|i| if i % 5 == 4 { 7 } else { (100 * k + i) as i16 - 300 }).collect()
    }

    /// An axial series of `n` slices 2.5 mm apart starting at z = 10 (LPS), 4 x 3 pixels.
    pub(crate) fn axial(n: usize, storage: Storage) -> Vec<TestSlice> {
        (0..n)
            .map(|k| TestSlice {
                series: "1.2.3.4",
                columns: 4,
                rows: 3,
                orientation: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
                position: [-20.0, -30.0, 10.0 + 2.5 * k as f64],
                pixel_spacing: [0.5, 0.75],
                rescale: [2.0, -1024.0],
                instance: (7 * k as u32 + 3) % 11,
                values: values(k, 4, 3),
                storage,
            })
            .collect()
    }

    /// Writes `slices` under shuffled names: neither name order nor instance numbers follow
    /// the position order.
    pub(crate) fn write_shuffled(dir: &Path, slices: &[TestSlice]) {
        for (k, slice) in slices.iter().enumerate() {
            let scrambled = (k * 3 + 2) % slices.len().max(1) + 10 * (k % 2);
            slice.write(dir, &format!("IM{scrambled:04}_{k}"));
        }
    }

    /// The transfer syntax every file in `dir` is stored with (so a test knows which codec it
    /// exercised).
    fn syntaxes(dir: &Path) -> Vec<String> {
        let mut found: Vec<String> = list_files(dir)
            .unwrap()
            .iter()
            .map(|f| dicom_object::open_file(f).unwrap().meta().transfer_syntax().trim_end_matches('\0').to_string())
            .collect();
        found.dedup();
        found
    }

    fn expected_values(slices: &[TestSlice]) -> Vec<f32> {
        slices
            .iter()
            .flat_map(|s| s.values.iter().map(|&v| (f64::from(v) * s.rescale[0] + s.rescale[1]) as f32))
            .collect()
    }

    #[test]
    fn shuffled_uncompressed_series_in_position_order_with_rescale() {
        let dir = tempfile::tempdir().unwrap();
        let slices = axial(5, Storage::Uncompressed);
        write_shuffled(dir.path(), &slices);
        std::fs::write(dir.path().join(".DS_Store"), b"junk").unwrap();
        let mut calls = Vec::new();
        let v = super::super::load(dir.path(), &mut |d, t| calls.push((d, t))).unwrap();
        assert_eq!(v.dims, [4, 3, 5]);
        assert_eq!(v.values(), expected_values(&slices));
        assert_eq!(v.spacing, [0.75, 0.5, 2.5]);
        // LPS axes (0.75, 0, 0), (0, 0.5, 0), (0, 0, 2.5), origin (-20, -30, 10); RAS negates x, y.
        assert_mat_eq(
            v.grid_to_world,
            Mat4::from_cols(
                Vec4::new(-0.75, 0.0, 0.0, 0.0),
                Vec4::new(0.0, -0.5, 0.0, 0.0),
                Vec4::new(0.0, 0.0, 2.5, 0.0),
                Vec4::new(20.0, 30.0, 10.0, 1.0),
            ),
        );
        assert!(calls.len() >= 5 && calls.last().is_some_and(|&(d, t)| d == t && t > 0));
    }

    #[test]
    fn one_rescale_keeps_the_stored_samples_and_several_convert_to_data_units() {
        let dir = tempfile::tempdir().unwrap();
        let slices = axial(3, Storage::Uncompressed);
        write_shuffled(dir.path(), &slices);
        let v = load_quiet(dir.path()).unwrap();
        assert!(matches!(v.samples, Samples::I16(_)), "{v:?}");
        assert_eq!(v.scaling, Scaling { slope: 2.0, intercept: -1024.0 });

        let dir = tempfile::tempdir().unwrap();
        let mut slices = axial(3, Storage::Uncompressed);
        slices[1].rescale = [1.0, -1000.0];
        write_shuffled(dir.path(), &slices);
        let v = load_quiet(dir.path()).unwrap();
        assert!(matches!(v.samples, Samples::F32(_)), "{v:?}");
        assert_eq!(v.scaling, Scaling::IDENTITY);
        assert_eq!(v.values(), expected_values(&slices));
    }

    #[test]
    fn rle_series_matches_uncompressed() {
        let dir = tempfile::tempdir().unwrap();
        let slices = axial(3, Storage::Rle);
        write_shuffled(dir.path(), &slices);
        assert_eq!(syntaxes(dir.path()), [uids::RLE_LOSSLESS]);
        let v = load_quiet(dir.path()).unwrap();
        assert_eq!(v.values(), expected_values(&slices));
    }

    #[test]
    fn jpeg_baseline_series_decodes_within_the_codec_loss() {
        let dir = tempfile::tempdir().unwrap();
        let mut slices = axial(3, Storage::JpegBaseline);
        for (k, s) in slices.iter_mut().enumerate() {
            s.values = (0..12).map(|i| (40 + 15 * i + 5 * k) as i16).collect();
        }
        write_shuffled(dir.path(), &slices);
        assert_eq!(syntaxes(dir.path()), [uids::JPEG_BASELINE8_BIT]);
        let v = load_quiet(dir.path()).unwrap();
        let expected = expected_values(&slices);
        // Stored values within a few grey levels (rescale slope 2).
        let worst = v.values().iter().zip(&expected).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
        assert!(worst <= 2.0 * 8.0, "worst difference {worst}: {:?} vs {expected:?}", v.values());
    }

    #[test]
    fn sagittal_series_is_placed_in_patient_space() {
        let dir = tempfile::tempdir().unwrap();
        // Rows along anterior -> posterior (+y LPS), columns downwards (-z); the normal
        // row x column is -x LPS (towards the patient's right), so slices go right-wards.
        let slices: Vec<TestSlice> = (0..3)
            .map(|k| TestSlice {
                orientation: [0.0, 1.0, 0.0, 0.0, 0.0, -1.0],
                position: [5.0 - 3.0 * k as f64, -10.0, 40.0],
                ..axial(3, Storage::Uncompressed).swap_remove(k)
            })
            .collect();
        write_shuffled(dir.path(), &slices);
        let v = load_quiet(dir.path()).unwrap();
        assert_eq!(v.values(), expected_values(&slices));
        // LPS: i -> (0, 0.75, 0), j -> (0, 0, -0.5), k -> (-3, 0, 0); RAS negates x, y.
        assert_mat_eq(
            v.grid_to_world,
            Mat4::from_cols(
                Vec4::new(0.0, -0.75, 0.0, 0.0),
                Vec4::new(0.0, 0.0, -0.5, 0.0),
                Vec4::new(3.0, 0.0, 0.0, 0.0),
                Vec4::new(-5.0, 10.0, 40.0, 1.0),
            ),
        );
        let p = v.grid_to_world.transform_point3(Vec3::new(0.0, 0.0, 2.0));
        assert!((p - Vec3::new(1.0, 10.0, 40.0)).length() < 1e-4, "{p}");
    }

    /// The error message of loading the series in `dir`.
    fn error(dir: &Path) -> String {
        let e = load_quiet(dir).unwrap_err();
        assert!(!e.is_io(), "{e}");
        e.kind.to_string()
    }

    #[test]
    fn several_series_are_refused_naming_a_file_of_each() {
        let dir = tempfile::tempdir().unwrap();
        let mut slices = axial(4, Storage::Uncompressed);
        slices[3].series = "1.2.3.5";
        write_shuffled(dir.path(), &slices);
        let message = error(dir.path());
        assert!(message.starts_with("the folder holds 2 series: `1.2.3.4` (3 files, e.g. `"), "{message}");
        assert!(message.contains("`1.2.3.5` (1 files, e.g. `") && message.contains("IM"), "{message}");
    }

    #[test]
    fn missing_and_unevenly_spaced_slices_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let mut slices = axial(5, Storage::Uncompressed);
        slices.remove(2);
        write_shuffled(dir.path(), &slices);
        let message = error(dir.path());
        assert!(message.starts_with("1 slice(s) missing between `"), "{message}");
        assert!(message.contains("5.000 mm apart, the other slices 2.500 mm"), "{message}");

        let dir = tempfile::tempdir().unwrap();
        let mut slices = axial(5, Storage::Uncompressed);
        slices[4].position[2] += 0.7;
        write_shuffled(dir.path(), &slices);
        assert!(error(dir.path()).starts_with("unequal slice spacing: `"));

        let dir = tempfile::tempdir().unwrap();
        let mut slices = axial(3, Storage::Uncompressed);
        slices[2].position = slices[1].position;
        write_shuffled(dir.path(), &slices);
        assert!(error(dir.path()).contains("are at the same position"));
    }

    #[test]
    fn bad_files_are_named() {
        let dir = tempfile::tempdir().unwrap();
        write_shuffled(dir.path(), &axial(2, Storage::Uncompressed));
        std::fs::write(dir.path().join("notes.txt"), b"not an image").unwrap();
        let message = error(dir.path());
        assert!(
            message.starts_with(&format!("`{}`: not a readable DICOM file", dir.path().join("notes.txt").display()))
        );

        let dir = tempfile::tempdir().unwrap();
        let mut slices = axial(3, Storage::Uncompressed);
        slices[1].pixel_spacing = [0.5, 0.8];
        slices[1].write(dir.path(), "b");
        slices[0].write(dir.path(), "a");
        slices[2].write(dir.path(), "c");
        let message = error(dir.path());
        assert!(message.starts_with(&format!("`{}`: its `Pixel Spacing` differs", dir.path().join("b").display())));

        let empty = tempfile::tempdir().unwrap();
        assert_eq!(error(empty.path()), "the folder holds no DICOM files");
    }

    #[test]
    fn packbits_round_trips_runs_and_literals() {
        let bytes: Vec<u8> = [vec![1, 2, 3], vec![9; 200], vec![4, 4, 5]].concat();
        let coded = packbits(&bytes);
        let mut decoded = Vec::new();
        let mut i = 0;
        while i < coded.len() {
            let n = coded[i] as i8;
            if n >= 0 {
                decoded.extend(&coded[i + 1..i + 2 + n as usize]);
                i += 2 + n as usize;
            } else if n != -128 {
                decoded.extend(std::iter::repeat_n(coded[i + 1], (1 - i32::from(n)) as usize));
                i += 2;
            } else {
                i += 1;
            }
        }
        assert_eq!(decoded, bytes);
    }
}
