//! Loader: reads the root files, lexes and parses them, and follows their imports into a module
//! graph. Missing files and import cycles are diagnostics at the `import` item.
//!
//! Public face: [`Loader`], which loads root files (from disk, from text or from the standard
//! library) into a [`ModuleGraph`] of [`LoadedModule`]s, and [`ParsedFiles`], the files already
//! read and parsed that a later load (another view of a scene, the language server's next check)
//! can reuse.

use crate::ast::{self, ItemKind};
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::source::{FileId, SourceFile, SourceMap, Span};
use crate::source_text::SourceText;
use crate::{lexer, parser, stdlib};
use rustc_hash::FxHashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

/// One loaded file.
#[derive(Debug)]
pub struct LoadedModule {
    /// Its file in the [`SourceMap`].
    pub file: FileId,
    /// Shared: the standard modules are parsed once per process, user files once per build.
    pub ast: Arc<ast::Module>,
    /// Indices (into [`ModuleGraph::modules`]) of the modules this one imports directly,
    /// in source order; an import that failed to load is left out.
    pub imports: Vec<usize>,
    /// `Some("shading")` for the standard module `std::shading`.
    pub std_name: Option<String>,
    /// Some of its items may be missing: its file has lexical or syntax errors or is not UTF-8,
    /// or one of its imports failed. A name the checker cannot find in it (or in a module that
    /// imports it) is then a follow-on of that error, not a mistake of its own.
    pub(crate) incomplete: bool,
}

/// Every module reachable from the roots. A file imported from several places is loaded once.
#[derive(Debug, Default)]
pub struct ModuleGraph {
    /// Every module loaded, each once; other modules refer to it by its index here.
    pub modules: Vec<LoadedModule>,
    /// The modules the user named, in the order given.
    pub roots: Vec<usize>,
}

/// Files already read and parsed into one [`SourceMap`], by canonical path: the views of a scene
/// load the same files into one map, and each is read, lexed and parsed once (its syntax errors
/// reported once).
#[derive(Debug, Default)]
pub struct ParsedFiles {
    files: FxHashMap<String, ParsedFile>,
    /// Paths as met → canonical paths: resolving one costs a system call per path component.
    canonical: FxHashMap<PathBuf, PathBuf>,
    /// Texts that stand in for files on disk, by canonical path (see [`ParsedFiles::with_overlay`]).
    overlay: FxHashMap<PathBuf, String>,
}

impl ParsedFiles {
    /// Nothing parsed yet, and `texts` (canonical path → text) read instead of those files on
    /// disk: an editor's unsaved buffers, so a check sees what the user is typing.
    pub fn with_overlay(texts: impl IntoIterator<Item = (PathBuf, String)>) -> ParsedFiles {
        ParsedFiles { overlay: texts.into_iter().collect(), ..ParsedFiles::default() }
    }
}

/// One file in [`ParsedFiles`]: its id, its syntax tree, and whether the tree may lack items
/// (the file had lexical or syntax errors, or is not UTF-8).
type ParsedFile = (FileId, Arc<ast::Module>, bool);

/// Builds a [`ModuleGraph`], adding every file it reads to the source map.
pub struct Loader<'a> {
    sources: &'a mut SourceMap,
    diags: &'a mut Diagnostics,
    graph: ModuleGraph,
    parsed: ParsedFiles,
    /// Canonical path or `std::name` → module index.
    loaded: FxHashMap<String, usize>,
    /// Modules whose imports are being followed (for cycle detection).
    in_progress: Vec<usize>,
}

impl<'a> Loader<'a> {
    /// A loader adding files to `sources` and reporting into `diags`.
    pub(crate) fn new(sources: &'a mut SourceMap, diags: &'a mut Diagnostics) -> Loader<'a> {
        Loader::with_parsed(sources, diags, ParsedFiles::default())
    }

    /// A loader that reuses the files an earlier loader parsed into the same `sources`.
    pub fn with_parsed(sources: &'a mut SourceMap, diags: &'a mut Diagnostics, parsed: ParsedFiles) -> Loader<'a> {
        Loader {
            sources,
            diags,
            graph: ModuleGraph::default(),
            parsed,
            loaded: FxHashMap::default(),
            in_progress: Vec::new(),
        }
    }

    /// Loads a root file from disk. An unreadable root is an `Err` (an I/O problem, exit code 2).
    pub fn load_root_file(&mut self, path: &Path) -> Result<usize, std::io::Error> {
        let canonical = self.canonical_path(path);
        let key = canonical.display().to_string();
        let index = match self.loaded.get(&key) {
            Some(&index) => index,
            None => self.add_file(path, canonical, key, || path.display().to_string())?,
        };
        self.graph.roots.push(index);
        Ok(index)
    }

    /// Loads a root module from text (tests, fuzzing, embedded sources). Imports resolve
    /// relative to `dir` when given.
    pub fn load_root_source(&mut self, name: &str, text: String, dir: Option<&Path>) -> usize {
        let path = dir.map(|d| self.canonical_path(&d.join(name)));
        let key = format!("<source {}>:{name}", self.graph.modules.len());
        let (file, ast, broken) = self.parse_file(name.to_string(), path, SourceText::Utf8(text), &key);
        let index = self.add_module(file, ast, None, key, broken);
        self.graph.roots.push(index);
        index
    }

    /// Loads a standard module (`std::name`) as a root.
    pub fn load_root_std(&mut self, name: &str) -> Option<usize> {
        let index = self.load_std(name)?;
        self.graph.roots.push(index);
        Some(index)
    }

    /// The graph of every module loaded.
    pub fn finish(self) -> ModuleGraph {
        self.graph
    }

    /// The graph, and the parsed files for the next loader over the same source map.
    pub(crate) fn finish_keeping_files(self) -> (ModuleGraph, ParsedFiles) {
        (self.graph, self.parsed)
    }

    /// The path with links and `..` resolved, or as given when it does not exist (yet).
    fn canonical_path(&mut self, path: &Path) -> PathBuf {
        if let Some(canonical) = self.parsed.canonical.get(path) {
            return canonical.clone();
        }
        let canonical = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
        self.parsed.canonical.insert(path.to_path_buf(), canonical.clone());
        canonical
    }

    fn load_std(&mut self, name: &str) -> Option<usize> {
        let key = format!("std::{name}");
        if let Some(&index) = self.loaded.get(&key) {
            return Some(index);
        }
        let file = self.sources.std_file(name)?;
        let parsed = &parsed_std()[file];
        // Empty unless a standard module itself has a syntax error (a bug in the compiler).
        parsed.diags.iter().cloned().for_each(|d| self.diags.push(d));
        Some(self.add_module(file, parsed.ast.clone(), Some(name), key, false))
    }

    /// Adds the file at `path` as a module under `key` (its canonical path): parsed into this
    /// source map by an earlier loader, or read and parsed now and shown as `name()`.
    fn add_file(
        &mut self,
        path: &Path,
        canonical: PathBuf,
        key: String,
        name: impl FnOnce() -> String,
    ) -> std::io::Result<usize> {
        let (file, ast, broken) = match self.parsed.files.get(&key) {
            Some(parsed) => parsed.clone(),
            None => {
                let text = match self.parsed.overlay.get(&canonical) {
                    Some(text) => SourceText::Utf8(text.clone()),
                    None => SourceText::read(path)?,
                };
                self.parse_file(name(), Some(canonical), text, &key)
            }
        };
        Ok(self.add_module(file, ast, None, key, broken))
    }

    /// Adds a file to the source map, lexes and parses it, and remembers it under `key`. A file
    /// that is not UTF-8 is not parsed: its one diagnostic says why, and its module is empty.
    fn parse_file(&mut self, name: String, canonical: Option<PathBuf>, text: SourceText, key: &str) -> ParsedFile {
        let (file, not_utf8) = text.add_to(self.sources, name, canonical);
        let errors_before = self.diags.error_count();
        let ast = match not_utf8 {
            Some(d) => {
                self.diags.push(d);
                ast::Module { file, items: Vec::new() }
            }
            None => parse_source(self.sources.file(file), file, self.diags),
        };
        let parsed = (file, Arc::new(ast), self.diags.error_count() > errors_before);
        self.parsed.files.insert(key.to_string(), parsed.clone());
        parsed
    }

    fn add_module(
        &mut self,
        file: FileId,
        ast: Arc<ast::Module>,
        std_name: Option<&str>,
        key: String,
        incomplete: bool,
    ) -> usize {
        let index = self.graph.modules.len();
        let std_name = std_name.map(String::from);
        self.graph.modules.push(LoadedModule { file, ast, imports: Vec::new(), std_name, incomplete });
        self.loaded.insert(key, index);
        self.in_progress.push(index);
        let imports = self.follow_imports(index);
        self.in_progress.pop();
        self.graph.modules[index].imports = imports;
        index
    }

    fn follow_imports(&mut self, index: usize) -> Vec<usize> {
        let module = &self.graph.modules[index];
        let importer = self.sources.file(module.file);
        let dir = importer.path.as_deref().and_then(Path::parent).map(Path::to_path_buf);
        let shown_dir = Path::new(&importer.name).parent().map(Path::to_path_buf).unwrap_or_default();
        let requests: Vec<(ImportRequest, Span)> = module
            .ast
            .items
            .iter()
            .filter_map(|item| match &item.kind {
                ItemKind::Import(ast::Import::Path { path, span }) => Some((ImportRequest::Path(path.clone()), *span)),
                ItemKind::Import(ast::Import::Std { path }) => {
                    let name = path.iter().map(|p| p.name.as_str()).collect::<Vec<_>>().join("::");
                    let span =
                        path.first().map(|p| p.span).unwrap_or(item.span).to(path.last().map_or(item.span, |p| p.span));
                    Some((ImportRequest::Std(name), span))
                }
                _ => None,
            })
            .collect();
        let mut imports = Vec::new();
        for (request, span) in requests {
            match self.import(request, dir.as_deref(), &shown_dir, span) {
                Some(target) if !imports.contains(&target) => imports.push(target),
                Some(_) => {}
                None => self.graph.modules[index].incomplete = true,
            }
        }
        imports
    }

    fn import(&mut self, request: ImportRequest, dir: Option<&Path>, shown_dir: &Path, span: Span) -> Option<usize> {
        match request {
            ImportRequest::Path(path) => self.import_path(&path, dir, shown_dir, span),
            ImportRequest::Std(name) => self.import_std(&name, span),
        }
    }

    /// `shown_dir` is the importing file's directory as the user named it: imported files are
    /// shown relative to it, so messages carry the paths the user wrote, not absolute ones.
    fn import_path(&mut self, path: &str, dir: Option<&Path>, shown_dir: &Path, span: Span) -> Option<usize> {
        let full = dir.map_or_else(|| PathBuf::from(path), |d| d.join(path));
        let canonical = self.canonical_path(&full);
        let key = canonical.display().to_string();
        if let Some(&target) = self.loaded.get(&key) {
            return self.check_cycle(target, span);
        }
        match self.add_file(&full, canonical, key, || lexical_join(shown_dir, path)) {
            Ok(index) => Some(index),
            Err(err) => {
                self.diags.push(
                    Diagnostic::new(Code::ImportNotFound, span, format!("cannot read `{path}`: {err}"))
                        .with_label("imported here")
                        .with_note("import paths are relative to the importing file"),
                );
                None
            }
        }
    }

    fn import_std(&mut self, name: &str, span: Span) -> Option<usize> {
        if let Some(&target) = self.loaded.get(&format!("std::{name}")) {
            return self.check_cycle(target, span);
        }
        if let Some(target) = self.load_std(name) {
            return Some(target);
        }
        let known = stdlib::names().collect::<Vec<_>>();
        let mut d = Diagnostic::new(Code::ImportNotFound, span, format!("no standard module `std::{name}`"))
            .with_label("not in the standard library");
        d = match crate::suggest::did_you_mean(name, known.iter().copied()) {
            Some(best) => d.with_help(format!("did you mean `std::{best}`?")),
            None => d.with_note(format!("standard modules: {}", known.join(", "))),
        };
        self.diags.push(d);
        None
    }

    /// An import of a module that is still being loaded closes a cycle.
    fn check_cycle(&mut self, target: usize, span: Span) -> Option<usize> {
        let Some(pos) = self.in_progress.iter().position(|&m| m == target) else { return Some(target) };
        let chain: Vec<String> = self.in_progress[pos..]
            .iter()
            .chain(std::iter::once(&target))
            .map(|&m| self.sources.file(self.graph.modules[m].file).name.clone())
            .collect();
        self.diags.push(
            Diagnostic::new(Code::ImportCycle, span, "import cycle")
                .with_label("this import closes the cycle")
                .with_note(format!("cycle: {}", chain.join(" -> ")))
                .with_help("move the shared functions into a module that both import"),
        );
        None
    }
}

/// A standard module parsed once per process, at the offsets every [`SourceMap`] gives it.
struct ParsedStd {
    ast: Arc<ast::Module>,
    diags: Vec<Diagnostic>,
}

/// The standard modules, parsed on first use, indexed by their file id.
fn parsed_std() -> &'static [ParsedStd] {
    static PARSED: OnceLock<Vec<ParsedStd>> = OnceLock::new();
    PARSED.get_or_init(|| {
        let sources = SourceMap::new();
        (0..stdlib::modules().count())
            .map(|file| {
                let mut diags = Diagnostics::new();
                let ast = Arc::new(parse_source(sources.file(file), file, &mut diags));
                ParsedStd { ast, diags: diags.iter().cloned().collect() }
            })
            .collect()
    })
}

fn parse_source(source: &SourceFile, file: FileId, diags: &mut Diagnostics) -> ast::Module {
    let eof = source.base + source.text.len() as u32;
    let lexed = lexer::lex(&source.text, source.base, diags);
    parser::parse_module(&lexed, file, eof, diags)
}

enum ImportRequest {
    Path(String),
    Std(String),
}

/// `base/rel` with `.` dropped and `dir/..` folded, without touching the file system.
fn lexical_join(base: &Path, rel: &str) -> String {
    use std::path::Component;
    let joined = base.join(rel);
    let mut parts: Vec<Component> = Vec::new();
    for part in joined.components() {
        match part {
            Component::CurDir => {}
            Component::ParentDir if matches!(parts.last(), Some(Component::Normal(_))) => {
                parts.pop();
            }
            other => parts.push(other),
        }
    }
    parts.iter().collect::<PathBuf>().display().to_string()
}

#[cfg(test)]
mod tests {
    use super::lexical_join;
    use std::path::Path;

    #[test]
    fn lexical_join_folds_dots_but_keeps_leading_parents() {
        assert_eq!(lexical_join(Path::new("../tests/a"), "./b.vrs"), "../tests/a/b.vrs");
        assert_eq!(lexical_join(Path::new("src/mods"), "../lib/c.vrs"), "src/lib/c.vrs");
        assert_eq!(lexical_join(Path::new(""), "../x.vrs"), "../x.vrs");
    }
}
