//! Diagnostics: values with a stable code, a primary span, labels and notes.
//!
//! Every pass reports through a [`Diagnostics`] sink; nothing is printed until the driver
//! decides how (codespan-reporting for people, one JSON object per line for tools).
//!
//! The public face: [`Code`] (every stable code, with its severity and title), [`Severity`],
//! [`Diagnostic`] (built with [`Diagnostic::new`] and the `with_*` methods), the
//! [`Diagnostics`] sink, [`sort`] for the order diagnostics are shown in, and
//! [`JsonDiagnostic`], the shape of `--message-format json`.

use crate::source::{SourceMap, Span};
use codespan_reporting::diagnostic as cs;
use serde::Serialize;

macro_rules! codes {
    ($($variant:ident = $code:literal, $severity:ident, $title:literal;)*) => {
        /// Stable diagnostic codes. The catalogue in `docs/reference.md` lists each one.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum Code { $(#[doc = $title] $variant),* }

        impl Code {
            /// Every code, in catalogue order.
            pub const ALL: &'static [Code] = &[$(Code::$variant),*];

            /// The code as printed: `E0104`, `W0001`.
            pub fn as_str(self) -> &'static str {
                match self { $(Code::$variant => $code),* }
            }

            /// A one-line meaning.
            pub fn title(self) -> &'static str {
                match self { $(Code::$variant => $title),* }
            }

            /// The severity diagnostics with this code have.
            pub fn severity(self) -> Severity {
                match self { $(Code::$variant => Severity::$severity),* }
            }
        }
    };
}

codes! {
    // Lexical and syntax.
    InvalidCharacter = "E0101", Error, "a character that is not part of VRS";
    UnterminatedComment = "E0102", Error, "a block comment is never closed";
    InvalidLiteral = "E0103", Error, "a malformed or out-of-range number literal";
    Syntax = "E0104", Error, "the parser expected something else here";
    TooDeep = "E0105", Error, "brackets or expressions nested deeper than the compiler allows";
    DeclarationAfterStatement = "E0106", Error, "a declaration after the first statement of a pipeline function";
    UnknownAttribute = "E0107", Error, "an attribute other than `@ray`";
    NotUtf8 = "E0108", Error, "a source or scene file that is not UTF-8 text";
    // Modules and names.
    ImportNotFound = "E0201", Error, "an imported file cannot be read, or a standard module does not exist";
    ImportCycle = "E0202", Error, "modules import each other in a cycle";
    Duplicate = "E0203", Error, "a name is defined twice in one scope";
    UnknownName = "E0204", Error, "a name that is not a local, parameter, constant or declared uniform";
    UnknownFunction = "E0205", Error, "a call to a function that is neither built in nor defined";
    UnknownType = "E0206", Error, "a type name that VRS does not know";
    // Types.
    TypeMismatch = "E0301", Error, "a value of one type where another is required";
    InvalidOperands = "E0302", Error, "an operator applied to types it does not accept";
    ArgumentCount = "E0303", Error, "a call with the wrong number of arguments";
    NoOverload = "E0304", Error, "no overload of a built-in accepts these argument types";
    InvalidMember = "E0305", Error, "a swizzle or member that the type does not have";
    InvalidIndex = "E0306", Error, "indexing a value that cannot be indexed, or with a non-integer";
    ResourceMisuse = "E0307", Error, "a `volume` or `tf` where only plain values may go";
    NotAssignable = "E0308", Error, "an assignment to something that cannot change";
    LiteralOutOfRange = "E0309", Error, "a literal that does not fit the type its context gives it";
    ConditionNotBool = "E0310", Error, "a condition that is not `bool`";
    RangeNotInteger = "E0311", Error, "a `for` range whose bounds are not both i32 or both u32";
    InvalidConstructor = "E0312", Error, "a type constructor with arguments it does not accept";
    IndexOutOfBounds = "E0313", Error, "a constant index past the end of a vector or matrix";
    // Functions.
    MissingReturn = "E0401", Error, "a library function can end without returning a value";
    Recursion = "E0402", Error, "a library function calls itself, directly or through others";
    ReturnMismatch = "E0403", Error, "`return e;` in a pipeline function, or `return;` in a library function";
    BreakOutsideLoop = "E0404", Error, "`break` or `continue` outside a `for` loop";
    ImpureLibrary = "E0405", Error, "a library function reads state or uniforms";
    // Declarations of pipeline functions.
    UndeclaredState = "E0501", Error, "`state.F` without a `state F` declaration";
    UndeclaredUniform = "E0502", Error, "a pipeline function reads a name it has not declared as a uniform";
    UndeclaredLibrary = "E0503", Error, "a call to a library function missing from the `use` list";
    StateConflict = "E0504", Error, "declarations of one state field disagree on type or lifetime";
    DefaultConflict = "E0505", Error, "declarations of one field or uniform give different defaults";
    UniformConflict = "E0506", Error, "declarations of one uniform disagree on type";
    NotConstant = "E0507", Error, "a default, range or `const` that is not a constant expression";
    ConstEvalFailed = "E0508", Error, "constant evaluation overflows its type (or gives infinity or NaN)";
    UnknownLibrary = "E0509", Error, "`use` names a library function that is not in scope";
    DivisionByZero = "E0510", Error, "an integer division or remainder by a constant zero, or a constant division by zero";
    ShiftTooLarge = "E0511", Error, "a shift by a constant amount of 32 or more";
    MathDomain = "E0512", Error, "a built-in called with constant arguments outside its domain";
    // Placement.
    UnknownStep = "E0601", Error, "a step path that names no pipeline step";
    GroupNotAllowed = "E0602", Error, "a group name alone with `in`, `replace` or `remove`";
    // Composition.
    UnknownSubstep = "E0603", Error, "a placement on a substep that the step does not hold";
    DoubleReplace = "E0604", Error, "a second `replace` of a substep that an earlier `replace` already took";
    NoDefault = "E0605", Error, "a state field that no declaration in the composed pipeline gives a default";
    UninstantiatedTemplate = "E0606", Error, "a template module used without instances";
    InvalidInstance = "E0607", Error, "an instance name that is not an identifier, or is listed twice";
    UnboundResource = "E0608", Error, "a `volume`, `tf` or `image` uniform that the scene does not bind";
    LayerRule = "E0609", Error, "a layer that reads what no earlier layer of its view writes (`geometry_depth` without meshes)";
    BadLookup = "E0610", Error, "a bricked volume's own lookup (`lookup`) that does not parse, validate or have the lookup's interface";
    OtherPipeline = "E0611", Error, "a pipeline function placed in a step of the other pipeline: a filter step in a view's modules, a ray step in its filters";
    // Scenes.
    SceneSyntax = "E0701", Error, "a scene file that is not valid TOML";
    SceneInvalid = "E0702", Error, "a scene value the composed views reject: a uniform no view reads or of another type, more entries than the limits allow";
    SceneUnknownKey = "E0703", Error, "a key the scene format does not know";
    SceneMissingKey = "E0704", Error, "a key that its table or another key needs is missing";
    SceneNoTable = "E0705", Error, "a scene without a `[[view]]` or without a primary volume";
    SceneConflict = "E0706", Error, "two keys that exclude each other (`path` and `phantom`, `window` and `level`, ...)";
    SceneSecondPrimary = "E0707", Error, "a second volume with `role = \"primary\"`";
    SceneOutOfRange = "E0708", Error, "a number outside the range its key allows";
    SceneMemorySize = "E0709", Error, "a `memory` or `host_memory` that is not a size of at least 64 MiB";
    SceneEmpty = "E0710", Error, "an empty path, `tf`, `instances` or `channel` list";
    SceneBadName = "E0711", Error, "a name that is not a name of its kind (a uniform, phantom, view or standard module)";
    SceneTwice = "E0712", Error, "a view or mesh named twice, or listed twice";
    SceneNoSuch = "E0713", Error, "a name that names no volume, mesh or view of the scene";
    ScenePlaneNotSlice = "E0714", Error, "a raycast view in a view's `planes` list";
    SceneUnknownValue = "E0715", Error, "a value that is not one of its key's choices";
    SceneWrongType = "E0716", Error, "a value of the wrong type or shape for its key or uniform";
    SceneTfCount = "E0717", Error, "a list of transfer functions whose length is not the number of channels";
    SceneUrlScheme = "E0718", Error, "a remote store whose URL is not `http://` or `https://`";
    SceneInput = "E0719", Error, "a volume, transfer function, phantom, mesh or image of the scene that cannot be read or made";
    TreeFewChildren = "E0720", Error, "a group of a renderer tree without children, or an occlusion group with one";
    TreeCycle = "E0721", Error, "a group of a renderer tree that contains itself";
    TreePictureVolume = "E0722", Error, "a view's `picture` that lists its volume other than once, or a group, image or slice view after it";
    TreeFilterFirst = "E0723", Error, "a filter as the first child of a group: nothing before it to filter";
    TreeFilterGroupKind = "E0724", Error, "a filter among the children of an occlusion or shadow group";
    // Probes.
    ProbeUnknownField = "E0801", Error, "a probe of a state field that the view does not declare";
    ProbeUnshowable = "E0802", Error, "a probe of a field whose type an image cannot show (a matrix)";
    // Internal.
    Internal = "E0901", Error, "a compiler bug: the generated IR did not validate";
    // Outside the input (exit code 2).
    Io = "E0902", Error, "a file given on the command line cannot be read, or an output cannot be written";
    Device = "E0903", Error, "no GPU adapter, or no device could be opened on it";
    GpuRefused = "E0904", Error, "the GPU refused a resource, a pipeline or a submission (validation, out of memory)";
    // Warnings.
    UnusedUse = "W0001", Warning, "a `use` of a library function the body never calls";
    UnusedUniform = "W0002", Warning, "a uniform declared but never read";
    UnusedState = "W0003", Warning, "a state field declared but never used";
    UnreachableCode = "W0004", Warning, "statements after `return`, `break` or `continue`";
    // Composition warnings.
    ReadBeforeWrite = "W0005", Warning, "a field read before any active function writes it (it sees its default)";
    WrittenNeverRead = "W0006", Warning, "a field written that no active function reads";
    SceneIgnored = "W0701", Warning, "a scene key that has no effect where it is";
    SceneUniformRange = "W0702", Warning, "a scene value for a uniform outside the range the uniform declares";
}

/// Whether a diagnostic stops compilation (error) or not (warning, note).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// Stops compilation: nothing is emitted while any error stands.
    Error,
    /// Reported, but compilation goes on.
    Warning,
}

/// One diagnostic. Build with [`Diagnostic::new`] and the `with_*` methods.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    /// The stable code (`E0104`), whose catalogue entry in `docs/reference.md` explains it.
    pub code: Code,
    /// Error or warning: [`Code::severity`] of `code`, set by [`Diagnostic::new`].
    pub severity: Severity,
    /// The headline: what is wrong, in one sentence.
    pub message: String,
    /// The primary span, in the [`SourceMap`]'s global offset space.
    pub span: Span,
    /// Text under the primary span.
    pub label: String,
    /// Secondary spans with their labels (an earlier declaration, the instance, ...).
    pub secondary: Vec<(Span, String)>,
    /// Plain notes and help lines, shown after the snippet.
    pub notes: Vec<String>,
}

impl Diagnostic {
    /// A diagnostic with its code, primary span and message.
    pub fn new(code: Code, span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            code,
            severity: code.severity(),
            message: message.into(),
            span,
            label: String::new(),
            secondary: Vec::new(),
            notes: Vec::new(),
        }
    }

    /// The label at the primary span.
    pub fn with_label(mut self, label: impl Into<String>) -> Self {
        self.label = label.into();
        self
    }

    /// A secondary span with its label.
    pub fn with_secondary(mut self, span: Span, label: impl Into<String>) -> Self {
        self.secondary.push((span, label.into()));
        self
    }

    /// A note, shown after the labels.
    pub fn with_note(mut self, note: impl Into<String>) -> Self {
        self.notes.push(note.into());
        self
    }

    /// A `help:` note proposing a fix.
    pub fn with_help(mut self, help: impl Into<String>) -> Self {
        self.notes.push(format!("help: {}", help.into()));
        self
    }

    /// Whether its code is an error.
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }
}

/// Collects diagnostics from every pass.
#[derive(Debug, Default)]
pub struct Diagnostics {
    list: Vec<Diagnostic>,
}

impl Diagnostics {
    /// An empty sink.
    pub fn new() -> Diagnostics {
        Diagnostics::default()
    }

    /// Reports `d`.
    pub fn push(&mut self, d: Diagnostic) {
        self.list.push(d);
    }

    /// Shorthand for `push(Diagnostic::new(...))`, returning the diagnostic for chaining.
    pub fn report(&mut self, code: Code, span: Span, message: impl Into<String>) -> &mut Diagnostic {
        self.list.push(Diagnostic::new(code, span, message));
        self.list.last_mut().expect("just pushed")
    }

    /// Whether any error was reported.
    pub fn has_errors(&self) -> bool {
        self.list.iter().any(Diagnostic::is_error)
    }

    /// How many errors were reported.
    pub fn error_count(&self) -> usize {
        self.list.iter().filter(|d| d.is_error()).count()
    }

    /// The diagnostics in the order they were reported.
    pub fn iter(&self) -> impl Iterator<Item = &Diagnostic> {
        self.list.iter()
    }

    /// How many diagnostics were reported.
    pub fn len(&self) -> usize {
        self.list.len()
    }

    /// Whether nothing was reported.
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// Keeps only the diagnostics for which `keep` holds (follow-on errors are dropped this way).
    pub fn retain(&mut self, keep: impl FnMut(&Diagnostic) -> bool) {
        self.list.retain(keep);
    }

    /// Takes over every diagnostic of `other`, in order.
    pub fn extend(&mut self, other: Diagnostics) {
        self.list.extend(other.list);
    }

    /// Sorted by file position, then code, without duplicates, so output is stable whatever
    /// order the passes ran in.
    pub fn sorted(&self) -> Vec<Diagnostic> {
        let mut list = self.list.clone();
        sort(&mut list);
        list.dedup();
        list
    }
}

/// Sorts diagnostics the way they are shown: by file position, then code, then message (a stable
/// sort, so equal ones keep their order).
pub fn sort(list: &mut [Diagnostic]) {
    list.sort_by(|a, b| (a.span.start, a.code, &a.message).cmp(&(b.span.start, b.code, &b.message)));
}

/// One line of `--message-format json`: the shape "Diagnostics" in `docs/language.md` shows.
#[derive(Serialize)]
pub struct JsonDiagnostic<'a> {
    /// `"error"` or `"warning"`.
    pub severity: Severity,
    /// The code as printed (`E0104`).
    pub code: &'a str,
    /// The diagnostic's message.
    pub message: &'a str,
    /// The name of the file the primary span is in (empty when the span is in none).
    pub file: String,
    /// 1-based line of the primary span's start (0 when it is in no file).
    pub line: usize,
    /// 1-based column of the primary span's start.
    pub column: usize,
    /// 1-based line of the primary span's end.
    pub end_line: usize,
    /// 1-based column just past the primary span's end.
    pub end_column: usize,
    /// The primary label, then each secondary label as `FILE:LINE:COLUMN: label`, then the
    /// notes and help lines.
    pub notes: Vec<String>,
}

impl Diagnostic {
    /// The JSON object for `--message-format json` (1-based lines and columns).
    pub fn to_json(&self, sources: &SourceMap) -> JsonDiagnostic<'_> {
        let start = sources.position(self.span.start);
        let end = sources.position(self.span.end);
        let file = start.map(|(id, _)| sources.file(id).name.clone()).unwrap_or_default();
        let (line, column) = start.map_or((0, 0), |(_, p)| (p.line, p.column));
        let (end_line, end_column) = end.map_or((line, column), |(_, p)| (p.line, p.column));
        let mut notes = Vec::new();
        if !self.label.is_empty() {
            notes.push(self.label.clone());
        }
        for (span, label) in &self.secondary {
            match sources.position(span.start) {
                Some((id, p)) => notes.push(format!("{}:{}:{}: {}", sources.file(id).name, p.line, p.column, label)),
                None => notes.push(label.clone()),
            }
        }
        notes.extend(self.notes.iter().cloned());
        JsonDiagnostic {
            severity: self.severity,
            code: self.code.as_str(),
            message: &self.message,
            file,
            line,
            column,
            end_line,
            end_column,
            notes,
        }
    }

    /// The codespan-reporting form, for terminals and snapshots. A span on a line longer than
    /// [`MAX_SHOWN_LINE`] bytes is given as `file:line:column` in a note instead of a snippet:
    /// showing such a line (generated or minified text) helps no one, and codespan-reporting
    /// takes microseconds per character of it.
    pub fn to_codespan(&self, sources: &SourceMap) -> cs::Diagnostic<usize> {
        let base = match self.severity {
            Severity::Error => cs::Diagnostic::error(),
            Severity::Warning => cs::Diagnostic::warning(),
        };
        let spans = std::iter::once(self.span).chain(self.secondary.iter().map(|(span, _)| *span));
        if spans.into_iter().any(|span| on_long_line(sources, span)) {
            let mut notes = Vec::new();
            let mut at = |span: Span, label: &str| {
                if let Some((id, p)) = sources.position(span.start) {
                    let label = if label.is_empty() { String::new() } else { format!(": {label}") };
                    notes.push(format!("at {}:{}:{}{label}", sources.file(id).name, p.line, p.column));
                }
            };
            at(self.span, &self.label);
            self.secondary.iter().for_each(|(span, label)| at(*span, label));
            notes.push(format!("(the line is longer than {MAX_SHOWN_LINE} bytes, so it is not shown)"));
            notes.extend(self.notes.iter().cloned());
            return base.with_code(self.code.as_str()).with_message(&self.message).with_notes(notes);
        }
        let mut labels = Vec::new();
        if let Some((file, range)) = sources.locate(self.span) {
            labels.push(cs::Label::primary(file, range).with_message(&self.label));
        }
        for (span, label) in &self.secondary {
            if let Some((file, range)) = sources.locate(*span) {
                labels.push(cs::Label::secondary(file, range).with_message(label));
            }
        }
        base.with_code(self.code.as_str())
            .with_message(&self.message)
            .with_labels(labels)
            .with_notes(self.notes.clone())
    }
}

/// Lines longer than this many bytes are not shown in a diagnostic's snippet.
pub const MAX_SHOWN_LINE: usize = 1000;

/// Whether `span` starts on a line longer than [`MAX_SHOWN_LINE`]. Looks at most that many
/// bytes either side of the span's start, so a diagnostic costs the same on any line.
fn on_long_line(sources: &SourceMap, span: Span) -> bool {
    let Some((id, range)) = sources.locate(span) else { return false };
    let text = sources.file(id).text.as_bytes();
    let at = range.start.min(text.len());
    let before = text[at.saturating_sub(MAX_SHOWN_LINE + 1)..at].iter().rev().take_while(|&&b| b != b'\n').count();
    let after_end = (at + MAX_SHOWN_LINE + 1).min(text.len());
    let after = text[at..after_end].iter().take_while(|&&b| b != b'\n').count();
    before + after > MAX_SHOWN_LINE
}

/// Renders diagnostics as codespan-reporting text (no colour): for snapshots and non-terminals.
pub fn render_plain(diags: &[Diagnostic], sources: &SourceMap) -> String {
    let config = codespan_reporting::term::Config::default();
    let mut out = String::new();
    for d in diags {
        // Rendering into a String only fails on a span outside its file, which `locate` rules out.
        let _ = codespan_reporting::term::emit_to_string(&mut out, &config, sources, &d.to_codespan(sources));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A diagnostic on a 3 MB line: its text names the position and leaves the line out, so
    /// printing it costs nothing like the line's length.
    #[test]
    fn a_span_on_a_very_long_line_is_shown_by_position() {
        let mut sources = SourceMap::new();
        let text = format!("const a: f32 = y; /* {} */\nconst b: f32 = z;\n", "x".repeat(3 << 20));
        let file = sources.add("long.vrs", None, text.clone());
        let base = sources.file(file).base;
        let at = |needle: &str| base + text.find(needle).expect("in the text") as u32;
        let long = Diagnostic::new(Code::UnknownName, Span::new(at("y;"), at("y;") + 1), "unknown name `y`")
            .with_label("not found");
        let short = Diagnostic::new(Code::UnknownName, Span::new(at("z;"), at("z;") + 1), "unknown name `z`")
            .with_label("not found");
        let rendered = render_plain(&[long, short], &sources);
        assert!(rendered.len() < 2000, "{} bytes", rendered.len());
        assert!(rendered.contains("at long.vrs:1:16: not found"), "{rendered}");
        assert!(rendered.contains("2 │ const b: f32 = z;"), "{rendered}");
    }

    #[test]
    fn lines_up_to_the_limit_are_shown() {
        let mut sources = SourceMap::new();
        let line = format!("{}y", " ".repeat(MAX_SHOWN_LINE - 1));
        let file = sources.add("edge.vrs", None, format!("{line}\n"));
        let y = sources.file(file).base + (MAX_SHOWN_LINE - 1) as u32;
        let d = Diagnostic::new(Code::UnknownName, Span::new(y, y + 1), "unknown name `y`");
        assert!(!on_long_line(&sources, d.span));
        let file = sources.add("over.vrs", None, format!("{line} \n"));
        let y = sources.file(file).base + (MAX_SHOWN_LINE - 1) as u32;
        assert!(on_long_line(&sources, Span::new(y, y + 1)));
    }
}
