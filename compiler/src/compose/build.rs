//! Composing the views of a scene: standard modules chosen by the scene's configuration, then
//! the scene's modules, then the view's; checked, placed, emitted as WGSL with reflection.

use super::entry;
use super::ir::{Composition, ModuleUse};
use super::layer_check;
use super::limits;
use super::reflect::{self, Reflection};
use super::uniform_check;
use super::view;
use crate::check;
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::loader::{Loader, ModuleGraph, ParsedFiles};
use crate::lower::LookupSource;
use crate::scene::{self, ModuleRef, ModuleSource, Scene, View};
use crate::source::{FileId, SourceMap, Span};
use crate::source_text::SourceText;
use crate::steps::PipelineKind;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock};

/// One composed view.
pub struct ViewOutput {
    /// The view's name in the scene file.
    pub name: String,
    /// Where every pipeline function of the view was placed, and the composed state and
    /// uniforms (there also when composing the view reported errors).
    pub composition: Composition,
    /// `None` when composing the view reported errors.
    pub shader: Option<ViewShader>,
    /// What the view was composed from and into; only when the build was asked for it
    /// ([`Keep::Ir`]).
    pub ir: Option<ViewIr>,
    /// The view's filter pass, when it lists `filters`.
    pub filter: Option<FilterOutput>,
    /// The passes of the filters in its tree, by index into `Scene::tree_filters`
    /// ([`Scene::filters_under`]'s order): each over the picture of the children before it.
    pub tree_filters: Vec<(usize, FilterOutput)>,
}

impl ViewOutput {
    /// Its filter passes: the view's own, then those of the filters in its tree.
    pub fn filter_passes(&self) -> impl Iterator<Item = &FilterOutput> {
        self.filter.iter().chain(self.tree_filters.iter().map(|(_, f)| f))
    }
}

/// A view's filter pass: its `filters` composed into the `filter.*` steps after the standard
/// `std::filter_picture`, emitted as a compute shader that runs after the view's picture.
pub struct FilterOutput {
    /// What its files are named after the view's name: `filters` for the view's own pass,
    /// `GROUP-K.filters` for a filter of its tree ([`Scene::tree_filter_label`]).
    pub name: String,
    /// Where every function of the pass was placed, and its state and uniforms.
    pub composition: Composition,
    /// `None` when composing the pass reported errors.
    pub shader: Option<ViewShader>,
    /// The pass's checked program and validated module; only with [`Keep::Ir`].
    pub ir: Option<ViewIr>,
}

impl FilterOutput {
    /// The label of a filter of the view's tree (`GROUP-K`, what its name starts with); `None`
    /// for the view's own pass.
    pub fn tree_label(&self) -> Option<&str> {
        self.name.strip_suffix(".filters")
    }
}

/// The shader of a view: WGSL text and reflection.
pub struct ViewShader {
    /// The whole WGSL module: the view's entry point and everything it calls.
    pub wgsl: String,
    /// What a runtime needs to drive the shader: its entry point, bindings, uniform layout and
    /// hashes (the `.json` written next to the `.wgsl`).
    pub reflection: Reflection,
}

/// A view's intermediate forms, for tools that look inside it: the checked program (for the
/// pipeline map) and the validated naga module (`explain`, naga's other back ends).
pub struct ViewIr {
    /// The checked program of the view's modules (the composition's placements index its
    /// pipeline functions).
    pub program: crate::hir::Program,
    /// `None` when the view did not compose.
    pub module: Option<ValidModule>,
}

/// A naga module and what validating it found out.
pub struct ValidModule {
    /// The module lowering built (the view's shader before it is written as WGSL).
    pub module: naga::Module,
    /// naga's validation result for it, which naga's back ends need alongside the module.
    pub info: naga::valid::ModuleInfo,
}

/// What a build keeps of each view besides its composition, WGSL and reflection.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Keep {
    /// Nothing more: each view's intermediate forms are freed by the thread that made them, while
    /// the other views still compose.
    #[default]
    Outputs,
    /// Also each view's [`ViewIr`].
    Ir,
}

/// The result of composing a scene.
pub struct BuiltScene {
    /// Every file read: the scene file and each module, for rendering the diagnostics.
    pub sources: SourceMap,
    /// Everything the scene file, its modules and its views reported.
    pub diags: Diagnostics,
    /// `None` when the scene file itself is invalid.
    pub scene: Option<Scene>,
    /// One per composed view, in the scene's order (only `only_view` when given).
    pub views: Vec<ViewOutput>,
}

/// Reads and composes a scene (every view, or only `only_view`). An unreadable scene file is
/// an I/O error; everything else is reported as diagnostics.
pub fn build_scene(path: &Path, only_view: Option<&str>) -> std::io::Result<BuiltScene> {
    build_scene_keeping(path, only_view, Keep::Outputs)
}

/// [`build_scene`], keeping what `keep` asks for.
pub fn build_scene_keeping(path: &Path, only_view: Option<&str>, keep: Keep) -> std::io::Result<BuiltScene> {
    Ok(compose_scene(read_scene(path)?, only_view, keep))
}

/// A scene file read into a new source map and parsed.
pub struct ParsedScene {
    /// Holds the scene file (modules are added as the scene is composed).
    pub sources: SourceMap,
    /// `None` when the scene file itself is invalid.
    pub scene: Option<Scene>,
    /// What parsing the scene reported (its errors, or its warnings).
    pub diags: Diagnostics,
}

/// Reads the scene file at `path` into a new source map and parses it.
pub fn read_scene(path: &Path) -> std::io::Result<ParsedScene> {
    let text = SourceText::read(path)?;
    let mut sources = SourceMap::new();
    let (file, not_utf8) = text.add_to(&mut sources, path.display().to_string(), Some(path.to_path_buf()));
    let mut diags = Diagnostics::new();
    let scene = match not_utf8 {
        Some(d) => {
            diags.push(d);
            None
        }
        None => scene::parse_scene(&sources, file, &mut diags),
    };
    Ok(ParsedScene { sources, scene, diags })
}

/// Composes a scene parsed from a file of `sources` (every view, or only `only_view`); an invalid
/// scene gives its diagnostics.
pub fn compose_scene(parsed: ParsedScene, only_view: Option<&str>, keep: Keep) -> BuiltScene {
    compose_scene_with(parsed, only_view, keep, ParsedFiles::default(), &[])
}

/// A module made by the compiler itself rather than read from a file (the probe variant of a
/// view, `compose/probe.rs`). It is placed after every module of the scene and the view.
#[derive(Clone, Debug)]
pub struct GeneratedModule {
    /// The name diagnostics show for it.
    pub name: String,
    /// Its VRS source.
    pub text: String,
    /// The pass it goes into (in a filter pass, after its filters).
    pub pass: ViewPass,
}

/// One of a view's passes: its ray pipeline, its own filter pass (its `filters`), or the pass of
/// a filter in its tree (by index into `Scene::tree_filters`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewPass {
    /// The ray pipeline (the view's shader).
    Ray,
    /// The view's own filter pass.
    Filter,
    /// The pass of tree filter N.
    TreeFilter(usize),
}

impl ViewPass {
    /// The pipeline the pass composes: the ray pipeline or a filter pipeline.
    pub fn pipeline(self) -> PipelineKind {
        match self {
            ViewPass::Ray => PipelineKind::Ray,
            ViewPass::Filter | ViewPass::TreeFilter(_) => PipelineKind::Filter,
        }
    }
}

/// [`compose_scene`], loading modules through `parsed` (whose overlay stands in for files on
/// disk: the language server composes a scene with the user's unsaved buffers this way), with
/// `extra` modules placed last in every view composed.
pub fn compose_scene_with(
    scene: ParsedScene,
    only_view: Option<&str>,
    keep: Keep,
    mut parsed: ParsedFiles,
    extra: &[GeneratedModule],
) -> BuiltScene {
    let ParsedScene { mut sources, scene, mut diags } = scene;
    let Some(scene) = scene else {
        return BuiltScene { sources, diags, scene: None, views: Vec::new() };
    };
    let too_many = limits::check_counts(&scene);
    if !too_many.is_empty() {
        too_many.into_iter().for_each(|d| diags.push(d));
        return BuiltScene { sources, diags, scene: Some(scene), views: Vec::new() };
    }
    let chosen: Vec<&View> = scene.views.iter().filter(|view| only_view.is_none_or(|v| v == view.name.name)).collect();
    // Loading grows the source map, so it runs view after view (each file parsed once); the rest
    // of a view's work only reads the map, so the views compose in parallel. (Parsing the files in
    // parallel too saved less than handing work to another thread costs here.)
    let lookups = load_lookups(&scene, &mut sources, &mut diags);
    let loaded: Vec<LoadedPipelines> = chosen
        .iter()
        .map(|view| {
            let ray = load_view(&scene, view, extra, &mut sources, &mut parsed);
            let filter = load_filters(&view.filters, (extra, ViewPass::Filter), &mut sources, &mut parsed);
            let tree_filters = scene
                .filters_under(view)
                .into_iter()
                .filter_map(|f| {
                    let module = std::slice::from_ref(scene.tree_filters.get(f)?);
                    let extra = (extra, ViewPass::TreeFilter(f));
                    Some((f, load_filters(module, extra, &mut sources, &mut parsed)?))
                })
                .collect();
            LoadedPipelines { ray, filter, tree_filters }
        })
        .collect();
    let context = ComposeContext { scene: &scene, sources: &sources, lookups: &lookups, keep };
    let composed = compose_loaded_views(&context, &chosen, loaded);
    let mut views = Vec::with_capacity(composed.len());
    let mut data_flow = DataFlowWarnings::default();
    for (output, view_diags) in composed {
        let compositing = chosen.iter().find(|v| v.name.name == output.name).map(|v| v.render.compositing.value);
        for d in view_diags.iter() {
            if !data_flow.add(d, &output.name, compositing) {
                diags.push(d.clone());
            }
        }
        views.push(output);
    }
    data_flow.finish(&mut diags);
    let every_view = only_view.is_none() && views.iter().all(view_composed);
    check_against_views(&scene, &views, every_view, &mut diags);
    if let Some(name) = only_view
        && views.is_empty()
    {
        let names: Vec<&str> = scene.views.iter().map(|v| v.name.name.as_str()).collect();
        diags.push(
            Diagnostic::new(Code::SceneInvalid, Span::DUMMY, format!("the scene has no view `{name}`"))
                .with_note(format!("views: {}", names.join(", "))),
        );
    }
    BuiltScene { sources, diags, scene: Some(scene), views }
}

/// Whether a view composed: its shader, and its filter passes'.
pub(crate) fn view_composed(view: &ViewOutput) -> bool {
    view.shader.is_some() && view.filter_passes().all(|f| f.shader.is_some())
}

/// The checks of a scene's values against its composed views (`every_view`: all of them, each
/// with a shader): uniform values (E0702), the volumes and transfer functions they bind (E0608)
/// and the layers they read (E0609). What a composition reused for a scene whose values changed
/// ([`super::cache`]) must pass again.
pub(crate) fn check_against_views(scene: &Scene, views: &[ViewOutput], every_view: bool, diags: &mut Diagnostics) {
    // A filter pass's uniforms are the view's too: the scene sets them like any other.
    let filters = views.iter().flat_map(|v| v.filter_passes().map(|f| &f.composition));
    let compositions: Vec<&Composition> = views.iter().map(|v| &v.composition).chain(filters).collect();
    uniform_check::check_scene_uniforms(scene, &compositions, every_view, diags);
    let named: Vec<(&str, &Composition)> = views.iter().map(|v| (v.name.as_str(), &v.composition)).collect();
    uniform_check::check_resources(scene, &named, diags);
    layer_check::check_layers(scene, &named, diags);
}

/// The data-flow warnings of every view (W0005, W0006), each once for all the views it holds in,
/// with a note naming them: views that share a module share its mistakes.
#[derive(Default)]
struct DataFlowWarnings {
    /// In the order first seen, with the views that report it and their compositing modes.
    list: Vec<(Diagnostic, Vec<String>, Vec<scene::Compositing>)>,
}

impl DataFlowWarnings {
    /// Takes `d`, reported by `view` (compositing with `mode`), if it is a data-flow warning
    /// (`false` otherwise).
    fn add(&mut self, d: &Diagnostic, view: &str, mode: Option<scene::Compositing>) -> bool {
        if !matches!(d.code, Code::ReadBeforeWrite | Code::WrittenNeverRead) {
            return false;
        }
        let entry = match self.list.iter().position(|(seen, _, _)| seen == d) {
            Some(i) => &mut self.list[i],
            None => {
                self.list.push((d.clone(), Vec::new(), Vec::new()));
                self.list.last_mut().expect("just pushed")
            }
        };
        entry.1.push(view.to_string());
        if let Some(mode) = mode.filter(|m| !entry.2.contains(m)) {
            entry.2.push(mode);
        }
        true
    }

    /// Pushes each warning once; a lost write also names the views' compositing modes, which
    /// decide which standard functions read the fields.
    fn finish(self, diags: &mut Diagnostics) {
        let quoted = |names: Vec<&str>| names.iter().map(|v| format!("`{v}`")).collect::<Vec<_>>().join(", ");
        for (mut d, views, modes) in self.list {
            if d.code == Code::WrittenNeverRead && !modes.is_empty() {
                d = d.with_note(format!("with compositing {}", quoted(modes.iter().map(|m| m.name()).collect())));
            }
            let which = if views.len() == 1 { "in view" } else { "in views" };
            diags.push(d.with_note(format!("{which} {}", quoted(views.iter().map(String::as_str).collect()))));
        }
    }
}

/// A view's modules, loaded: the graph, how each root is used, and its own diagnostics so far.
struct LoadedView {
    graph: ModuleGraph,
    uses: Vec<ModuleUse>,
    diags: Diagnostics,
}

/// The standard module every filter pass starts with: it reads the picture and writes the
/// filtered colour.
pub const FILTER_PICTURE: &str = "filter_picture";

/// The modules of a view's pipelines, loaded: its ray pipeline, its filter pass, and the
/// passes of the filters in its tree (by index into `Scene::tree_filters`).
struct LoadedPipelines {
    ray: LoadedView,
    filter: Option<LoadedView>,
    tree_filters: Vec<(usize, LoadedView)>,
}

/// Loads the modules of a filter pass, `filters`, after [`FILTER_PICTURE`], then the `extra`
/// modules of that pass (`None` for no filters).
fn load_filters(
    filters: &[ModuleRef],
    (extra, pass): (&[GeneratedModule], ViewPass),
    sources: &mut SourceMap,
    parsed: &mut ParsedFiles,
) -> Option<LoadedView> {
    if filters.is_empty() {
        return None;
    }
    let mut diags = Diagnostics::new();
    let mut loader = Loader::with_parsed(sources, &mut diags, std::mem::take(parsed));
    let mut uses = Vec::new();
    if let Some(module) = loader.load_root_std(FILTER_PICTURE) {
        uses.push(ModuleUse { module, instances: None, span: Span::DUMMY });
    }
    let mut missing = Vec::new();
    for module_ref in filters {
        match load_module(&mut loader, module_ref) {
            Ok(module) => uses.push(module_use(module, module_ref)),
            Err(d) => missing.push(d),
        }
    }
    load_generated(&mut loader, extra, pass, &mut uses);
    let (graph, files) = loader.finish_keeping_files();
    *parsed = files;
    missing.into_iter().for_each(|d| diags.push(d));
    Some(LoadedView { graph, uses, diags })
}

/// Loads the generated modules of `pass` as roots, placed in the order given.
fn load_generated(loader: &mut Loader<'_>, extra: &[GeneratedModule], pass: ViewPass, uses: &mut Vec<ModuleUse>) {
    for generated in extra.iter().filter(|g| g.pass == pass) {
        let module = loader.load_root_source(&generated.name, generated.text.clone(), None);
        uses.push(ModuleUse { module, instances: None, span: Span::DUMMY });
    }
}

/// How a module the scene names is used: with the instances it gives.
fn module_use(module: usize, module_ref: &ModuleRef) -> ModuleUse {
    ModuleUse {
        module,
        instances: module_ref.instances.as_ref().map(|list| list.iter().map(|i| i.name.clone()).collect()),
        span: module_ref.span,
    }
}

/// Loads the standard modules a view's configuration selects, then the scene's modules, then
/// the view's own, then the `extra` ones. `parsed` carries the files earlier views already
/// parsed into `sources`.
fn load_view(
    scene: &Scene,
    view: &View,
    extra: &[GeneratedModule],
    sources: &mut SourceMap,
    parsed: &mut ParsedFiles,
) -> LoadedView {
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
            Ok(module) => uses.push(module_use(module, module_ref)),
            Err(d) => missing.push(d),
        }
    }
    load_generated(&mut loader, extra, ViewPass::Ray, &mut uses);
    let (graph, files) = loader.finish_keeping_files();
    *parsed = files;
    missing.into_iter().for_each(|d| diags.push(d));
    LoadedView { graph, uses, diags }
}

/// Checking, lowering and naga's passes recurse as deep as the nesting limits (E0105) allow,
/// which takes more than the 2 MiB of a test or worker thread in a debug build. A view composes
/// on a stack with at least `VIEW_STACK_MIN` left, moving to a fresh `VIEW_STACK` when the caller's
/// has less.
const VIEW_STACK_MIN: usize = 4 << 20;
const VIEW_STACK: usize = 16 << 20;

/// Threads for composition work, one per core beside the caller's, started once: threads that
/// live on keep their allocator heaps warm (a fresh thread per view cost more than composing it).
/// `None` on a single core, where views compose one after the other on the calling thread.
fn composer_pool() -> Option<&'static rayon::ThreadPool> {
    static POOL: OnceLock<Option<rayon::ThreadPool>> = OnceLock::new();
    POOL.get_or_init(|| {
        let threads = std::thread::available_parallelism().map_or(0, |n| n.get() - 1);
        if threads == 0 {
            return None;
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("vrsc-compose-{i}"))
            .stack_size(VIEW_STACK)
            .build()
            .ok()
    })
    .as_ref()
}

/// Waits until `done` holds by spinning, then yielding, for at most [`AWAIT_SPIN`] (after which
/// the caller falls back to a blocking wait).
fn await_briefly(done: impl Fn() -> bool) {
    let start = std::time::Instant::now();
    let mut spins = 0u32;
    while !done() && start.elapsed() < AWAIT_SPIN {
        if spins < 64 {
            spins += 1;
            std::hint::spin_loop();
        } else {
            std::thread::yield_now();
        }
    }
}

/// Longer than a view takes to compose, short enough not to matter when a helper never comes.
const AWAIT_SPIN: std::time::Duration = std::time::Duration::from_millis(5);

/// A unit of composition work, and its result.
type Job<'j, T> = Box<dyn FnOnce() -> T + Send + 'j>;

/// Runs `jobs` and gives their results in order. The calling thread and the composer threads
/// take the next job from a shared queue until none is left: the queue starts at job `first`
/// (the caller's) and wraps around. A helper thread that is slow to wake (a busy virtual
/// machine can take milliseconds to run it) then simply finds no work left, and the caller is
/// never worse off than running every job itself. A caller out of work spins for the helpers'
/// last jobs rather than sleep ([`await_briefly`]).
fn run_jobs<T: Send>(jobs: Vec<Job<'_, T>>, first: usize) -> Vec<T> {
    let Some(pool) = composer_pool().filter(|_| jobs.len() > 1) else {
        return jobs.into_iter().map(|job| job()).collect();
    };
    let helpers = pool.current_num_threads().min(jobs.len() - 1);
    let queue: Vec<Mutex<Option<Job<'_, T>>>> = jobs.into_iter().map(|job| Mutex::new(Some(job))).collect();
    let results: Vec<Mutex<Option<T>>> = queue.iter().map(|_| Mutex::new(None)).collect();
    let next = AtomicUsize::new(0);
    // Jobs completed so far, by any thread: the caller waits on this, not on the scope.
    let finished = AtomicUsize::new(0);
    let work = || loop {
        let taken = next.fetch_add(1, Ordering::Relaxed);
        if taken >= queue.len() {
            break;
        }
        let i = (first + taken) % queue.len();
        let (Some(slot), Some(result)) = (queue.get(i), results.get(i)) else { break };
        if let Some(job) = slot.lock().ok().and_then(|mut job| job.take()) {
            let value = job();
            if let Ok(mut result) = result.lock() {
                *result = Some(value);
            }
        }
        finished.fetch_add(1, Ordering::Release);
    };
    pool.in_place_scope(|s| {
        for _ in 0..helpers {
            s.spawn(|_| work());
        }
        work();
        // The caller, out of work, waits for the helpers' last jobs. Sleeping in the scope's
        // latch would cost it a wake-up (0.05 to 0.4 ms on this kind of virtual machine).
        await_briefly(|| finished.load(Ordering::Acquire) == queue.len());
    });
    // Every job has run when the scope ends (a panic in one resumes here).
    results.into_iter().filter_map(|r| r.into_inner().ok().flatten()).collect()
}

/// Composes loaded views in parallel; the results come in the order given. The calling thread
/// starts at once with the heaviest view (most items in its modules), while a composer thread
/// is still waking up for the others.
fn compose_loaded_views(
    context: &ComposeContext<'_>,
    views: &[&View],
    loaded: Vec<LoadedPipelines>,
) -> Vec<(ViewOutput, Diagnostics)> {
    let weight = |l: &LoadedView| -> usize { l.graph.modules.iter().map(|m| m.ast.items.len()).sum() };
    let heaviest = loaded.iter().enumerate().max_by_key(|(_, l)| weight(&l.ray)).map_or(0, |(i, _)| i);
    let jobs = views
        .iter()
        .zip(loaded)
        .map(|(&view, loaded)| {
            let job: Job<'_, _> = Box::new(move || {
                stacker::maybe_grow(VIEW_STACK_MIN, VIEW_STACK, || compose_loaded(context, view, loaded))
            });
            job
        })
        .collect();
    run_jobs(jobs, heaviest)
}

/// Checks, places and emits one loaded view, its filter pass and those of its tree.
fn compose_loaded(context: &ComposeContext<'_>, view: &View, loaded: LoadedPipelines) -> (ViewOutput, Diagnostics) {
    let (ray, mut diags) = compose_pipeline(context, view, loaded.ray, PipelineKind::Ray);
    let mut filter_pass = |filters: LoadedView, name: String| {
        let (pass, own) = compose_pipeline(context, view, filters, PipelineKind::Filter);
        own.iter().for_each(|d| diags.push(d.clone()));
        let (composition, shader, ir) = pass.into_parts(context.keep);
        FilterOutput { name, composition, shader, ir }
    };
    let filter = loaded.filter.map(|loaded| filter_pass(loaded, "filters".into()));
    let label = |f: usize| format!("{}.filters", context.scene.tree_filter_label(f));
    let tree_filters = loaded.tree_filters.into_iter().map(|(f, loaded)| (f, filter_pass(loaded, label(f)))).collect();
    let (composition, shader, ir) = ray.into_parts(context.keep);
    (ViewOutput { name: view.name.name.clone(), composition, shader, ir, filter, tree_filters }, diags)
}

/// One pipeline of a view, composed: its checked program, its composition, and its shader with
/// its validated module (`None` after errors).
struct ComposedPipeline {
    program: crate::hir::Program,
    composition: Composition,
    emitted: Option<(ViewShader, ValidModule)>,
}

impl ComposedPipeline {
    /// The composition, the shader, and the intermediate forms when `keep` asks for them
    /// (unless kept, the program and the module are freed here, by the thread that made them).
    fn into_parts(self, keep: Keep) -> (Composition, Option<ViewShader>, Option<ViewIr>) {
        let (shader, module) = self.emitted.unzip();
        (self.composition, shader, (keep == Keep::Ir).then(|| ViewIr { program: self.program, module }))
    }
}

/// Checks, places and emits the pipeline of `kind` of a view from its loaded modules; the
/// diagnostics are the loaded ones and what composing added.
fn compose_pipeline(
    context: &ComposeContext<'_>,
    view: &View,
    loaded: LoadedView,
    kind: PipelineKind,
) -> (ComposedPipeline, Diagnostics) {
    let ComposeContext { scene, sources, .. } = *context;
    let LoadedView { graph, uses, mut diags } = loaded;
    let program = check::check_program(&graph, sources, &mut diags);
    let is_std = |m: usize| graph.modules.get(m).is_some_and(|m| m.std_name.is_some());
    let required = match kind {
        PipelineKind::Ray => entry::ENTRY_FIELDS,
        PipelineKind::Filter => entry::FILTER_ENTRY_FIELDS,
    };
    // A function with an error is left out of the program, so placing what is left would report
    // its absence (fields without defaults, reads before writes, a template that looks like a
    // plain module): follow-ons of the errors already reported. Those are the only ones shown.
    let composition = if diags.has_errors() || graph.modules.iter().any(|m| m.incomplete) {
        super::compose(&program, &uses, (kind, is_std), required, &mut Diagnostics::new())
    } else {
        super::compose(&program, &uses, (kind, is_std), required, &mut diags)
    };
    if kind == PipelineKind::Filter && !diags.has_errors() {
        layer_check::check_filter_inputs(scene, view, &composition, &mut diags);
    }
    let emitted = if diags.has_errors() {
        None
    } else {
        emit_shader(context, view, (kind, &program), &composition).map_err(|d| diags.push(d)).ok()
    };
    (ComposedPipeline { program, composition, emitted }, diags)
}

/// Each bricked volume's binding and the file of its own lookup (`[[volume]] lookup`), if any.
type Lookups = Vec<(String, Option<FileId>)>;

/// Reads the scene's own brick lookups into `sources`; one that cannot be read is an error
/// (E0201) and its volume keeps the standard lookup.
fn load_lookups(scene: &Scene, sources: &mut SourceMap, diags: &mut Diagnostics) -> Lookups {
    let mut lookups = Vec::new();
    for (binding, lookup) in scene.bricked_bindings() {
        let file = lookup.and_then(|l| match std::fs::read_to_string(&l.resolved) {
            Ok(text) => Some(sources.add(l.given.clone(), Some(l.resolved.clone()), text)),
            Err(e) => {
                diags.push(
                    Diagnostic::new(Code::ImportNotFound, l.span, format!("cannot read `{}`: {e}", l.given))
                        .with_label("named here")
                        .with_note("lookup paths are relative to the scene file"),
                );
                None
            }
        });
        lookups.push((binding, file));
    }
    lookups
}

/// What every view of a scene composes with.
struct ComposeContext<'a> {
    scene: &'a Scene,
    sources: &'a SourceMap,
    lookups: &'a Lookups,
    keep: Keep,
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

/// The shader of a view's pipeline of `kind` and its validated module.
fn emit_shader(
    context: &ComposeContext<'_>,
    view: &View,
    (kind, program): (PipelineKind, &crate::hir::Program),
    composition: &Composition,
) -> Result<(ViewShader, ValidModule), Diagnostic> {
    let ComposeContext { scene, sources, lookups, .. } = *context;
    let bricked: Vec<(String, LookupSource<'_>)> = lookups
        .iter()
        .map(|(binding, file)| {
            let lookup = file.map_or(LookupSource::Standard, |id| {
                let file = sources.file(id);
                LookupSource::File { text: &file.text, base: file.base }
            });
            (binding.clone(), lookup)
        })
        .collect();
    let vm = match kind {
        PipelineKind::Ray => view::emit(program, composition, sources, &bricked)?,
        PipelineKind::Filter => super::filter::emit(program, composition, sources)?,
    };
    let wgsl = crate::lower::write_wgsl(&vm.module, &vm.info)?;
    let reflection = reflect::reflect(scene, view, program, composition, &vm, &wgsl, sources);
    Ok((ViewShader { wgsl, reflection }, ValidModule { module: vm.module, info: vm.info }))
}
