//! The data side of the formats with a text header (NRRD, MetaImage): the samples follow the
//! header in the same file (attached) or sit in a file the header names (detached), raw or
//! compressed, after some bytes to skip.
//!
//! How the header places the data ([`Placement`]) and reading the samples it places
//! ([`read_data`]), once for both formats, so they keep the same limits and error messages;
//! [`super::text_header`] finds and sizes the data stream from a header.

use std::io::{BufRead, Read};
use std::path::Path;

use flate2::bufread::{GzDecoder, ZlibDecoder};

use super::{DataSource, Layout, LoadErrorKind, SampleSink, read_samples, skip_bytes};

/// How the data is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Encoding {
    Raw,
    /// gzip (NRRD `encoding: gzip`).
    Gzip,
    /// zlib (MetaImage `CompressedData = True`).
    Zlib,
}

/// Where the samples are in the data stream and how they are stored, as the header says.
#[derive(Clone, Copy, Debug)]
pub(super) struct Placement {
    pub(super) layout: Layout,
    pub(super) encoding: Encoding,
    /// Bytes of the stream, as stored, before the data; `None` when the data is at the end of
    /// the stream (-1 in both formats), which only raw data allows since it needs the data's
    /// stored size.
    pub(super) skip: Option<u64>,
    /// Bytes of the decompressed stream before the samples (NRRD's `byte skip` for gzip data);
    /// ignored for raw data.
    pub(super) decoded_skip: u64,
}

/// Reads the samples `data` places in a stream holding `len` more bytes, checking that exactly
/// the header's number of bytes is there. `past_end` is the format's error for a skip that goes
/// beyond the data, given the skip.
pub(super) fn read_data(
    reader: &mut dyn BufRead,
    data: Placement,
    len: u64,
    file: Option<&Path>,
    past_end: &dyn Fn(u64) -> LoadErrorKind,
    sink: &mut dyn SampleSink,
) -> Result<(), LoadErrorKind> {
    let raw_source = DataSource { file, compressed: false, available: None };
    let expected = data.layout.bytes();
    let skip = match data.skip {
        Some(skip) => skip,
        None => len.checked_sub(expected).ok_or_else(|| raw_source.mismatch(expected, len))?,
    };
    if skip_bytes(reader, skip).map_err(|e| raw_source.read_error(e))? < skip {
        return Err(past_end(skip));
    }
    match data.encoding {
        Encoding::Raw => {
            let source = DataSource { available: Some(len - skip), ..raw_source };
            read_samples(reader, data.layout, &source, sink)
        }
        Encoding::Gzip => read_decoded(&mut GzDecoder::new(reader), data, file, past_end, sink),
        Encoding::Zlib => read_decoded(&mut ZlibDecoder::new(reader), data, file, past_end, sink),
    }
}

/// Skips `data.decoded_skip` bytes of a decompressing stream, then reads the samples. The
/// decompressed length is unknown until it is read, so [`read_samples`] grows the output with
/// the data actually there rather than with what the header claims.
fn read_decoded(
    decoder: &mut dyn Read,
    data: Placement,
    file: Option<&Path>,
    past_end: &dyn Fn(u64) -> LoadErrorKind,
    sink: &mut dyn SampleSink,
) -> Result<(), LoadErrorKind> {
    let source = DataSource { file, compressed: true, available: None };
    let skip = data.decoded_skip;
    if skip_bytes(decoder, skip).map_err(|e| source.read_error(e))? < skip {
        return Err(past_end(skip));
    }
    read_samples(decoder, data.layout, &source, sink)
}

#[cfg(test)]
mod tests {
    use super::super::tests::{gzip, zlib};
    use super::super::{ScalarType, VolumeInfo};
    use super::*;

    fn placement(encoding: Encoding, skip: Option<u64>, decoded_skip: u64) -> Placement {
        Placement { layout: Layout { ty: ScalarType::U8, big_endian: false, voxels: 3 }, encoding, skip, decoded_skip }
    }

    fn read(bytes: &[u8], data: Placement) -> Result<Vec<f32>, String> {
        let past_end = |skip| LoadErrorKind::Header(format!("skip {skip} is past the end"));
        let mut sink = super::super::Collect::default();
        let info = VolumeInfo {
            dims: [3, 1, 1],
            grid_to_world: glam::Mat4::IDENTITY,
            scaling: super::super::Scaling::IDENTITY,
        };
        sink.begin(&info).map_err(|e| e.to_string())?;
        read_data(&mut &bytes[..], data, bytes.len() as u64, None, &past_end, &mut sink).map_err(|e| e.to_string())?;
        Ok(sink.samples.map(|s| s.to_f32()).unwrap_or_default())
    }

    #[test]
    fn skips_stored_and_decoded_bytes() {
        assert_eq!(read(b"xx\x01\x02\x03", placement(Encoding::Raw, Some(2), 0)), Ok(vec![1.0, 2.0, 3.0]));
        // No skip: the data is at the end, however long what comes before it.
        assert_eq!(read(b"xxxx\x01\x02\x03", placement(Encoding::Raw, None, 0)), Ok(vec![1.0, 2.0, 3.0]));
        assert_eq!(
            read(b"\x01\x02", placement(Encoding::Raw, None, 0)).unwrap_err(),
            "header says 3 bytes of data, file has 2"
        );
        // The stored skip comes before the compressed stream, the decoded one inside it.
        let mut stored = b"z".to_vec();
        stored.extend(gzip(b"yy\x04\x05\x06"));
        assert_eq!(read(&stored, placement(Encoding::Gzip, Some(1), 2)), Ok(vec![4.0, 5.0, 6.0]));
        assert_eq!(read(&zlib(b"\x07\x08\x09"), placement(Encoding::Zlib, Some(0), 0)), Ok(vec![7.0, 8.0, 9.0]));
    }

    #[test]
    fn skips_past_the_end_are_the_formats_errors() {
        assert_eq!(read(b"\x01\x02\x03", placement(Encoding::Raw, Some(9), 0)).unwrap_err(), "skip 9 is past the end");
        assert_eq!(
            read(&gzip(b"\x01\x02\x03"), placement(Encoding::Gzip, Some(0), 5)).unwrap_err(),
            "skip 5 is past the end"
        );
    }
}
