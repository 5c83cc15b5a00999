//! The modules around a document, parsed: the document, what it imports, the modules of the
//! scenes that list it, and every standard module. Hover, completion and navigation look names
//! up here.

use crate::{stdlib_files, uri};
use lsp_types::{Location, Uri};
use std::path::PathBuf;
use vrsc::ast::{self, DeclKind, ItemKind};
use vrsc::diag::Diagnostics;
use vrsc::loader::{Loader, ModuleGraph, ParsedFiles};
use vrsc::source::{FileId, SourceMap, Span};

use crate::text::LineIndex;

/// Parsed modules around one document (see the module comment).
pub struct Workspace {
    pub sources: SourceMap,
    pub graph: ModuleGraph,
    /// The document's module.
    pub document: usize,
}

/// A `state` declaration found somewhere in the workspace.
pub struct StateDecl<'a> {
    pub module: usize,
    pub pipeline: &'a ast::PipelineFn,
    pub ray: bool,
    pub ty: &'a ast::TypeExpr,
    pub default: Option<&'a ast::Expr>,
    pub doc: Option<&'a str>,
    pub name_span: Span,
}

/// A `uniform` declaration found somewhere in the workspace.
pub struct UniformDecl<'a> {
    pub ty: &'a ast::TypeExpr,
    pub default: Option<&'a ast::Expr>,
    pub range: Option<&'a (ast::Expr, ast::Expr)>,
    pub doc: Option<&'a str>,
    pub name_span: Span,
}

/// An item with its doc comment and module.
pub struct Found<'a, T> {
    pub module: usize,
    pub item: &'a T,
    pub doc: Option<&'a str>,
}

impl Workspace {
    /// Loads `document` (from `text`; imports resolve next to `path`), then `scene_modules`, then
    /// every standard module. `overlay` stands in for files on disk.
    pub fn load(
        name: &str,
        path: Option<&std::path::Path>,
        text: &str,
        scene_modules: &[PathBuf],
        overlay: Vec<(PathBuf, String)>,
    ) -> Workspace {
        let mut sources = SourceMap::new();
        // The checker reports on the document; what loading finds again here is not shown.
        let mut ignored = Diagnostics::new();
        let mut loader = Loader::with_parsed(&mut sources, &mut ignored, ParsedFiles::with_overlay(overlay));
        let document = match path.map(|p| loader.load_root_file(p)) {
            Some(Ok(index)) => index,
            _ => loader.load_root_source(name, text.to_string(), path.and_then(|p| p.parent())),
        };
        for module in scene_modules {
            let _ = loader.load_root_file(module);
        }
        for std in vrsc::stdlib::names() {
            loader.load_root_std(std);
        }
        let graph = loader.finish();
        Workspace { sources, graph, document }
    }

    pub fn ast(&self, module: usize) -> &ast::Module {
        &self.graph.modules[module].ast
    }

    pub fn document_ast(&self) -> &ast::Module {
        self.ast(self.document)
    }

    /// The document's global offset of local byte `offset`.
    pub fn document_offset(&self, offset: usize) -> u32 {
        self.sources.file(self.graph.modules[self.document].file).base + offset as u32
    }

    /// How a module is named to the user: `std::shading`, or its file's name (`ellipsoid.vrs`).
    pub fn module_label(&self, module: usize) -> String {
        let m = &self.graph.modules[module];
        let file = self.sources.file(m.file);
        match (&m.std_name, &file.path) {
            (Some(name), _) => format!("std::{name}"),
            (None, Some(path)) => {
                path.file_name().map_or_else(|| file.name.clone(), |n| n.to_string_lossy().into_owned())
            }
            (None, None) => file.name.clone(),
        }
    }

    pub fn snippet(&self, span: Span) -> &str {
        self.sources.snippet(span)
    }

    /// Every module index, the document's first.
    fn modules(&self) -> impl Iterator<Item = usize> + '_ {
        std::iter::once(self.document).chain((0..self.graph.modules.len()).filter(|&m| m != self.document))
    }

    /// The modules whose library functions and constants the document sees: itself and what it
    /// imports.
    pub fn visible_modules(&self) -> Vec<usize> {
        std::iter::once(self.document).chain(self.graph.modules[self.document].imports.iter().copied()).collect()
    }

    /// Every `state NAME` declaration, the document's first.
    pub fn state_decls(&self, name: &str) -> Vec<StateDecl<'_>> {
        let mut out = Vec::new();
        for module in self.modules() {
            for p in pipelines(self.ast(module)) {
                for decl in &p.decls {
                    if let DeclKind::State { ray, name: n, ty, default } = &decl.kind
                        && n.name == name
                    {
                        let doc = decl.doc.as_deref();
                        out.push(StateDecl {
                            module,
                            pipeline: p,
                            ray: *ray,
                            ty,
                            default: default.as_ref(),
                            doc,
                            name_span: n.span,
                        });
                    }
                }
            }
        }
        out
    }

    /// Every state field name declared anywhere, sorted, with one declaration each (preferring
    /// one with a default).
    pub fn state_names(&self) -> Vec<(String, StateDecl<'_>)> {
        let mut names: Vec<String> = Vec::new();
        for module in self.modules() {
            for p in pipelines(self.ast(module)) {
                for decl in &p.decls {
                    if let DeclKind::State { name, .. } = &decl.kind {
                        names.push(name.name.clone());
                    }
                }
            }
        }
        names.sort();
        names.dedup();
        names
            .into_iter()
            .filter_map(|name| {
                let mut decls = self.state_decls(&name);
                let best = decls.iter().position(|d| d.default.is_some()).unwrap_or(0);
                (!decls.is_empty()).then(|| (name, decls.swap_remove(best)))
            })
            .collect()
    }

    /// Every `uniform NAME` declaration, the document's first.
    pub fn uniform_decls(&self, name: &str) -> Vec<UniformDecl<'_>> {
        let mut out = Vec::new();
        for module in self.modules() {
            for p in pipelines(self.ast(module)) {
                for decl in &p.decls {
                    if let DeclKind::Uniform { name: n, ty, default, range } = &decl.kind
                        && n.name == name
                    {
                        let doc = decl.doc.as_deref();
                        out.push(UniformDecl {
                            ty,
                            default: default.as_ref(),
                            range: range.as_ref(),
                            doc,
                            name_span: n.span,
                        });
                    }
                }
            }
        }
        out
    }

    /// Library functions called `name` in `modules` (or anywhere when `None`).
    pub fn lib_fns(&self, name: Option<&str>, modules: Option<&[usize]>) -> Vec<Found<'_, ast::LibFn>> {
        self.items(modules, |kind| match kind {
            ItemKind::LibFn(f) if name.is_none_or(|n| f.name.name == n) => Some(f),
            _ => None,
        })
    }

    /// Constants called `name` in `modules`.
    pub fn consts(&self, name: Option<&str>, modules: &[usize]) -> Vec<Found<'_, ast::ConstItem>> {
        self.items(Some(modules), |kind| match kind {
            ItemKind::Const(c) if name.is_none_or(|n| c.name.name == n) => Some(c),
            _ => None,
        })
    }

    /// Pipeline functions whose placement targets `step`, the document's first, then in load
    /// order (standard modules included).
    pub fn placed_in(&self, step: vrsc::steps::Step) -> Vec<Found<'_, ast::PipelineFn>> {
        self.items(None, |kind| match kind {
            ItemKind::Pipeline(p) if placement_step(&p.placement) == Some(step) => Some(p),
            _ => None,
        })
    }

    fn items<'a, T>(
        &'a self,
        modules: Option<&[usize]>,
        pick: impl Fn(&'a ItemKind) -> Option<&'a T>,
    ) -> Vec<Found<'a, T>> {
        let all: Vec<usize> = match modules {
            Some(list) => list.to_vec(),
            None => self.modules().collect(),
        };
        let mut out = Vec::new();
        for module in all {
            for item in &self.ast(module).items {
                if let Some(found) = pick(&item.kind) {
                    out.push(Found { module, item: found, doc: item.doc.as_deref() });
                }
            }
        }
        out
    }

    /// The module of the standard library called `name`.
    pub fn std_module(&self, name: &str) -> Option<usize> {
        self.graph.modules.iter().position(|m| m.std_name.as_deref() == Some(name))
    }

    /// Where a global span lies, as an editor location: the document itself (its buffer text),
    /// another file on disk, or a standard module's cached file.
    pub fn location(&self, span: Span, document_uri: &Uri) -> Option<Location> {
        let (file, range) = self.sources.locate(span)?;
        let uri = if file == self.graph.modules[self.document].file {
            document_uri.clone()
        } else {
            file_uri(&self.sources, file)?
        };
        let text = &self.sources.file(file).text;
        Some(Location::new(uri, LineIndex::new(text).range(text, range)))
    }
}

/// The URI of a file of `sources`: its path, or a standard module's cached copy.
pub fn file_uri(sources: &SourceMap, file: FileId) -> Option<Uri> {
    let f = sources.file(file);
    match &f.path {
        Some(path) => uri::from_path(path),
        None => uri::from_path(&stdlib_files::path_of(f.name.strip_prefix("std::")?)?),
    }
}

fn pipelines(module: &ast::Module) -> impl Iterator<Item = &ast::PipelineFn> {
    module.items.iter().filter_map(|item| match &item.kind {
        ItemKind::Pipeline(p) => Some(p),
        _ => None,
    })
}

/// The step a placement targets (a group resolved as `before`/`after` do).
pub fn placement_step(placement: &ast::Placement) -> Option<vrsc::steps::Step> {
    resolve_step(&placement.target.step_name(), Some(placement.kind))
}

/// The step a dotted name means under a placement (`None` for `remove`): a group stands for its
/// first step with `before` and its last otherwise (the checker rejects a group with `in`,
/// `replace` and `remove`; hover and navigation still point somewhere useful).
pub fn resolve_step(name: &str, placement: Option<ast::PlacementKind>) -> Option<vrsc::steps::Step> {
    use vrsc::steps::{Step, StepLookup};
    match Step::lookup(name) {
        StepLookup::Step(step) => Some(step),
        StepLookup::Group { first, .. } if placement == Some(ast::PlacementKind::Before) => Some(first),
        StepLookup::Group { last, .. } => Some(last),
        StepLookup::Unknown => None,
    }
}

impl Workspace {
    /// The pipeline functions of one module, in source order.
    pub fn pipelines_in(&self, module: usize) -> Vec<&ast::PipelineFn> {
        pipelines(self.ast(module)).collect()
    }
}
