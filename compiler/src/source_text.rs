//! Reading the text of a source file (a VRS module or a scene). Both are UTF-8; a file that is
//! not is a diagnostic (E0108) at its first invalid byte, like any other mistake in it, not an
//! I/O error: the file exists and was read, its content is wrong.
//!
//! Public face: none outside the crate; the loader and the scene reader use [`SourceText`].

use crate::diag::{Code, Diagnostic};
use crate::source::{SourceMap, Span};
use std::path::Path;

/// A file's bytes as text.
#[derive(Debug)]
pub(crate) enum SourceText {
    /// Valid UTF-8.
    Utf8(String),
    /// Not UTF-8: the text with every invalid sequence replaced by U+FFFD (so it can be shown),
    /// and the offset of the first invalid byte, which is the same in both (everything before it
    /// is unchanged).
    NotUtf8 {
        /// The text with U+FFFD in place of each invalid sequence.
        shown: String,
        /// Offset of the first invalid byte.
        first_bad: usize,
        /// That byte.
        byte: u8,
    },
}

impl SourceText {
    /// Reads `path`; only a file that cannot be opened or read is an `Err`.
    pub(crate) fn read(path: &Path) -> std::io::Result<SourceText> {
        std::fs::read(path).map(SourceText::from_bytes)
    }

    /// Takes the bytes as UTF-8 if they are, else as the lossy text and its first invalid byte.
    pub(crate) fn from_bytes(bytes: Vec<u8>) -> SourceText {
        match String::from_utf8(bytes) {
            Ok(text) => SourceText::Utf8(text),
            Err(e) => {
                let first_bad = e.utf8_error().valid_up_to();
                let byte = e.as_bytes()[first_bad];
                SourceText::NotUtf8 { shown: String::from_utf8_lossy(e.as_bytes()).into_owned(), first_bad, byte }
            }
        }
    }

    /// The text to add to a [`SourceMap`].
    pub(crate) fn text(self) -> String {
        match self {
            SourceText::Utf8(text) | SourceText::NotUtf8 { shown: text, .. } => text,
        }
    }

    /// Adds the text to `sources` as file `name`; for a file that is not UTF-8, also the E0108
    /// diagnostic at its first invalid byte.
    pub(crate) fn add_to(
        self,
        sources: &mut SourceMap,
        name: String,
        path: Option<std::path::PathBuf>,
    ) -> (usize, Option<Diagnostic>) {
        let problem = match &self {
            SourceText::Utf8(_) => None,
            SourceText::NotUtf8 { first_bad, byte, .. } => Some((*first_bad, *byte)),
        };
        let file = sources.add(name, path, self.text());
        let diag = problem.map(|(first_bad, byte)| {
            let start = sources.file(file).base + first_bad as u32;
            // The shown text holds U+FFFD (3 bytes) there: the span covers that whole character.
            not_utf8(Span::new(start, start + '\u{FFFD}'.len_utf8() as u32), first_bad, byte)
        });
        (file, diag)
    }
}

fn not_utf8(span: Span, offset: usize, byte: u8) -> Diagnostic {
    Diagnostic::new(
        Code::NotUtf8,
        span,
        format!("the file is not UTF-8: byte 0x{byte:02X} at offset {offset} is invalid"),
    )
    .with_label("the first byte that is not UTF-8")
    .with_note("VRS modules and scene files are UTF-8 text")
    .with_help("save the file as UTF-8 (an editor's \"save with encoding\"), or remove the byte")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_bad_byte_is_found_and_shown() {
        let text = SourceText::from_bytes(b"lib fn f() {}\n// caf\xE9 \xFF\n".to_vec());
        let SourceText::NotUtf8 { first_bad, byte, .. } = &text else { panic!("{text:?}") };
        assert_eq!((*first_bad, *byte), (20, 0xE9));
        let mut sources = SourceMap::new();
        let (file, diag) = text.add_to(&mut sources, "m.vrs".into(), None);
        let diag = diag.expect("a diagnostic");
        assert_eq!(diag.code, Code::NotUtf8);
        assert_eq!(sources.snippet(diag.span), "\u{FFFD}");
        let (at, position) = sources.position(diag.span.start).expect("in the file");
        assert_eq!((at, position.line, position.column), (file, 2, 7));
    }

    #[test]
    fn utf8_gives_no_diagnostic() {
        let mut sources = SourceMap::new();
        let (_, diag) = SourceText::from_bytes("// ü\n".as_bytes().to_vec()).add_to(&mut sources, "m.vrs".into(), None);
        assert!(diag.is_none());
    }
}
