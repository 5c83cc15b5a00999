//! Composing the views of a scene: standard modules chosen by the scene's configuration, then
//! the scene's modules, then the view's; checked, placed, emitted as WGSL with reflection.

use super::place::{self, Composition, ModuleUse};
use super::reflect::{self, Reflection};
use super::view;
use crate::check;
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::loader::Loader;
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
    let mut views = Vec::new();
    for view in &scene.views {
        if only_view.is_some_and(|v| v != view.name.name) {
            continue;
        }
        views.push(compose_view(&scene, view, &mut sources, &mut diags));
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

/// Composes one view of a scene.
pub fn compose_view(scene: &Scene, view: &View, sources: &mut SourceMap, diags: &mut Diagnostics) -> ViewOutput {
    let mut view_diags = Diagnostics::new();
    let mut loader = Loader::new(sources, &mut view_diags);
    let mut uses = Vec::new();
    let mut std_modules = Vec::new();
    for std in scene.standard_modules(view) {
        if let Some(module) = loader.load_root_std(std.name) {
            std_modules.push(module);
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
    let graph = loader.finish();
    missing.into_iter().for_each(|d| view_diags.push(d));
    let program = check::check_program(&graph, sources, &mut view_diags);
    let is_std = |m: usize| graph.modules.get(m).is_some_and(|m| m.std_name.is_some());
    let composition = place::compose(&program, &uses, is_std, ENTRY_FIELDS, &mut view_diags);
    let shader = if view_diags.has_errors() {
        None
    } else {
        match emit_shader(scene, view, &program, &composition, sources) {
            Ok(shader) => Some(shader),
            Err(d) => {
                view_diags.push(d);
                None
            }
        }
    };
    diags.extend(view_diags);
    ViewOutput { name: view.name.name.clone(), composition, program, shader }
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
