//! The formats with a text header (NRRD, MetaImage): reading the header's `key <separator>
//! value` lines ([`read_fields`], the format's syntax given as a [`Syntax`]); once a format has
//! validated the fields ([`TextHeader`]), finding and sizing the data after the header or in the
//! file it names, and reading it ([`load`]) or locating it for a mapping ([`locate`]), the same
//! for both formats.

use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::path::Path;

use glam::Mat4;

use super::raw::{self, Encoding, Placement};
use super::{
    DataSource, Layout, LoadErrorKind, MAX_HEADER_LINES, ProgressReader, RawData, SampleSink, Scaling, VolumeInfo,
    check_claim, open, read_header_line, sibling,
};

/// How a format writes its header lines. Both formats skip `#` comment lines.
pub(super) struct Syntax {
    /// The first line's prefix (NRRD's `NRRD000`); `None` when the fields start at once.
    pub(super) magic: Option<&'static str>,
    /// Between a field's key and its value (`=`, `: `); a line ending in it without its
    /// trailing spaces is a field with an empty value.
    pub(super) separator: &'static str,
    /// Marks a line as a key/value pair of metadata, skipped (NRRD's `:=`), unless the
    /// separator comes first.
    pub(super) metadata: Option<&'static str>,
    /// The key a field is stored under.
    pub(super) key: fn(&str) -> String,
    /// Whether an empty line ends the header (NRRD's attached data follows one); otherwise
    /// blank lines are skipped.
    pub(super) blank_ends: bool,
    /// The field (stored key, name for the error) that must come last (MetaImage's
    /// `ElementDataFile`): the header ends after it, and without it is an error. `None`: the
    /// header ends at the end of the file (or a blank line).
    pub(super) last: Option<(&'static str, &'static str)>,
    /// How a field line looks, for the error about one that is not (`Key = Value`).
    pub(super) shape: &'static str,
    /// The error for a file that is not of the format: an unreadable first line, a wrong magic,
    /// or, without a magic, no field before a line that is not one.
    pub(super) not_format: &'static str,
}

/// Reads a header written in `syntax`: the magic line, then the fields up to the header's end.
/// Returns the fields by stored key and the header's length in bytes.
pub(super) fn read_fields(
    reader: &mut dyn BufRead,
    syntax: &Syntax,
) -> Result<(HashMap<String, String>, u64), LoadErrorKind> {
    let not_format = || LoadErrorKind::Header(syntax.not_format.into());
    let mut fields = HashMap::new();
    let mut consumed = 0;
    let mut first_field_line = 1;
    if let Some(magic) = syntax.magic {
        let first = read_header_line(reader).map_err(|e| match e {
            LoadErrorKind::Header(_) => not_format(),
            other => other,
        })?;
        let (line, n) = first.ok_or_else(not_format)?;
        if !line.starts_with(magic) {
            return Err(not_format());
        }
        consumed += n;
        first_field_line = 2;
    }
    for line_number in first_field_line.. {
        if line_number > MAX_HEADER_LINES {
            return Err(LoadErrorKind::Header(format!("the header has more than {MAX_HEADER_LINES} lines")));
        }
        let line = read_header_line(reader).map_err(|e| match e {
            LoadErrorKind::Header(_) if line_number == 1 => not_format(),
            other => other,
        })?;
        let Some((line, n)) = line else {
            return match syntax.last {
                None => Ok((fields, consumed)),
                Some(_) if fields.is_empty() => Err(not_format()),
                Some((_, name)) => Err(LoadErrorKind::Header(format!("missing field `{name}`"))),
            };
        };
        consumed += n;
        if syntax.blank_ends && line.is_empty() {
            break;
        }
        if line.starts_with('#') || (!syntax.blank_ends && line.trim().is_empty()) {
            continue;
        }
        let bare = syntax.separator.trim_end();
        let field = line
            .find(syntax.separator)
            .map(|i| (i, syntax.separator.len()))
            .or_else(|| line.strip_suffix(bare).map(|s| (s.len(), bare.len())));
        let pair = syntax.metadata.and_then(|m| line.find(m));
        match (field, pair) {
            (Some((i, sep)), pair) if pair.is_none_or(|p| i < p) => {
                let key = (syntax.key)(&line[..i]);
                let last = syntax.last.is_some_and(|(last, _)| key == last);
                fields.insert(key, line[i + sep..].trim().to_string());
                if last {
                    break;
                }
            }
            (_, Some(_)) => {} // a key/value pair: metadata only
            _ if syntax.magic.is_none() && fields.is_empty() => return Err(not_format()),
            _ => {
                return Err(LoadErrorKind::Header(format!(
                    "header line {line_number} is not {}: `{line}`",
                    syntax.shape
                )));
            }
        }
    }
    Ok((fields, consumed))
}

/// The validated header fields the data and its placement depend on, as far as
/// [`load`] needs them to find and read the data.
#[derive(Debug)]
pub(super) struct TextHeader {
    /// Voxels per axis (x, y, z).
    pub(super) dims: [u32; 3],
    /// Voxel index -> world position (mm, RAS+).
    pub(super) grid_to_world: Mat4,
    /// The data file a detached header names; `None` when the data follows the header.
    pub(super) data_file: Option<String>,
    /// Where the samples are in the data stream and how they are stored.
    pub(super) data: Placement,
    /// Lines of the data stream before the byte skip (NRRD's `line skip`; 0 in MetaImage).
    pub(super) line_skip: u64,
    /// The format's error for a skip of the given bytes that goes past the end of the data.
    pub(super) past_end: fn(u64) -> LoadErrorKind,
}

impl TextHeader {
    /// The data file a detached header names; `None` when the data follows the header.
    pub(super) fn data_file(&self) -> Option<&str> {
        self.data_file.as_deref()
    }

    /// The volume's shape and placement (the formats' samples are not scaled).
    pub(super) fn info(&self) -> VolumeInfo {
        VolumeInfo { dims: self.dims, grid_to_world: self.grid_to_world, scaling: Scaling::IDENTITY }
    }

    /// Reads the samples from a stream positioned at the start of the data: right after the
    /// header (attached) or at the start of the data file (detached, then named by `file` for
    /// error messages), holding `len` more bytes. Skips `line skip` lines, then the byte skip.
    pub(super) fn read_data(
        &self,
        reader: &mut dyn BufRead,
        len: u64,
        file: Option<&Path>,
        sink: &mut dyn SampleSink,
    ) -> Result<(), LoadErrorKind> {
        let consumed = self.skip_lines(reader, file)?;
        raw::read_data(reader, self.data, len.saturating_sub(consumed), file, &self.past_end, sink)
    }

    /// Skips the `line skip` lines that come before the byte skip in the data stream and
    /// returns the bytes skipped.
    pub(super) fn skip_lines(&self, reader: &mut dyn BufRead, file: Option<&Path>) -> Result<u64, LoadErrorKind> {
        let raw_source = DataSource { file, compressed: false, available: None };
        let mut consumed = 0;
        for _ in 0..self.line_skip {
            let n = reader.skip_until(b'\n').map_err(|e| raw_source.read_error(e))? as u64;
            if n == 0 {
                return Err(LoadErrorKind::Header(format!(
                    "`line skip` {} is more lines than the data has",
                    self.line_skip
                )));
            }
            consumed += n;
        }
        Ok(consumed)
    }
}

/// Loads a file with a text header: `read_header` parses the header from the start of the file
/// and returns it with its length in bytes; then the data is read from the rest of the file or
/// from the data file the header names into `sink`. Returns the volume's shape.
///
/// Progress is about the file holding the data (so a small detached header reports nothing of
/// its own) and ends with one report of `done == total`.
pub(super) fn load(
    path: &Path,
    progress: &mut dyn FnMut(u64, u64),
    read_header: impl FnOnce(&mut dyn BufRead) -> Result<(TextHeader, u64), LoadErrorKind>,
    sink: &mut dyn SampleSink,
) -> Result<VolumeInfo, LoadErrorKind> {
    let (file, len) = open(path, false)?;
    let mut reader = BufReader::new(ProgressReader::new(file, len, &mut *progress));
    let (header, header_len) = read_header(&mut reader)?;
    let total = match header.data_file() {
        None => {
            let data_len = len.saturating_sub(header_len);
            check_placement(&header, data_len)?;
            sink.begin(&header.info())?;
            header.read_data(&mut reader, data_len, None, sink)?;
            len
        }
        Some(name) => {
            drop(reader);
            let data_path = sibling(path, name);
            let (file, data_len) = open(&data_path, true)?;
            check_placement(&header, data_len)?;
            sink.begin(&header.info())?;
            let mut reader = BufReader::new(ProgressReader::new(file, data_len, &mut *progress));
            header.read_data(&mut reader, data_len, Some(&data_path), sink)?;
            data_len
        }
    };
    progress(total, total);
    Ok(header.info())
}

/// Where the samples of a file with a text header lie (see [`super::raw_layout`]), reading only
/// the header (and the lines a NRRD `line skip` passes over); `None` for compressed data. The
/// data section must hold exactly the header's samples, as [`load`] requires.
pub(super) fn locate(
    path: &Path,
    read_header: impl FnOnce(&mut dyn BufRead) -> Result<(TextHeader, u64), LoadErrorKind>,
) -> Result<Option<RawData>, LoadErrorKind> {
    let (file, len) = open(path, false)?;
    let mut reader = BufReader::new(file);
    let (header, header_len) = read_header(&mut reader)?;
    let data = header.data;
    if data.encoding != Encoding::Raw {
        return Ok(None);
    }
    // The data stream: the rest of this file, or the whole data file.
    let (data_path, start, len, lines) = match header.data_file() {
        None => {
            check_placement(&header, len.saturating_sub(header_len))?;
            let lines = header.skip_lines(&mut reader, None)?;
            (path.to_path_buf(), header_len, len, lines)
        }
        Some(name) => {
            let data_path = sibling(path, name);
            let (file, len) = open(&data_path, true)?;
            check_placement(&header, len)?;
            let lines = header.skip_lines(&mut BufReader::new(file), Some(&data_path))?;
            (data_path, 0, len, lines)
        }
    };
    let offset = start + lines;
    let available = len.saturating_sub(offset);
    let expected = data.layout.bytes();
    let mismatch = |found| LoadErrorKind::SizeMismatch { expected, found, compressed: false };
    let skip = match data.skip {
        Some(skip) => skip,
        None => available.checked_sub(expected).ok_or_else(|| mismatch(available))?,
    };
    let stored = available.checked_sub(skip).ok_or_else(|| (header.past_end)(skip))?;
    if stored != expected {
        return Err(mismatch(stored));
    }
    let Layout { ty, big_endian, .. } = data.layout;
    Ok(Some(RawData { file: data_path, offset: offset + skip, sample: ty, big_endian, info: header.info() }))
}

/// Refuses a header whose samples cannot fit in the `len` bytes of its data stream (see
/// [`check_claim`]), or whose skip goes past them, before the sink is told the grid.
fn check_placement(header: &TextHeader, len: u64) -> Result<(), LoadErrorKind> {
    let data = header.data;
    let skip = data.skip.unwrap_or(0);
    let stored = len.checked_sub(skip).ok_or_else(|| (header.past_end)(skip))?;
    check_claim(data.layout.bytes(), stored, data.encoding != Encoding::Raw)
}

#[cfg(test)]
mod tests {
    use super::*;

    const KEY_EQUALS_VALUE: Syntax = Syntax {
        magic: None,
        separator: "=",
        metadata: None,
        key: |key| key.trim().to_ascii_lowercase(),
        blank_ends: false,
        last: Some(("end", "End")),
        shape: "`Key = Value`",
        not_format: "not key = value",
    };

    const FIELD_COLON_VALUE: Syntax = Syntax {
        magic: Some("MAGIC"),
        separator: ": ",
        metadata: Some(":="),
        key: |key| key.replace(' ', "").to_ascii_lowercase(),
        blank_ends: true,
        last: None,
        shape: "`field: value`",
        not_format: "not magic",
    };

    fn fields(text: &str, syntax: &Syntax) -> Result<(Vec<(String, String)>, u64), String> {
        let (fields, len) = read_fields(&mut text.as_bytes(), syntax).map_err(|e| e.to_string())?;
        let mut fields: Vec<_> = fields.into_iter().collect();
        fields.sort();
        Ok((fields, len))
    }

    fn pairs(list: &[(&str, &str)]) -> Vec<(String, String)> {
        list.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect()
    }

    #[test]
    fn a_last_field_ends_the_header_and_blank_lines_are_skipped() {
        let text = "# c\n\n A Key = 1 = 2 \nEnd = x\nafter";
        assert_eq!(fields(text, &KEY_EQUALS_VALUE), Ok((pairs(&[("a key", "1 = 2"), ("end", "x")]), 29)));
        assert_eq!(fields("A = 1\n", &KEY_EQUALS_VALUE).unwrap_err(), "missing field `End`");
        assert_eq!(fields("", &KEY_EQUALS_VALUE).unwrap_err(), "not key = value");
        assert_eq!(fields("# c\nno separator\n", &KEY_EQUALS_VALUE).unwrap_err(), "not key = value");
        assert_eq!(
            fields("A = 1\nno separator\n", &KEY_EQUALS_VALUE).unwrap_err(),
            "header line 2 is not `Key = Value`: `no separator`"
        );
    }

    #[test]
    fn a_magic_line_comes_first_and_a_blank_line_ends_the_header() {
        let text = "MAGIC0004\ndata file: a b\nempty:\nk:=v: w\n# c\n\ndata";
        assert_eq!(fields(text, &FIELD_COLON_VALUE), Ok((pairs(&[("datafile", "a b"), ("empty", "")]), 45)));
        assert_eq!(fields("MAGIC\na: 1", &FIELD_COLON_VALUE), Ok((pairs(&[("a", "1")]), 10)));
        assert_eq!(fields("other\n", &FIELD_COLON_VALUE).unwrap_err(), "not magic");
        assert_eq!(
            fields("MAGIC\nno separator\n", &FIELD_COLON_VALUE).unwrap_err(),
            "header line 2 is not `field: value`: `no separator`"
        );
    }
}
