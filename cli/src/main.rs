//! The `vrsc` command line. Exit codes: 0 success (warnings allowed), 1 the input has errors,
//! 2 usage or I/O problems.

mod failure;
mod inputs;

use clap::{Parser, Subcommand, ValueEnum};
use codespan_reporting::term::{self, termcolor};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use vrsc::compose::backends::Target;
use vrsc::compose::build::{Keep, build_scene_keeping};
use vrsc::diag::{Code, Diagnostic};
use vrsc::driver::{self, Checked};
use vrsc::source::{SourceMap, Span};

mod watch;

// Composition allocates many small nodes; mimalloc takes about a quarter off its instruction
// count compared with the system allocator (see compiler/benches/compose.rs).
#[global_allocator]
static GLOBAL: vrsc_alloc::MiMalloc = vrsc_alloc::MiMalloc;

#[derive(Parser)]
#[command(name = "vrsc", version, about = "Compiler for VRS volume-rendering pipeline functions")]
struct Cli {
    /// How diagnostics are printed: `human` (codespan style) or `json` (one object per line on stdout).
    #[arg(long, value_enum, default_value_t = MessageFormat::Human, global = true)]
    message_format: MessageFormat,
    /// Colour in human diagnostics.
    #[arg(long, value_enum, default_value_t = ColorMode::Auto, global = true)]
    color: ColorMode,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Parse and check modules on their own (imports followed).
    Check {
        #[arg(required = true)]
        files: Vec<PathBuf>,
    },
    /// Print the WGSL of a module's functions, each pipeline function lowered on its own.
    Emit {
        file: PathBuf,
        /// Write the WGSL here instead of standard output.
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Compose every view of a scene; write DIR/VIEW.wgsl and DIR/VIEW.json (reflection).
    Build {
        scene: PathBuf,
        #[arg(short, long)]
        output: PathBuf,
        /// Also translate each view through naga's back ends: spirv, glsl, msl, hlsl
        /// (comma-separated or repeated); written as DIR/VIEW.spv, .comp.glsl, .metal, .hlsl.
        #[arg(long, value_delimiter = ',')]
        emit: Vec<Target>,
    },
    /// Print a view's composed WGSL with each function annotated by the VRS file:line it came from.
    Explain {
        scene: PathBuf,
        /// The view (may be left out when the scene has one view).
        #[arg(long)]
        view: Option<String>,
    },
    /// Render every view of a scene to DIR/VIEW.png.
    Render {
        scene: PathBuf,
        #[arg(short, long)]
        output: PathBuf,
        /// Image size for every view, WxH (overrides the scene's `size`).
        #[arg(long, value_parser = parse_size)]
        size: Option<[u32; 2]>,
        /// Use the software adapter (lavapipe) even when a GPU is present.
        #[arg(long)]
        software: bool,
        /// Samples per pixel of a path-traced view (`compositing = "pathtrace"`): the frames
        /// its picture is the mean of. Other views render once.
        #[arg(long, default_value_t = vrs_runtime::view::DEFAULT_SAMPLES, value_parser = clap::value_parser!(u32).range(1..=65536))]
        samples: u32,
        #[command(flatten)]
        probe: ProbeArgs,
    },
    /// Open a window with every view of a scene; follows edits of the scene and its modules.
    View {
        scene: PathBuf,
        /// Use the software adapter (lavapipe) even when a GPU is present.
        #[arg(long)]
        software: bool,
        /// The interactive frame budget in milliseconds (all views together): while the camera
        /// moves, views render at the resolution that fits it, and refine when input stops.
        #[arg(long, default_value_t = 100)]
        budget_ms: u64,
    },
    /// Render every view to DIR/VIEW.png, then again on every change of the scene or a module it
    /// reads (imports included), until Ctrl-C.
    Watch {
        scene: PathBuf,
        #[arg(short, long)]
        output: PathBuf,
        /// Image size for every view, WxH (overrides the scene's `size`).
        #[arg(long, value_parser = parse_size)]
        size: Option<[u32; 2]>,
        /// Use the software adapter (lavapipe) even when a GPU is present.
        #[arg(long)]
        software: bool,
    },
    /// Print the pipeline map of a scene's views: steps, their functions, where each came from.
    Pipeline {
        scene: PathBuf,
        /// Only this view.
        #[arg(long)]
        view: Option<String>,
    },
    /// Run the language server on standard input and output (for editors: editors/README.md).
    Lsp,
}

/// `vrsc render --probe`: a state field shown as an image instead of the views' pictures.
#[derive(clap::Args)]
struct ProbeArgs {
    /// Write DIR/VIEW.FIELD.png for every view that declares state field FIELD (and print each
    /// image's value range and mapping) instead of DIR/VIEW.png.
    #[arg(long, value_name = "FIELD")]
    probe: Option<String>,
    /// Read the field at the first sample whose accumulated opacity (accum.a) reaches A
    /// (default for sample fields: 0.5; `@ray` fields are read at ray.finish unless this or
    /// --probe-sample is given).
    #[arg(long, value_name = "A", requires = "probe", conflicts_with = "probe_sample")]
    probe_threshold: Option<f32>,
    /// Read the field at sample N of each ray (0-based).
    #[arg(long, value_name = "N", requires = "probe")]
    probe_sample: Option<u32>,
}

impl ProbeArgs {
    /// Where the probe reads its field; `None` leaves it to the field's lifetime.
    fn at(&self) -> Option<vrs_runtime::ProbeAt> {
        use vrs_runtime::ProbeAt;
        self.probe_threshold.map(ProbeAt::Opacity).or(self.probe_sample.map(ProbeAt::Sample))
    }
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum MessageFormat {
    Human,
    Json,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ColorMode {
    Auto,
    Always,
    Never,
}

/// Exit status of a command.
enum Outcome {
    Ok,
    InputErrors,
    Failure,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if matches!(cli.command, Command::Render { .. } | Command::View { .. } | Command::Watch { .. }) {
        quiet_vulkan_loader();
    }
    // A window's event loop must run on the main thread (winit); composition there grows its
    // stack as it needs (stacker), so the viewer does without the worker below.
    if let Command::View { scene, software, budget_ms } = &cli.command {
        return exit_code(view(scene, *software, *budget_ms));
    }
    // Deeply nested input recurses in the passes; a large stack keeps such input an error
    // rather than a crash. The limits in the lexer and checker bound the depth itself.
    let worker = std::thread::Builder::new().stack_size(256 << 20).spawn(move || run(&cli));
    let outcome = match worker.map(|h| h.join()) {
        Ok(Ok(outcome)) => outcome,
        _ => {
            eprintln!("error: internal compiler error (a panic); please report it with the input");
            Outcome::Failure
        }
    };
    exit_code(outcome)
}

fn exit_code(outcome: Outcome) -> ExitCode {
    match outcome {
        Outcome::Ok => ExitCode::SUCCESS,
        Outcome::InputErrors => ExitCode::from(1),
        Outcome::Failure => ExitCode::from(2),
    }
}

/// Gives the Vulkan loader a valid `XDG_RUNTIME_DIR` when the environment has none (or names
/// something that is not a folder), so that a render that succeeds prints no
/// `error: XDG_RUNTIME_DIR is invalid` lines. The folder is private (mode 700), as the XDG
/// specification asks. Runs before any other thread starts: changing the environment is only
/// sound while no other thread reads it.
fn quiet_vulkan_loader() {
    let valid = std::env::var_os("XDG_RUNTIME_DIR").is_some_and(|dir| Path::new(&dir).is_dir());
    if valid {
        return;
    }
    // One folder for every run, so renders leave nothing new behind.
    let dir = std::env::temp_dir().join("vrsc-xdg-runtime");
    let made = std::fs::create_dir_all(&dir).and_then(|()| {
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700))?;
        }
        Ok(())
    });
    if made.is_ok() {
        // SAFETY: called at the start of `main`, before any other thread exists.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", &dir) };
    }
}

fn run(cli: &Cli) -> Outcome {
    let printer = Printer { format: cli.message_format, color: cli.color };
    match &cli.command {
        Command::Build { scene, output, emit } => build(&printer, scene, output, emit),
        Command::Render { scene, output, size, software, samples, probe } => {
            render(&printer, scene, output, RenderArgs { size: *size, software: *software, samples: *samples, probe })
        }
        Command::View { scene, software, budget_ms } => view(scene, *software, *budget_ms),
        Command::Watch { scene, output, size, software } => {
            watch::watch(&printer, &watch::WatchArgs { scene, dir: output, size: *size, software: *software })
        }
        Command::Explain { scene, view } => explain(&printer, scene, view.as_deref()),
        Command::Pipeline { scene, view } => pipeline(&printer, scene, view.as_deref()),
        Command::Lsp => match vrsc_lsp::run_stdio() {
            Ok(()) => Outcome::Ok,
            Err(e) => printer.io_failure(&format!("language server: {e}")),
        },
        Command::Check { files } => match driver::check_files(files) {
            Ok(checked) => printer.finish(&checked),
            Err(e) => printer.io_failure(&e),
        },
        Command::Emit { file, output } => {
            let mut checked = match driver::check_files(std::slice::from_ref(file)) {
                Ok(c) => c,
                Err(e) => return printer.io_failure(&e),
            };
            let wgsl = checked.emit_standalone_wgsl();
            let outcome = printer.finish(&checked);
            let Some(wgsl) = wgsl else { return outcome };
            let written = match output {
                Some(path) => std::fs::write(path, wgsl).map_err(|e| format!("cannot write `{}`: {e}", path.display())),
                None => std::io::stdout().write_all(wgsl.as_bytes()).map_err(|e| format!("cannot write WGSL: {e}")),
            };
            match written {
                Ok(()) => outcome,
                Err(message) => printer.io_failure(&message),
            }
        }
    }
}

fn build(printer: &Printer, scene: &std::path::Path, dir: &std::path::Path, targets: &[Target]) -> Outcome {
    // naga's other back ends translate the view's module, which only a build keeping it has.
    let keep = if targets.is_empty() { Keep::Outputs } else { Keep::Ir };
    let built = match build_scene_keeping(scene, None, keep) {
        Ok(b) => b,
        Err(e) => return printer.io_failure(&format!("cannot read `{}`: {e}", scene.display())),
    };
    let outcome = printer.report(&with_input_checks(&built), &built.sources);
    if !matches!(outcome, Outcome::Ok) {
        return outcome;
    }
    if let Err(e) = inputs::check_output_dir(dir) {
        return printer.io_failure(&e);
    }
    for view in &built.views {
        let Some(shader) = &view.shader else { continue };
        let json = serde_json::to_string_pretty(&shader.reflection).unwrap_or_default();
        let mut outputs =
            vec![("wgsl".to_string(), shader.wgsl.as_bytes().to_vec()), ("json".into(), json.into_bytes())];
        // A build with targets keeps the module of every view that composed.
        let module = view.ir.as_ref().and_then(|ir| ir.module.as_ref());
        for &target in targets {
            let Some(valid) = module else { break };
            match vrsc::compose::backends::translate(&valid.module, &valid.info, "main", target) {
                Ok(bytes) => outputs.push((target.extension().to_string(), bytes)),
                Err(e) => {
                    let message = format!("view `{}`: naga's {} back end failed: {e}", view.name, target.name());
                    return printer.fail(Diagnostic::new(Code::Internal, Span::DUMMY, message));
                }
            }
        }
        // The filter passes beside the view's shader: VIEW.filters.wgsl and .json for its own,
        // VIEW.GROUP-K.filters.wgsl and .json for each filter of its tree.
        for pass in view.filter_passes() {
            let Some(filter) = &pass.shader else { continue };
            let json = serde_json::to_string_pretty(&filter.reflection).unwrap_or_default();
            outputs.push((format!("{}.wgsl", pass.name), filter.wgsl.as_bytes().to_vec()));
            outputs.push((format!("{}.json", pass.name), json.into_bytes()));
        }
        for (ext, bytes) in &outputs {
            let path = dir.join(format!("{}.{ext}", view.name));
            if let Err(e) = std::fs::write(&path, bytes) {
                return printer.io_failure(&format!("cannot write `{}`: {e}", path.display()));
            }
        }
        let extensions: Vec<&str> = outputs.iter().map(|(ext, _)| ext.as_str()).collect();
        eprintln!("wrote {}/{}.{{{}}}", dir.display(), view.name, extensions.join(","));
    }
    Outcome::Ok
}

fn explain(printer: &Printer, scene: &std::path::Path, only: Option<&str>) -> Outcome {
    let built = match build_scene_keeping(scene, only, Keep::Ir) {
        Ok(b) => b,
        Err(e) => return printer.io_failure(&format!("cannot read `{}`: {e}", scene.display())),
    };
    let outcome = printer.report(&built.diags.sorted(), &built.sources);
    if only.is_none() && built.views.len() > 1 {
        let names: Vec<&str> = built.views.iter().map(|v| v.name.as_str()).collect();
        eprintln!("error: the scene has several views; pick one with --view ({})", names.join(", "));
        return Outcome::Failure;
    }
    for view in &built.views {
        if let Some(text) = vrsc::compose::explain::explain_with_filters(view, &built.sources) {
            print!("{text}");
        }
    }
    outcome
}

fn pipeline(printer: &Printer, scene: &std::path::Path, only: Option<&str>) -> Outcome {
    let built = match build_scene_keeping(scene, only, Keep::Ir) {
        Ok(b) => b,
        Err(e) => return printer.io_failure(&format!("cannot read `{}`: {e}", scene.display())),
    };
    let outcome = printer.report(&built.diags.sorted(), &built.sources);
    for view in &built.views {
        println!("== view {} ==", view.name);
        let table = built.scene.as_ref().and_then(|s| Some((s, s.views.iter().find(|v| v.name.name == view.name)?)));
        if let Some((scene, table)) = table {
            println!("picture: {}", scene.describe_picture(table));
        }
        print!("{}", view.render_maps(&built.sources));
    }
    outcome
}

fn view(scene: &Path, software: bool, budget_ms: u64) -> Outcome {
    let options = vrs_viewer::ViewerOptions {
        scene: scene.to_path_buf(),
        software,
        budget: std::time::Duration::from_millis(budget_ms.max(1)),
    };
    match vrs_viewer::run(options) {
        Ok(()) => Outcome::Ok,
        Err(e) => {
            eprintln!("{}", e.trim_end());
            Outcome::InputErrors
        }
    }
}

/// The largest `--size` side: any device's limit lies below it.
const MAX_SIZE_ARG: u32 = 65536;

fn parse_size(text: &str) -> Result<[u32; 2], String> {
    let (w, h) = text.split_once(['x', 'X']).ok_or("expected WxH, for example 512x512")?;
    // Beyond a scene's limit the device decides: a size it cannot hold is its E0904.
    let parse = |s: &str| s.trim().parse::<u32>().ok().filter(|&n| (1..=MAX_SIZE_ARG).contains(&n));
    match (parse(w), parse(h)) {
        (Some(w), Some(h)) => Ok([w, h]),
        _ => Err(format!("width and height must be whole numbers from 1 to {MAX_SIZE_ARG}")),
    }
}

/// What `vrsc render` was asked for besides the scene and the folder.
struct RenderArgs<'a> {
    size: Option<[u32; 2]>,
    software: bool,
    samples: u32,
    probe: &'a ProbeArgs,
}

fn render(printer: &Printer, scene_path: &Path, dir: &Path, args: RenderArgs) -> Outcome {
    use vrs_runtime::{AdapterChoice, Gpu, RenderOptions, SceneRenderer};
    // A probe needs each view's program to know the fields it declares.
    let keep = if args.probe.probe.is_some() { Keep::Ir } else { Keep::Outputs };
    let built = match build_scene_keeping(scene_path, None, keep) {
        Ok(b) => b,
        Err(e) => return printer.io_failure(&format!("cannot read `{}`: {e}", scene_path.display())),
    };
    let outcome = printer.report(&with_input_checks(&built), &built.sources);
    let Some(scene) = built.scene.as_ref().filter(|_| matches!(outcome, Outcome::Ok)) else { return outcome };
    let probed = match &args.probe.probe {
        Some(field) => match vrsc::compose::probe::views_with_field(&built, field) {
            Ok(views) => Some((field.as_str(), views)),
            Err(d) => return printer.report(&[d], &built.sources),
        },
        None => None,
    };
    if let Err(e) = inputs::check_output_dir(dir) {
        return printer.io_failure(&e);
    }
    let choice = if args.software { AdapterChoice::Software } else { AdapterChoice::PreferHardware };
    let gpu = match Gpu::headless(choice) {
        Ok(gpu) => gpu,
        Err(e) => return printer.fail(Diagnostic::new(Code::Device, Span::DUMMY, e.to_string())),
    };
    eprintln!("rendering on {}", gpu.adapter);
    let options = RenderOptions { size: args.size, samples: args.samples, ..RenderOptions::default() };
    let mut bar = ProgressBar::default();
    let renderer = SceneRenderer::from_built(gpu, scene_path, scene, &built, options, &mut |name, done, total| {
        bar.update(name, done, total)
    });
    // Notices after rendering: loading's, and what streaming bricked volumes loaded.
    let result = renderer.and_then(|mut r| {
        let images = match probed {
            Some((field, views)) => render_probes(&mut r, field, &views, args.probe.at()),
            None => trace_paths(&mut r, args.samples, &mut bar).and_then(|()| r.render_all()),
        };
        r.notices.iter().for_each(|n| eprintln!("note: {n}"));
        images
    });
    let images = match result {
        Ok(images) => images,
        Err(e) => return printer.report(&[failure::runtime(&e, scene)], &built.sources),
    };
    if let Err(e) = std::fs::create_dir_all(dir) {
        return printer.io_failure(&format!("cannot create `{}`: {e}", dir.display()));
    }
    for (name, image) in images {
        let path = dir.join(format!("{name}.png"));
        if let Err(e) = image.save(&path) {
            return printer.io_failure(&format!("cannot write `{}`: {e}", path.display()));
        }
        eprintln!("wrote {} ({}x{})", path.display(), image.width(), image.height());
    }
    Outcome::Ok
}

/// Renders the frames of each path-traced view up to `samples` in sixteen parts, saying how far
/// it got (a picture of many samples takes minutes on a software adapter); `render_all` then
/// adds the last frames and reads the pictures back.
fn trace_paths(
    renderer: &mut vrs_runtime::SceneRenderer,
    samples: u32,
    bar: &mut ProgressBar,
) -> Result<(), vrs_runtime::RuntimeError> {
    let step = (samples / 16).max(1);
    for index in 0..renderer.views().len() {
        if !renderer.views()[index].renderer.is_progressive() {
            continue;
        }
        let name = format!("view `{}`", renderer.views()[index].name);
        let mut done = 0;
        while done + step < samples {
            done += step;
            renderer.views_mut()[index].renderer.set_samples(done);
            renderer.render_view(index)?;
            bar.samples(&name, done, samples);
        }
        renderer.views_mut()[index].renderer.set_samples(samples);
        bar.samples(&name, samples, samples);
    }
    Ok(())
}

/// Probes of `field` in the views with these indices, named `VIEW.FIELD`; prints each legend.
fn render_probes(
    renderer: &mut vrs_runtime::SceneRenderer,
    field: &str,
    views: &[usize],
    at: Option<vrs_runtime::ProbeAt>,
) -> Result<Vec<(String, image::RgbaImage)>, vrs_runtime::RuntimeError> {
    let spec = vrs_runtime::ProbeSpec { field: field.to_string(), at };
    let mut images = Vec::new();
    for &index in views {
        let probe = renderer.render_probe(index, &spec)?;
        println!("{}", probe.legend());
        images.push((format!("{}.{field}", probe.view), probe.image));
    }
    Ok(images)
}

/// A one-line progress bar on stderr (a terminal only) for volumes large enough to take a while
/// to read and for the frames of path-traced views.
#[derive(Default)]
struct ProgressBar {
    shown: Option<(String, u64)>,
}

impl ProgressBar {
    const MIN_BYTES: u64 = 4 << 20;

    /// `done` of `total` bytes of volume `name` read.
    fn update(&mut self, name: &str, done: u64, total: u64) {
        if total >= Self::MIN_BYTES {
            self.show(&format!("loading {name}"), done, total, "");
        }
    }

    /// `done` of `total` samples per pixel of a path-traced view rendered.
    fn samples(&mut self, view: &str, done: u32, total: u32) {
        let count = format!(" {done} of {total} samples");
        self.show(&format!("path tracing {view}"), u64::from(done), u64::from(total), &count);
    }

    fn show(&mut self, what: &str, done: u64, total: u64, after: &str) {
        if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            return;
        }
        let percent = done.saturating_mul(100) / total.max(1);
        if self.shown.as_ref().is_some_and(|(n, p)| n == what && *p == percent) {
            return;
        }
        let filled = (percent / 5).min(20) as usize;
        eprint!("\r{what} [{}{}] {percent:>3}%{after}", "#".repeat(filled), " ".repeat(20 - filled));
        if done >= total {
            eprintln!();
        }
        self.shown = Some((what.to_string(), percent));
    }
}

/// A build's diagnostics, sorted, followed by those of the scene's inputs (volumes, transfer
/// functions, phantoms) when the scene parsed.
fn with_input_checks(built: &vrsc::compose::build::BuiltScene) -> Vec<Diagnostic> {
    let mut diags = built.diags.sorted();
    if let Some(scene) = &built.scene {
        diags.extend(inputs::check_scene_inputs(scene));
    }
    diags
}

struct Printer {
    format: MessageFormat,
    color: ColorMode,
}

impl Printer {
    /// Prints every diagnostic and says whether the input had errors.
    fn finish(&self, checked: &Checked) -> Outcome {
        self.report(&checked.diags.sorted(), &checked.sources)
    }

    /// Prints every diagnostic; the outcome is a failure (exit 2) when one is about the machine
    /// (`failure::is_environment`), else an input error when one is an error.
    fn report(&self, diags: &[Diagnostic], sources: &SourceMap) -> Outcome {
        self.print(diags, sources);
        if diags.iter().any(failure::is_environment) {
            Outcome::Failure
        } else if diags.iter().any(Diagnostic::is_error) {
            Outcome::InputErrors
        } else {
            Outcome::Ok
        }
    }

    /// One error outside any source file (a path on the command line, an output, the GPU).
    fn fail(&self, d: Diagnostic) -> Outcome {
        self.report(&[d], &SourceMap::new())
    }

    fn io_failure(&self, e: &dyn std::fmt::Display) -> Outcome {
        self.fail(failure::io(e.to_string()))
    }

    fn print(&self, diags: &[Diagnostic], sources: &SourceMap) {
        match self.format {
            MessageFormat::Json => {
                let stdout = std::io::stdout();
                let mut out = stdout.lock();
                for d in diags {
                    if let Ok(line) = serde_json::to_string(&d.to_json(sources)) {
                        let _ = writeln!(out, "{line}");
                    }
                }
            }
            MessageFormat::Human => {
                let choice = match self.color {
                    ColorMode::Always => termcolor::ColorChoice::Always,
                    ColorMode::Never => termcolor::ColorChoice::Never,
                    ColorMode::Auto if std::io::IsTerminal::is_terminal(&std::io::stderr()) => {
                        termcolor::ColorChoice::Auto
                    }
                    ColorMode::Auto => termcolor::ColorChoice::Never,
                };
                let stream = termcolor::StandardStream::stderr(choice);
                let mut lock = stream.lock();
                let config = term::Config::default();
                for d in diags {
                    let _ = term::emit_to_write_style(&mut lock, &config, sources, &d.to_codespan(sources));
                }
                summarize(diags);
            }
        }
    }
}

fn summarize(diags: &[Diagnostic]) {
    let errors = diags.iter().filter(|d| d.is_error()).count();
    let warnings = diags.len() - errors;
    let plural = |n: usize, word: &str| format!("{n} {word}{}", if n == 1 { "" } else { "s" });
    if errors > 0 {
        eprintln!("{} and {} emitted", plural(errors, "error"), plural(warnings, "warning"));
    } else if warnings > 0 {
        eprintln!("{} emitted", plural(warnings, "warning"));
    }
}
