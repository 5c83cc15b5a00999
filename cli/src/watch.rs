//! `vrsc watch`: the prototyping loop without a window. Renders every view to `DIR/VIEW.png`,
//! then rebuilds on each change of the scene or a module it reads, rewriting the images
//! atomically; a broken edit prints its diagnostics and leaves the last good images alone.

use super::{MessageFormat, Outcome, Printer, failure};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use vrs_live::{Failure, FileWatcher, LiveScene, Rebuild};
use vrs_runtime::{AdapterChoice, Gpu, RenderOptions, SceneRenderer};
use vrsc::diag::{Code, Diagnostic};
use vrsc::source::Span;

/// What `vrsc watch` was asked to do.
pub struct WatchArgs<'a> {
    pub scene: &'a Path,
    pub dir: &'a Path,
    pub size: Option<[u32; 2]>,
    pub software: bool,
}

pub fn watch(printer: &Printer, args: &WatchArgs) -> Outcome {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    if let Err(e) = ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst)) {
        return printer.io_failure(&format!("cannot handle Ctrl-C: {e}"));
    }
    if let Err(e) = std::fs::create_dir_all(args.dir) {
        return printer.io_failure(&format!("cannot create `{}`: {e}", args.dir.display()));
    }
    let mut watcher = match FileWatcher::new(|| {}) {
        Ok(w) => w,
        Err(e) => return printer.io_failure(&format!("cannot watch files: {e}")),
    };
    let choice = if args.software { AdapterChoice::Software } else { AdapterChoice::PreferHardware };
    let gpu = match Gpu::headless(choice) {
        Ok(gpu) => gpu,
        Err(e) => return printer.fail(Diagnostic::new(Code::Device, Span::DUMMY, e.to_string())),
    };
    eprintln!("rendering on {}", gpu.adapter);
    let Some(mut live) = open_when_good(printer, args, gpu, &mut watcher, &stop) else { return Outcome::Ok };
    // The files are watched before each report: a client that edits as soon as it reads one
    // (an editor, a test) must not edit before the watch is in place.
    let rendered = render(&mut live, args.dir);
    if let Err(e) = watcher.watch(live.files()) {
        return printer.io_failure(&format!("cannot watch files: {e}"));
    }
    report(printer, &[], None, &rendered);
    loop {
        let Some(changed) = next_change(&watcher, &stop) else { return stopped(printer) };
        let rebuild = live.rebuild();
        if let Err(e) = watcher.watch(live.files()) {
            return printer.io_failure(&format!("cannot watch files: {e}"));
        }
        let changed: Vec<PathBuf> = changed.into_iter().collect();
        if let Some(built) = &rebuild.built {
            printer.print(&built.diags.sorted(), &built.sources);
        }
        if let Err(failure) = &rebuild.outcome {
            let why = match failure {
                Failure::Compose => "the scene does not compose (see above)".to_string(),
                Failure::Runtime(e) => format!("error: {e}"),
            };
            report(printer, &changed, Some(&rebuild), &Err(why));
            continue;
        }
        let rendered = render(&mut live, args.dir);
        report(printer, &changed, Some(&rebuild), &rendered);
    }
}

/// Opens the scene, waiting for edits while it does not compose.
fn open_when_good(
    printer: &Printer,
    args: &WatchArgs,
    gpu: Gpu,
    watcher: &mut FileWatcher,
    stop: &AtomicBool,
) -> Option<LiveScene> {
    let options = RenderOptions { size: args.size, ..RenderOptions::default() };
    loop {
        let built = vrsc::compose::build::build_scene(args.scene, None);
        let mut files = vec![args.scene.to_path_buf()];
        if let Ok(built) = &built {
            printer.print(&built.diags.sorted(), &built.sources);
            files.extend(built.sources.files().filter_map(|(_, f)| f.path.clone()));
            if let Some(scene) = built.scene.as_ref().filter(|_| !built.diags.has_errors()) {
                match SceneRenderer::from_built(
                    gpu.clone(),
                    args.scene,
                    scene,
                    built,
                    options.clone(),
                    &mut |_, _, _| {},
                ) {
                    Ok(renderer) => {
                        renderer.notices.iter().for_each(|n| eprintln!("note: {n}"));
                        return Some(LiveScene::new(renderer));
                    }
                    Err(e) => {
                        printer.report(&[failure::runtime(&e, scene)], &built.sources);
                    }
                }
            }
        } else if let Err(e) = &built {
            printer.io_failure(&format!("cannot read `{}`: {e}", args.scene.display()));
        }
        eprintln!("waiting for a change of the scene's files");
        if watcher.watch(&files).is_err() {
            return None;
        }
        next_change(watcher, stop)?;
    }
}

/// Waits for a change, or `None` once Ctrl-C or SIGTERM arrived.
fn next_change(watcher: &FileWatcher, stop: &AtomicBool) -> Option<BTreeSet<PathBuf>> {
    while !stop.load(Ordering::SeqCst) {
        if let Some(changed) = watcher.wait(Duration::from_millis(100)) {
            return Some(changed);
        }
    }
    None
}

fn stopped(printer: &Printer) -> Outcome {
    if printer.format == MessageFormat::Human {
        eprintln!("stopped");
    }
    Outcome::Ok
}

/// What a render wrote, or why not.
type Rendered = Result<(Duration, Vec<PathBuf>), String>;

fn render(live: &mut LiveScene, dir: &Path) -> Rendered {
    let started = Instant::now();
    let images = live.render_all().map_err(|e| format!("error: {e}"))?;
    let elapsed = started.elapsed();
    let mut written = Vec::new();
    for (view, image) in images {
        let path = dir.join(format!("{view}.png"));
        write_atomically(&path, &image).map_err(|e| format!("error: cannot write `{}`: {e}", path.display()))?;
        written.push(path);
    }
    Ok((elapsed, written))
}

/// Writes beside the target, then renames over it: a reader never sees half a PNG.
fn write_atomically(path: &Path, image: &image::RgbaImage) -> Result<(), String> {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let temp = path.with_file_name(format!(".{name}.partial"));
    image.save_with_format(&temp, image::ImageFormat::Png).map_err(|e| e.to_string())?;
    std::fs::rename(&temp, path).map_err(|e| e.to_string())
}

/// One line per rebuild: what changed, compose time, what was recompiled, render time; or why
/// nothing was written. JSON mode prints it as one object on stdout.
fn report(printer: &Printer, changed: &[PathBuf], rebuild: Option<&Rebuild>, rendered: &Rendered) {
    let names: Vec<String> = changed.iter().map(|p| display_name(p)).collect();
    let compose_ms = rebuild.map(|r| r.compose.as_secs_f64() * 1e3);
    let applied = rebuild.and_then(|r| r.outcome.as_ref().ok());
    let recompiled: Vec<&str> = applied.map(|a| a.recompiled.iter().map(String::as_str).collect()).unwrap_or_default();
    let compiled = applied.map_or(0, |a| a.compiled);
    let cache_hit = applied.map(|a| !a.composed);
    match printer.format {
        MessageFormat::Json => {
            let (ok, render_ms, images, error) = match rendered {
                Ok((t, images)) => (true, Some(t.as_secs_f64() * 1e3), images.clone(), None),
                Err(e) => (false, None, Vec::new(), Some(e.clone())),
            };
            let line = serde_json::json!({
                "event": if rebuild.is_some() { "rebuild" } else { "render" },
                "ok": ok,
                "changed": names,
                "compose_ms": compose_ms,
                "cache_hit": cache_hit,
                "recompiled_views": recompiled,
                "pipelines_compiled": compiled,
                "render_ms": render_ms,
                "images": images,
                "error": error,
            });
            println!("{line}");
        }
        MessageFormat::Human => {
            let what =
                if names.is_empty() { "first render".to_string() } else { format!("{} changed", names.join(", ")) };
            let compose = match (compose_ms, cache_hit) {
                (Some(ms), Some(true)) => format!("; composed in {ms:.1} ms (cache hit)"),
                (Some(ms), _) => format!("; composed in {ms:.1} ms"),
                _ => String::new(),
            };
            let pipelines = match (rebuild.is_some(), compiled) {
                (false, _) => String::new(),
                (true, 0) => "; no pipeline compiled".to_string(),
                (true, n) => format!("; {n} pipeline(s) compiled ({})", recompiled.join(", ")),
            };
            match rendered {
                Ok((t, images)) => eprintln!(
                    "{what}{compose}{pipelines}; rendered {} view(s) in {:.0} ms",
                    images.len(),
                    t.as_secs_f64() * 1e3
                ),
                Err(e) => {
                    eprintln!("{e}");
                    eprintln!("{what}{compose}: not rendered; the last good images stay");
                }
            }
        }
    }
}

fn display_name(path: &Path) -> String {
    let cwd = std::env::current_dir().ok().and_then(|d| d.canonicalize().ok());
    match cwd.as_ref().and_then(|d| path.strip_prefix(d).ok()) {
        Some(relative) => relative.display().to_string(),
        None => path.display().to_string(),
    }
}
