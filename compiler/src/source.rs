//! Source files and spans.
//!
//! Public face: [`Span`], [`SourceMap`] (the files of one compilation, which turns a span back
//! into a file, a line and a column: [`Position`]), [`SourceFile`] and [`FileId`].
//!
//! Every file gets a disjoint range of one global byte-offset space, so a [`Span`] is two `u32`
//! offsets and needs no file id. That is exactly the shape of `naga::Span`, which lets lowering
//! carry VRS spans straight into naga's span table and map validation errors back to VRS files.

use crate::stdlib;
use std::borrow::Cow;
use std::ops::Range;
use std::path::PathBuf;

/// A byte range in the global offset space of a [`SourceMap`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Span {
    /// Global offset of the first byte covered.
    pub start: u32,
    /// Global offset just past the last byte covered (`start` for an empty span).
    pub end: u32,
}

impl Span {
    /// The empty span at offset 0, which no file holds: for what has no place in the source.
    pub const DUMMY: Span = Span { start: 0, end: 0 };

    /// The span `start..end` (global offsets).
    pub fn new(start: u32, end: u32) -> Span {
        Span { start, end }
    }

    /// The smallest span covering both.
    pub fn to(self, other: Span) -> Span {
        Span::new(self.start.min(other.start), self.end.max(other.end))
    }

    /// Whether this is [`Span::DUMMY`], a span that points nowhere.
    pub fn is_dummy(self) -> bool {
        self == Span::DUMMY
    }
}

impl From<Range<usize>> for Span {
    fn from(r: Range<usize>) -> Span {
        Span::new(r.start as u32, r.end as u32)
    }
}

impl From<Span> for naga::Span {
    fn from(s: Span) -> naga::Span {
        naga::Span::new(s.start, s.end)
    }
}

/// Index of a file in a [`SourceMap`].
pub type FileId = usize;

/// One source file: its display name, where it came from and its text.
#[derive(Debug)]
pub struct SourceFile {
    /// The name diagnostics print (a path as the user gave it, or `std::name`).
    pub name: String,
    /// The canonical path on disk, for files read from disk (imports resolve relative to it).
    pub path: Option<PathBuf>,
    /// Borrowed for the embedded standard modules, owned for everything read or generated.
    pub text: Cow<'static, str>,
    /// Global offset of the file's first byte.
    pub base: u32,
    line_starts: Cow<'static, [u32]>,
}

impl SourceFile {
    /// 0-based line and 0-based byte column of a local offset.
    fn line_col(&self, local: u32) -> (usize, usize) {
        let line = match self.line_starts.binary_search(&local) {
            Ok(l) => l,
            Err(l) => l - 1,
        };
        (line, (local - self.line_starts[line]) as usize)
    }
}

/// All files of one compilation. Files are only ever added, so spans stay valid.
///
/// Every map starts with the standard modules at the same offsets (file ids `0..` in
/// [`stdlib::names`] order), so their parsed trees can be shared by every compilation of a
/// process (see `loader::parsed_std`).
#[derive(Debug, Default)]
pub struct SourceMap {
    files: Vec<SourceFile>,
    next_base: u32,
}

/// A resolved position: 1-based line, 1-based column in characters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Position {
    /// The line, from 1.
    pub line: usize,
    /// The column, from 1, counted in characters (not bytes).
    pub column: usize,
}

impl SourceMap {
    /// An empty map.
    pub fn new() -> SourceMap {
        // Offset 0 is reserved so that `Span::DUMMY` never points into a real file.
        let mut map = SourceMap { files: Vec::new(), next_base: 1 };
        for ((name, text), lines) in stdlib::modules().zip(std_line_starts()) {
            map.push(format!("std::{name}"), None, Cow::Borrowed(text), Cow::Borrowed(lines));
        }
        map
    }

    /// Adds a file (at the next free offsets) and returns its id.
    pub fn add(&mut self, name: impl Into<String>, path: Option<PathBuf>, text: String) -> FileId {
        let lines = line_starts(&text);
        self.push(name.into(), path, Cow::Owned(text), Cow::Owned(lines))
    }

    fn push(
        &mut self,
        name: String,
        path: Option<PathBuf>,
        text: Cow<'static, str>,
        line_starts: Cow<'static, [u32]>,
    ) -> FileId {
        let base = self.next_base;
        // One spare byte after each file, so an end-of-file span still maps to this file.
        self.next_base = base.saturating_add(text.len() as u32 + 1);
        self.files.push(SourceFile { name, path, text, base, line_starts });
        self.files.len() - 1
    }

    /// The file of standard module `name` (`shading` for `std::shading`).
    pub(crate) fn std_file(&self, name: &str) -> Option<FileId> {
        stdlib::index(name)
    }

    /// The file `id`.
    pub fn file(&self, id: FileId) -> &SourceFile {
        &self.files[id]
    }

    /// Every file with its id, in the order added.
    pub fn files(&self) -> impl Iterator<Item = (FileId, &SourceFile)> {
        self.files.iter().enumerate()
    }

    /// The file that holds a global offset.
    pub(crate) fn file_of(&self, offset: u32) -> Option<FileId> {
        let idx = self.files.partition_point(|f| f.base <= offset);
        let id = idx.checked_sub(1)?;
        let f = &self.files[id];
        (offset <= f.base + f.text.len() as u32).then_some(id)
    }

    /// The file of a span and the span's range local to that file.
    pub fn locate(&self, span: Span) -> Option<(FileId, Range<usize>)> {
        let id = self.file_of(span.start)?;
        let f = &self.files[id];
        let len = f.text.len() as u32;
        let start = (span.start - f.base).min(len);
        let end = span.end.saturating_sub(f.base).clamp(start, len);
        Some((id, start as usize..end as usize))
    }

    /// Line and column (both 1-based; columns count characters) of a global offset.
    pub fn position(&self, offset: u32) -> Option<(FileId, Position)> {
        let id = self.file_of(offset)?;
        let f = &self.files[id];
        let local = (offset - f.base).min(f.text.len() as u32);
        let (line, byte_col) = f.line_col(local);
        let line_start = f.line_starts[line] as usize;
        let mut end = line_start + byte_col;
        while !f.text.is_char_boundary(end) {
            end -= 1;
        }
        let column = f.text[line_start..end].chars().count() + 1;
        Some((id, Position { line: line + 1, column }))
    }

    /// The text a span covers.
    pub fn snippet(&self, span: Span) -> &str {
        match self.locate(span) {
            Some((id, r)) => self.files[id].text.get(r).unwrap_or(""),
            None => "",
        }
    }
}

fn line_starts(text: &str) -> Vec<u32> {
    std::iter::once(0).chain(text.match_indices('\n').map(|(i, _)| i as u32 + 1)).collect()
}

/// Line starts of the standard modules, computed once per process.
fn std_line_starts() -> &'static [Vec<u32>] {
    static LINES: std::sync::OnceLock<Vec<Vec<u32>>> = std::sync::OnceLock::new();
    LINES.get_or_init(|| stdlib::modules().map(|(_, text)| line_starts(text)).collect())
}

impl<'a> codespan_reporting::files::Files<'a> for SourceMap {
    type FileId = FileId;
    type Name = &'a str;
    type Source = &'a str;

    fn name(&'a self, id: FileId) -> Result<&'a str, codespan_reporting::files::Error> {
        self.files.get(id).map(|f| f.name.as_str()).ok_or(codespan_reporting::files::Error::FileMissing)
    }

    fn source(&'a self, id: FileId) -> Result<&'a str, codespan_reporting::files::Error> {
        self.files.get(id).map(|f| &*f.text).ok_or(codespan_reporting::files::Error::FileMissing)
    }

    fn line_index(&'a self, id: FileId, byte_index: usize) -> Result<usize, codespan_reporting::files::Error> {
        let f = self.files.get(id).ok_or(codespan_reporting::files::Error::FileMissing)?;
        Ok(f.line_col(byte_index.min(f.text.len()) as u32).0)
    }

    fn line_range(&'a self, id: FileId, line_index: usize) -> Result<Range<usize>, codespan_reporting::files::Error> {
        let f = self.files.get(id).ok_or(codespan_reporting::files::Error::FileMissing)?;
        let start = *f
            .line_starts
            .get(line_index)
            .ok_or(codespan_reporting::files::Error::LineTooLarge { given: line_index, max: f.line_starts.len() - 1 })?
            as usize;
        let end = f.line_starts.get(line_index + 1).map_or(f.text.len(), |&e| e as usize);
        Ok(start..end)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spans_map_back_to_files_lines_and_columns() {
        let mut map = SourceMap::new();
        let a = map.add("a.vrs", None, "ab\ncd".into());
        let b = map.add("b.vrs", None, "é\nxyz".into());
        let fb = map.file(b).base;
        assert_eq!(map.file_of(map.file(a).base + 4), Some(a));
        assert_eq!(map.position(fb + 5).unwrap(), (b, Position { line: 2, column: 3 }));
        assert_eq!(map.position(fb + 2).unwrap(), (b, Position { line: 1, column: 2 }));
        assert_eq!(map.snippet(Span::new(fb + 3, fb + 6)), "xyz");
        assert_eq!(map.file_of(0), None);
    }
}
