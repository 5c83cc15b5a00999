//! Composing the views of a scene: standard modules chosen by the scene's configuration, then
//! the scene's modules, then the view's; checked, placed, emitted as WGSL with reflection.

use super::place::{self, Composition, ModuleUse};
use super::reflect::{self, Reflection};
use super::view;
use crate::check;
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::loader::{Loader, ModuleGraph, ParsedFiles};
use crate::scene::{self, ModuleRef, ModuleSource, Scene, View};
use crate::source::{SourceMap, Span};
use std::path::Path;

/// Fields the entry point reads or writes itself.
pub const ENTRY_FIELDS: &[&str] = &["pixel", "terminate", "out_color"];

/// One composed view.
pub struct ViewOutput {
    pub name: String,
    pub composition: Composition,
    pub program: crate::hir::Program,
    /// `None` when composing the view reported errors.
    pub shader: Option<ViewShader>,
}

/// The shader of a view: WGSL text, its naga module, and reflection.
pub struct ViewShader {
    pub module: naga::Module,
    pub info: naga::valid::ModuleInfo,
    pub wgsl: String,
    pub reflection: Reflection,
}

/// The result of composing a scene.
pub struct BuiltScene {
    pub sources: SourceMap,
    pub diags: Diagnostics,
    /// `None` when the scene file itself is invalid.
    pub scene: Option<Scene>,
    pub views: Vec<ViewOutput>,
}

/// Reads and composes a scene (every view, or only `only_view`). An unreadable scene file is
/// an I/O error; everything else is reported as diagnostics.
pub fn build_scene(path: &Path, only_view: Option<&str>) -> std::io::Result<BuiltScene> {
    let text = std::fs::read_to_string(path)?;
    let mut sources = SourceMap::new();
    let file = sources.add(path.display().to_string(), Some(path.to_path_buf()), text);
    let mut diags = Diagnostics::new();
    let scene = match scene::parse_scene(&sources, file) {
        Ok(scene) => scene,
        Err(e) => {
            e.diagnostics.into_iter().for_each(|d| diags.push(d));
            return Ok(BuiltScene { sources, diags, scene: None, views: Vec::new() });
        }
    };
    scene.warnings.iter().cloned().for_each(|d| diags.push(d));
    let chosen: Vec<&View> = scene.views.iter().filter(|view| only_view.is_none_or(|v| v == view.name.name)).collect();
    // Loading grows the source map, so it runs view after view (each file parsed once); the rest
    // of a view's work only reads the map, so the views compose in parallel.
    let mut parsed = ParsedFiles::default();
    let loaded: Vec<LoadedView> =
        chosen.iter().map(|view| load_view(&scene, view, &mut sources, &mut parsed)).collect();
    let composed = compose_loaded_views(&scene, &chosen, loaded, &sources);
    let mut views = Vec::with_capacity(composed.len());
    for (output, view_diags) in composed {
        diags.extend(view_diags);
        views.push(output);
    }
    if let Some(name) = only_view
        && views.is_empty()
    {
        let names: Vec<&str> = scene.views.iter().map(|v| v.name.name.as_str()).collect();
        diags.push(
            Diagnostic::new(Code::SceneInvalid, Span::DUMMY, format!("the scene has no view `{name}`"))
                .with_note(format!("views: {}", names.join(", "))),
        );
    }
    Ok(BuiltScene { sources, diags, scene: Some(scene), views })
}

/// Composes one view of a scene whose file is already in `sources`.
pub fn compose_view(scene: &Scene, view: &View, sources: &mut SourceMap, diags: &mut Diagnostics) -> ViewOutput {
    let loaded = load_view(scene, view, sources, &mut ParsedFiles::default());
    let (output, view_diags) = compose_loaded(scene, view, loaded, sources);
    diags.extend(view_diags);
    output
}

/// A view's modules, loaded: the graph, how each root is used, and its own diagnostics so far.
struct LoadedView {
    graph: ModuleGraph,
    uses: Vec<ModuleUse>,
    diags: Diagnostics,
}

/// Loads the standard modules a view's configuration selects, then the scene's modules, then
/// the view's own. `parsed` carries the files earlier views already parsed into `sources`.
fn load_view(scene: &Scene, view: &View, sources: &mut SourceMap, parsed: &mut ParsedFiles) -> LoadedView {
    let mut diags = Diagnostics::new();
    let mut loader = Loader::with_parsed(sources, &mut diags, std::mem::take(parsed));
    let mut uses = Vec::new();
    for std in scene.standard_modules(view) {
        if let Some(module) = loader.load_root_std(std.name) {
            let instances = (!std.instances.is_empty()).then_some(std.instances);
            uses.push(ModuleUse { module, instances, span: Span::DUMMY });
        }
    }
    let mut missing = Vec::new();
    for module_ref in scene.modules.iter().chain(&view.modules) {
        match load_module(&mut loader, module_ref) {
            Ok(module) => uses.push(ModuleUse {
                module,
                instances: module_ref.instances.as_ref().map(|list| list.iter().map(|i| i.name.clone()).collect()),
                span: module_ref.span,
            }),
            Err(d) => missing.push(d),
        }
    }
    let (graph, files) = loader.finish_keeping_files();
    *parsed = files;
    missing.into_iter().for_each(|d| diags.push(d));
    LoadedView { graph, uses, diags }
}

/// Composes loaded views, each on its own thread but the first, in the order given.
fn compose_loaded_views(
    scene: &Scene,
    views: &[&View],
    loaded: Vec<LoadedView>,
    sources: &SourceMap,
) -> Vec<(ViewOutput, Diagnostics)> {
    let mut work = views.iter().zip(loaded);
    let Some((first_view, first)) = work.next() else { return Vec::new() };
    std::thread::scope(|s| {
        let others: Vec<_> =
            work.map(|(view, loaded)| s.spawn(move || compose_loaded(scene, view, loaded, sources))).collect();
        let mut outputs = vec![compose_loaded(scene, first_view, first, sources)];
        for handle in others {
            // A panic in a view's thread is a compiler bug: let it surface as it would have here.
            outputs.push(handle.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)));
        }
        outputs
    })
}

/// Checks, places and emits one loaded view.
fn compose_loaded(scene: &Scene, view: &View, loaded: LoadedView, sources: &SourceMap) -> (ViewOutput, Diagnostics) {
    let LoadedView { graph, uses, mut diags } = loaded;
    let program = check::check_program(&graph, sources, &mut diags);
    let is_std = |m: usize| graph.modules.get(m).is_some_and(|m| m.std_name.is_some());
    let composition = place::compose(&program, &uses, is_std, ENTRY_FIELDS, &mut diags);
    let shader = if diags.has_errors() {
        None
    } else {
        match emit_shader(scene, view, &program, &composition, sources) {
            Ok(shader) => Some(shader),
            Err(d) => {
                diags.push(d);
                None
            }
        }
    };
    (ViewOutput { name: view.name.name.clone(), composition, program, shader }, diags)
}

fn load_module(loader: &mut Loader<'_>, module_ref: &ModuleRef) -> Result<usize, Diagnostic> {
    match &module_ref.source {
        ModuleSource::Std(name) => loader.load_root_std(&name.value).ok_or_else(|| {
            Diagnostic::new(Code::ImportNotFound, name.span, format!("no standard module `std::{}`", name.value))
                .with_label("not in the standard library")
        }),
        ModuleSource::File(file) => loader.load_root_file(&file.resolved).map_err(|e| {
            Diagnostic::new(Code::ImportNotFound, file.span, format!("cannot read `{}`: {e}", file.given))
                .with_label("named here")
                .with_note("module paths are relative to the scene file")
        }),
    }
}

fn emit_shader(
    scene: &Scene,
    view: &View,
    program: &crate::hir::Program,
    composition: &Composition,
    sources: &SourceMap,
) -> Result<ViewShader, Diagnostic> {
    let vm = view::emit(program, composition, sources)?;
    let wgsl = crate::lower::write_wgsl(&vm.module, &vm.info)?;
    let reflection = reflect::reflect(scene, view, program, composition, &vm, &wgsl, sources);
    Ok(ViewShader { module: vm.module, info: vm.info, wgsl, reflection })
}
