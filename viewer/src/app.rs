//! The event loop of `vrsc view`: winit events into egui, file changes into rebuilds, and each
//! frame's GPU work submitted without waiting for it.

use crate::panel::{self, Layout, ViewSlot};
use crate::side::SidePanel;
use crate::window::Surface;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};
use vrs_live::{FileWatcher, GpuWaiter, LiveScene, ViewFrames};
use vrs_runtime::{RenderOptions, SceneRenderer};
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop, EventLoopProxy};
use winit::window::{Window, WindowId};

/// What `vrsc view` was asked to open.
#[derive(Clone, Debug)]
pub struct ViewerOptions {
    /// The scene file (`.toml`) to show.
    pub scene: PathBuf,
    /// Only the software adapter (lavapipe).
    pub software: bool,
    /// The interactive frame budget for all views together.
    pub budget: Duration,
}

/// Opens the window and runs until it is closed. Errors are the scene's diagnostics or why no
/// window or device could be had.
pub fn run(options: ViewerOptions) -> Result<(), String> {
    let event_loop = EventLoop::<Wake>::with_user_event().build().map_err(|e| format!("no display: {e}"))?;
    let mut app = App { options, proxy: event_loop.create_proxy(), running: None, error: None };
    event_loop.run_app(&mut app).map_err(|e| e.to_string())?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// How long the loop sleeps between looks at bricks being loaded: the loader threads do not
/// wake the window, so it looks again after this (short enough that bricks show as they come,
/// long enough not to spin).
const BRICK_POLL: Duration = Duration::from_millis(30);

/// Sent from the file watcher's and the GPU waiter's threads: something is ready to show.
#[derive(Clone, Copy, Debug)]
pub struct Wake;

struct App {
    options: ViewerOptions,
    proxy: EventLoopProxy<Wake>,
    running: Option<Running>,
    error: Option<String>,
}

/// Everything of an open window.
struct Running {
    surface: Surface,
    egui: egui::Context,
    input: egui_winit::State,
    live: LiveScene,
    watcher: FileWatcher,
    waiter: GpuWaiter,
    slots: Vec<ViewSlot>,
    layout: Layout,
    side: SidePanel,
    status: String,
    /// When to draw again without an event (bricks loading).
    wake_at: Option<Instant>,
    /// When the scene was last loaded, and which views have not shown its full picture yet
    /// (each says so on the terminal when it does).
    loaded: (Instant, Vec<bool>),
}

impl ApplicationHandler<Wake> for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        match self.open(event_loop) {
            Ok(running) => self.running = Some(running),
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn user_event(&mut self, _: &ActiveEventLoop, _: Wake) {
        if let Some(r) = &self.running {
            r.surface.window.request_redraw();
        }
    }

    /// Sleeps until the next event, or until the time a redraw was asked for.
    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        let Some(r) = &mut self.running else { return };
        match r.wake_at {
            Some(at) if Instant::now() >= at => {
                r.wake_at = None;
                r.surface.window.request_redraw();
                event_loop.set_control_flow(ControlFlow::Wait);
            }
            Some(at) => event_loop.set_control_flow(ControlFlow::WaitUntil(at)),
            None => event_loop.set_control_flow(ControlFlow::Wait),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(r) = &mut self.running else { return };
        let response = r.input.on_window_event(&r.surface.window, &event);
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => r.surface.resize(size.width, size.height),
            WindowEvent::RedrawRequested => r.frame(),
            _ => {}
        }
        if response.repaint {
            r.surface.window.request_redraw();
        }
    }
}

impl App {
    fn open(&self, event_loop: &ActiveEventLoop) -> Result<Running, String> {
        let title = format!("vrsc view — {}", self.options.scene.display());
        let attributes =
            Window::default_attributes().with_title(title).with_inner_size(winit::dpi::LogicalSize::new(1100.0, 640.0));
        let window = Arc::new(event_loop.create_window(attributes).map_err(|e| format!("cannot open a window: {e}"))?);
        let descriptor =
            wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(event_loop.owned_display_handle()));
        let instance = wgpu::Instance::new(descriptor);
        let surface = Surface::new(&instance, window.clone(), self.options.software)?;
        eprintln!("rendering on {}", surface.gpu.adapter);
        let renderer =
            SceneRenderer::open(surface.gpu.clone(), &self.options.scene, RenderOptions::default(), &mut |_, _, _| {})
                .map_err(|e| e.to_string())?;
        renderer.notices.iter().for_each(|n| eprintln!("note: {n}"));
        let live = LiveScene::new(renderer);
        let proxy = self.proxy.clone();
        let mut watcher = FileWatcher::new(move || {
            let _ = proxy.send_event(Wake);
        })
        .map_err(|e| format!("cannot watch the scene's files: {e}"))?;
        watcher.watch(live.files()).map_err(|e| format!("cannot watch the scene's files: {e}"))?;
        let proxy = self.proxy.clone();
        let waiter = GpuWaiter::new(surface.gpu.device.clone(), move || {
            let _ = proxy.send_event(Wake);
        });
        let egui = egui::Context::default();
        let input = egui_winit::State::new(
            egui.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(surface.gpu.device.limits().max_texture_dimension_2d as usize),
        );
        let mut running = Running {
            surface,
            egui,
            input,
            live,
            watcher,
            waiter,
            slots: Vec::new(),
            layout: Layout::Tiles,
            side: SidePanel::default(),
            status: "watching the scene's files".into(),
            wake_at: None,
            loaded: (Instant::now(), Vec::new()),
        };
        running.sync_slots(self.options.budget);
        Ok(running)
    }
}

impl Running {
    /// One view slot per view of the scene, each with its share of the frame budget.
    fn sync_slots(&mut self, budget: Duration) {
        let names = self.live.view_names();
        let share = budget / names.len().max(1) as u32;
        if self.slots.iter().map(|s| &s.name).ne(names.iter()) {
            let old = std::mem::take(&mut self.slots);
            for name in names {
                let slot = old.iter().position(|s| s.name == name);
                self.slots.push(match slot {
                    Some(i) => old[i].clone_for(&name),
                    None => ViewSlot::new(name, ViewFrames::new(share)),
                });
            }
        }
    }

    fn frame(&mut self) {
        let now = Instant::now();
        self.follow_files();
        let raw = self.input.take_egui_input(&self.surface.window);
        let egui = self.egui.clone();
        let output = egui.run_ui(raw, |ui| {
            panel::show(ui, &mut self.live, &mut self.slots, &mut self.layout, &mut self.side, &self.status, now);
        });
        for (index, slot) in self.slots.iter_mut().enumerate() {
            slot.update_probe(&self.egui, &mut self.live, index, now);
        }
        self.input.handle_platform_output(&self.surface.window, output.platform_output.clone());
        let mut frames: Vec<&mut ViewFrames> = self.slots.iter_mut().map(|s| &mut s.frames).collect();
        if let Some((index, e)) = ViewFrames::step_views(&mut frames, &mut self.live, &self.waiter, now) {
            self.status = format!("view `{}`: {e}", self.slots[index].name);
        }
        let mut busy = false;
        for (index, slot) in self.slots.iter_mut().enumerate() {
            slot.show(&mut self.surface, &self.live, index);
            busy |= slot.frames.busy();
        }
        self.announce_full_pictures(now);
        self.stream_bricks(now);
        let capture = self.egui.input(|i| panel::pressed(i, egui::Key::E, true)).then(|| self.window_png());
        if let (Some(path), Some(result)) = (&capture, self.surface.paint(&self.egui, output, capture.as_deref())) {
            self.status = match result {
                Ok([w, h]) => format!("window exported ({w}x{h}) to {}", path.display()),
                Err(e) => format!("window export failed: {e}"),
            };
            eprintln!("{}", self.status);
        }
        // Work in flight wakes the loop when it finishes; work held back while the user
        // interacts needs a look once input has settled.
        if busy {
            let settle = self.slots.iter().map(|s| s.frames.refiner().settle).max().unwrap_or_default();
            self.egui.request_repaint_after(settle);
            self.surface.window.request_redraw();
        }
    }

    /// Where Shift+E writes the window: `SCENE-window.png` beside the scene.
    fn window_png(&self) -> std::path::PathBuf {
        let scene = self.live.renderer().path();
        let stem = scene.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "scene".into());
        scene.with_file_name(format!("{stem}-window.png"))
    }

    /// Says on the terminal when each view first shows the full picture of the scene as loaded:
    /// how long after the load it took, so that a user (and the window test) sees cheap views
    /// settle first.
    fn announce_full_pictures(&mut self, now: Instant) {
        let (loaded_at, waiting) = &mut self.loaded;
        waiting.resize(self.slots.len(), true);
        for (slot, waiting) in self.slots.iter().zip(waiting.iter_mut()) {
            if *waiting && slot.frames.refiner().quality() == vrs_live::Quality::Full {
                *waiting = false;
                let [w, h] = slot.frames.refiner().full_size();
                let ms = now.saturating_duration_since(*loaded_at).as_secs_f64() * 1e3;
                eprintln!("view `{}`: full {w}×{h} picture {ms:.0} ms after the scene loaded", slot.name);
            }
        }
    }

    /// Places the bricks that arrived for the frames just submitted and asks for those they
    /// need; while bricks are on their way the loop draws again after [`BRICK_POLL`].
    fn stream_bricks(&mut self, now: Instant) {
        if let Err(e) = self.live.stream_bricks() {
            self.status = format!("bricks: {e}");
        }
        self.wake_at = self.live.bricks_busy().then(|| now + BRICK_POLL);
    }

    /// Rebuilds after a change of the scene's files; the window and the terminal get the same
    /// diagnostics.
    fn follow_files(&mut self) {
        let Some(changed) = self.watcher.changes() else { return };
        let rebuild = self.live.rebuild();
        let names: Vec<String> =
            changed.iter().filter_map(|p| p.file_name()).map(|n| n.to_string_lossy().into_owned()).collect();
        self.status = match &rebuild.outcome {
            Ok(applied) => {
                let pipelines = match applied.compiled {
                    0 => "no pipeline compiled".to_string(),
                    n => format!("{n} pipeline(s) compiled"),
                };
                format!(
                    "{} changed: composed in {:.1} ms{}, {pipelines}",
                    names.join(", "),
                    rebuild.compose.as_secs_f64() * 1e3,
                    if applied.composed { "" } else { " (cache hit)" }
                )
            }
            Err(_) => format!("{} changed: errors, showing the last good picture", names.join(", ")),
        };
        eprintln!("{}", self.status);
        if let Some(text) = rebuild.error_text() {
            eprintln!("{text}");
        }
        let budget: Duration = self.slots.iter().map(|s| s.frames.refiner().budget).sum();
        self.sync_slots(budget);
        if rebuild.outcome.is_ok() {
            self.loaded = (Instant::now(), Vec::new());
        }
        let _ = self.watcher.watch(self.live.files());
    }
}
