//! One analysis of one document: the checker's diagnostics (the same checker as `vrsc check`),
//! the composition diagnostics of every scene that lists the document, the fixes the checker's
//! hints give, and (built on first use) the [`Workspace`] that hover and navigation read.

use crate::fixes::{self, Fix};
use crate::text::LineIndex;
use crate::workspace::{Workspace, file_uri};
use lsp_types::{DiagnosticRelatedInformation, DiagnosticSeverity, Location, NumberOrString, Uri};
use std::cell::OnceCell;
use std::path::{Path, PathBuf};
use vrsc::compose::build::{Keep, compose_scene_with, read_scene};
use vrsc::diag::{Diagnostic, Severity};
use vrsc::driver::{self, Checked};
use vrsc::loader::ParsedFiles;
use vrsc::source::{FileId, SourceMap};

/// What the server knows about one version of a document.
pub struct Analysis {
    pub uri: Uri,
    /// Canonical path, for a document that is a file.
    pub path: Option<PathBuf>,
    pub text: String,
    pub lines: LineIndex,
    /// The checker's result for the document and what it imports.
    pub checked: Checked,
    /// The document's file in `checked.sources`.
    pub file: FileId,
    /// Every diagnostic shown on the document.
    pub diagnostics: Vec<Reported>,
    /// The module files of the scenes that list the document.
    scene_modules: Vec<PathBuf>,
    /// The scene files that list the document.
    scenes: Vec<PathBuf>,
    /// Every file the scenes' compositions read (modules and what they import).
    scene_files: Vec<PathBuf>,
    overlay: Vec<(PathBuf, String)>,
    workspace: OnceCell<Workspace>,
}

/// A diagnostic as sent to the editor, and the fix it offers.
pub struct Reported {
    pub diagnostic: lsp_types::Diagnostic,
    pub fix: Option<Fix>,
    /// Code, message and notes: the same diagnostic from a scene is not shown twice.
    key: (vrsc::diag::Code, String, Vec<String>),
}

/// What an analysis needs besides the document's text.
pub struct Context {
    /// The document's canonical path, when it is a file.
    pub path: Option<PathBuf>,
    /// Scene files (canonical) that list the document.
    pub scenes: Vec<PathBuf>,
    /// Open documents (canonical path, text), the analysed one included: read instead of disk.
    pub overlay: Vec<(PathBuf, String)>,
}

impl Analysis {
    pub fn new(uri: Uri, text: String, context: Context) -> Analysis {
        let Context { path, scenes, overlay } = context;
        let name = path
            .as_deref()
            .and_then(Path::file_name)
            .map_or_else(|| uri.as_str().to_string(), |n| n.to_string_lossy().into_owned());
        let checked = check(&name, path.as_deref(), &text, &overlay);
        let file = checked.graph.roots.first().map_or(0, |&root| checked.graph.modules[root].file);
        let lines = LineIndex::new(&text);
        let mut analysis = Analysis {
            uri,
            path,
            text,
            lines,
            checked,
            file,
            diagnostics: Vec::new(),
            scene_modules: Vec::new(),
            scenes: Vec::new(),
            scene_files: Vec::new(),
            overlay,
            workspace: OnceCell::new(),
        };
        analysis.report_checked();
        for scene in &scenes {
            analysis.report_scene(scene);
        }
        analysis.scenes = scenes;
        analysis
    }

    /// Whether the file at `path` (canonical) went into this analysis: the document's imports,
    /// its scenes and their modules (and what those import). A change to it needs a new analysis.
    pub fn depends_on(&self, path: &Path) -> bool {
        let checked = self.checked.sources.files().any(|(_, f)| f.path.as_deref() == Some(path));
        checked
            || self.scenes.iter().chain(&self.scene_modules).any(|p| p == path)
            || self.scene_files.iter().any(|p| p == path)
    }

    /// The parsed modules around the document, loaded on first use.
    pub fn workspace(&self) -> &Workspace {
        self.workspace.get_or_init(|| {
            let name = self.sources().file(self.file).name.clone();
            Workspace::load(&name, self.path.as_deref(), &self.text, &self.scene_modules, self.overlay.clone())
        })
    }

    pub fn sources(&self) -> &SourceMap {
        &self.checked.sources
    }

    /// The document's local byte offset of an LSP position.
    pub fn offset(&self, position: lsp_types::Position) -> usize {
        self.lines.offset(&self.text, position)
    }

    fn report_checked(&mut self) {
        for d in &self.checked.diags.sorted() {
            if let Some(reported) = self.reported(d, &self.checked.sources, None) {
                self.diagnostics.push(reported);
            }
        }
    }

    /// Composes the scene at `scene_path` with the open documents and reports what it finds in
    /// this document.
    fn report_scene(&mut self, scene_path: &Path) {
        let Ok(scene) = read_scene(scene_path) else { return };
        if let Some(scene) = &scene.scene {
            for module in scene.module_refs() {
                if let vrsc::scene::ModuleSource::File(file) = &module.source {
                    self.scene_modules.push(crate::scenes::canonical(&file.resolved));
                }
            }
        }
        let parsed = ParsedFiles::with_overlay(self.overlay.clone());
        let built = compose_scene_with(scene, None, Keep::Outputs, parsed, &[]);
        self.scene_files.extend(built.sources.files().filter_map(|(_, f)| f.path.clone()));
        for d in &built.diags.sorted() {
            if let Some(reported) = self.reported(d, &built.sources, Some(scene_path)) {
                self.diagnostics.push(reported);
            }
        }
    }

    /// `d` (whose spans are in `sources`) as shown, when its primary span is in this document
    /// and it is not already shown.
    fn reported(&self, d: &Diagnostic, sources: &SourceMap, scene: Option<&Path>) -> Option<Reported> {
        let (file, range) = sources.locate(d.span)?;
        let in_document = match (scene, &self.path) {
            (None, _) => file == self.file,
            (Some(_), Some(path)) => sources.file(file).path.as_deref() == Some(path.as_path()),
            (Some(_), None) => false,
        };
        if !in_document {
            return None;
        }
        let scene_name = scene.and_then(Path::file_name).map(|n| n.to_string_lossy().into_owned());
        let diagnostic = to_lsp(d, sources, self.lines.range(&self.text, range.clone()), scene_name.as_deref());
        let key = (d.code, d.message.clone(), d.notes.clone());
        // A scene checks the module again: what the checker already showed is shown once.
        let duplicate = self.diagnostics.iter().any(|r| r.diagnostic.range == diagnostic.range && r.key == key);
        if duplicate {
            return None;
        }
        let root = self.checked.graph.roots.first().map(|&r| &self.checked.graph.modules[r].ast);
        let base = self.checked.sources.file(self.file).base;
        // Spans of a scene's map differ from the checker's: the fix is found at the same local offset.
        let local = d.span.start - sources.file(file).base;
        let shifted = Diagnostic { span: vrsc::source::Span::new(base + local, base + local), ..d.clone() };
        let fix = root.and_then(|module| fixes::fix_for(&shifted, module, base, &self.text));
        Some(Reported { diagnostic, fix, key })
    }
}

/// The checker over the document (from its text) and everything it imports.
fn check(name: &str, path: Option<&Path>, text: &str, overlay: &[(PathBuf, String)]) -> Checked {
    if let Some(path) = path {
        let parsed = ParsedFiles::with_overlay(overlay.iter().cloned());
        if let Ok(checked) = driver::check_files_with(&[path.to_path_buf()], parsed) {
            return checked;
        }
    }
    driver::check_source(name, text, path.and_then(Path::parent))
}

/// The LSP form of a diagnostic whose primary span is `range`: code and severity as `vrsc check`
/// prints them, the scene that found it, the label and notes after the message, secondary spans
/// as related information.
fn to_lsp(d: &Diagnostic, sources: &SourceMap, range: lsp_types::Range, scene: Option<&str>) -> lsp_types::Diagnostic {
    let mut message = d.message.clone();
    if let Some(scene) = scene {
        message.push_str(&format!(" (composing scene `{scene}`)"));
    }
    if !d.label.is_empty() {
        message.push_str(&format!("\n{}", d.label));
    }
    for note in &d.notes {
        message.push_str(&format!("\n{note}"));
    }
    let related: Vec<DiagnosticRelatedInformation> = d
        .secondary
        .iter()
        .filter_map(|(span, label)| {
            let (file, local) = sources.locate(*span)?;
            let uri = file_uri(sources, file)?;
            let text = &sources.file(file).text;
            let location = Location::new(uri, LineIndex::new(text).range(text, local));
            Some(DiagnosticRelatedInformation { location, message: label.clone() })
        })
        .collect();
    lsp_types::Diagnostic {
        range,
        severity: Some(match d.severity {
            Severity::Error => DiagnosticSeverity::ERROR,
            Severity::Warning => DiagnosticSeverity::WARNING,
        }),
        code: Some(NumberOrString::String(d.code.as_str().to_string())),
        source: Some("vrsc".to_string()),
        message,
        related_information: (!related.is_empty()).then_some(related),
        ..lsp_types::Diagnostic::default()
    }
}
