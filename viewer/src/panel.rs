//! What the window shows: every view (tiled or in tabs) with its frame time and quality, the
//! status line, and the diagnostics of a broken edit over the last good picture.

use crate::crosshair;
use crate::handles::{self, HandleDrag, Marker};
use crate::navigate;
use crate::side::SidePanel;
use crate::window::Surface;
use egui::{Color32, Rect, Sense, Vec2};
use std::time::Instant;
use vrs_live::{LiveScene, Quality, ViewFrames, Work};
use vrs_runtime::SliceAxis;
use vrs_runtime::geometry::{PatientBox, volume_to_world};
use vrs_runtime::scene::BrickProgress;

/// How views share the window.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    Tiles,
    /// One view at a time, by index.
    Tab(usize),
}

/// A view's place in the window: its frames and the egui texture that shows them.
pub struct ViewSlot {
    pub name: String,
    pub frames: ViewFrames,
    /// The egui texture id, and the wgpu texture it currently shows.
    texture: Option<(egui::TextureId, wgpu::Texture)>,
    /// The state field shown instead of the picture, if any.
    pub probe: Option<ProbeView>,
    /// The mesh point being dragged in this (slice) view, and where the cursor last set it.
    drag: Option<(HandleDrag, egui::Pos2)>,
    /// What the last export (E) said, and when: shown in the caption for a while.
    exported: Option<(Instant, String)>,
    /// The fields the `show:` menu lists (name, type), and the hashes of the view's shaders
    /// they were found for: composed again only when a shader changed.
    fields: Option<(String, Vec<(String, String)>)>,
}

/// A probe shown in a view's place: the field, and its image once rendered.
pub struct ProbeView {
    pub field: String,
    /// The image, its legend, and the view generation it shows.
    pub shown: Option<(egui::TextureHandle, String, u64)>,
    /// Why the last probe could not be rendered.
    pub error: Option<String>,
}

impl ViewSlot {
    pub fn new(name: String, frames: ViewFrames) -> ViewSlot {
        ViewSlot { name, frames, texture: None, probe: None, drag: None, exported: None, fields: None }
    }

    /// The same view after a reload: the schedule starts again, the texture id and the probe
    /// (rendered again) are kept.
    pub fn clone_for(&self, name: &str) -> ViewSlot {
        let budget = self.frames.refiner().budget;
        let probe = self.probe.as_ref().map(|p| ProbeView { field: p.field.clone(), shown: None, error: None });
        let (frames, texture) = (ViewFrames::new(budget), self.texture.clone());
        ViewSlot { name: name.to_string(), frames, texture, probe, drag: None, exported: None, fields: None }
    }

    /// Renders the probe again when the view changed and the user is not interacting (a probe
    /// is a full-resolution render that the window waits for).
    pub fn update_probe(&mut self, ctx: &egui::Context, live: &mut LiveScene, index: usize, now: Instant) {
        let Some(probe) = &mut self.probe else { return };
        let generation = live.generation(index);
        let current = probe.shown.as_ref().is_some_and(|(_, _, g)| *g == generation);
        if current || self.frames.refiner().interacting(now) || probe.error.is_some() {
            return;
        }
        match live.render_probe(index, &vrs_runtime::ProbeSpec::of(probe.field.clone())) {
            Ok(image) => {
                let size = [image.image.width() as usize, image.image.height() as usize];
                let colours = egui::ColorImage::from_rgba_unmultiplied(size, image.image.as_raw());
                let texture = ctx.load_texture(format!("probe {index}"), colours, egui::TextureOptions::LINEAR);
                probe.shown = Some((texture, image.legend(), generation));
            }
            Err(e) => probe.error = Some(e.to_string()),
        }
    }

    /// Points the view's egui texture at the picture to show now (no copy: egui samples the
    /// view's own texture).
    pub fn show(&mut self, surface: &mut Surface, live: &LiveScene, index: usize) {
        let Some(shown) = self.frames.shown(live, index) else { return };
        let view = shown.texture.create_view(&Default::default());
        let device = &surface.gpu.device;
        let filter = wgpu::FilterMode::Linear;
        match &self.texture {
            Some((_, texture)) if texture == shown.texture => {}
            Some((id, _)) => {
                surface.painter.update_egui_texture_from_wgpu_texture(device, &view, filter, *id);
                self.texture = Some((*id, shown.texture.clone()));
            }
            None => {
                let id = surface.painter.register_native_texture(device, &view, filter);
                self.texture = Some((id, shown.texture.clone()));
            }
        }
    }
}

/// The colour of the renderer's notices in the status bar: amber, read before the status.
const NOTICE_COLOUR: Color32 = Color32::from_rgb(230, 180, 90);

/// Lays out the whole window for one frame and applies the user's input to the views.
pub fn show(
    ui: &mut egui::Ui,
    live: &mut LiveScene,
    slots: &mut [ViewSlot],
    layout: &mut Layout,
    side: &mut SidePanel,
    status: &str,
    now: Instant,
) {
    let raycast_views = (0..slots.len()).filter(|&i| live.camera(i).is_some()).count();
    egui::Panel::top("toolbar").show(ui, |ui| toolbar(ui, slots, layout, side, raycast_views > 1));
    egui::Panel::bottom("status").show(ui, |ui| {
        ui.label(status);
        notices(ui, &live.renderer().notices);
        if let Some(progress) = live.brick_progress() {
            ui.weak(brick_line(&progress));
        }
    });
    if let Some(error) = live.last_error() {
        diagnostics(ui.ctx(), error);
    }
    if side.show(ui, live) {
        slots.iter_mut().for_each(|s| s.frames.input(now));
    }
    egui::CentralPanel::default().show(ui, |ui| {
        let area = ui.available_rect_before_wrap();
        let shown: Vec<usize> = match *layout {
            Layout::Tiles => (0..slots.len()).collect(),
            Layout::Tab(i) => vec![i.min(slots.len().saturating_sub(1))],
        };
        let cells = tiles(area, shown.len());
        let pixels_per_point = ui.ctx().pixels_per_point();
        let mut moved = false;
        for (&index, cell) in shown.iter().zip(cells) {
            moved |= view_cell(ui, live, &mut slots[index], index, cell, pixels_per_point, now);
        }
        // A dragged mesh point is a uniform: every view shows it.
        if moved {
            slots.iter_mut().for_each(|s| s.frames.input(now));
        }
    });
}

/// A broken edit's diagnostics, whole (up to a scrolled height), over the lower left of the
/// views: the views keep their size, so nothing renders again for it, and no line (the caret's)
/// is cut off by a panel's height.
fn diagnostics(ctx: &egui::Context, error: &str) {
    egui::Area::new(egui::Id::NULL.with("diagnostics"))
        .anchor(egui::Align2::LEFT_BOTTOM, Vec2::new(8.0, -34.0))
        .order(egui::Order::Foreground)
        .show(ctx, |ui| {
            egui::Frame::popup(ui.style()).show(ui, |ui| {
                egui::ScrollArea::vertical().max_height(ctx.content_rect().height() * 0.5).show(ui, |ui| {
                    ui.label(egui::RichText::new(error).monospace().color(Color32::from_rgb(255, 110, 100)));
                });
            });
        });
}

/// The renderer's notices, each a line: what the terminal says at load (a phantom standing in
/// for an absent file, an automatic window, rays cut short), in the window too.
pub fn notices(ui: &mut egui::Ui, notices: &[String]) {
    for notice in notices {
        ui.colored_label(NOTICE_COLOUR, format!("note: {notice}"));
    }
}

/// The residency of the scene's bricked volumes in one line, e.g. `bricks: 65 of 512 slots
/// resident · 12 loading · 3 requested · 227 of one value`.
pub fn brick_line(progress: &BrickProgress) -> String {
    let r = progress.residency;
    let mut line = format!("bricks: {} of {} slots resident", r.resident, r.slots);
    if r.pending > 0 {
        line += &format!(" · {} loading", r.pending);
    }
    if progress.asked > 0 {
        line += &format!(" · {} requested", progress.asked);
    }
    line += &format!(" · {} of one value", r.constant);
    if r.floor > 0 {
        // The pictures ask for more than the pool holds: they show a coarser level throughout.
        line += &format!(" · level {} and coarser shown (memory budget)", r.floor);
    } else if r.refused > 0 {
        // The pool is full: the rays show those parts from a coarser level.
        line += " · memory budget full, parts shown coarser";
    }
    line
}

/// Where the window keeps whether the 3D views' cameras are linked (toolbar, L).
fn linked_cameras_id() -> egui::Id {
    egui::Id::NULL.with("linked 3D cameras")
}

/// Whether a camera change in one 3D view moves every 3D view.
fn cameras_linked(ctx: &egui::Context) -> bool {
    ctx.data(|d| d.get_temp::<bool>(linked_cameras_id())).unwrap_or(false)
}

/// Gives every other 3D view the camera of view `index` (linked cameras); whether any changed.
fn follow_camera(live: &mut LiveScene, index: usize) -> bool {
    let Some(camera) = live.camera(index) else { return false };
    let mut moved = false;
    for other in (0..live.view_names().len()).filter(|&j| j != index) {
        if live.camera(other).is_some_and(|c| c != camera) {
            live.set_camera(other, camera);
            moved = true;
        }
    }
    moved
}

/// The toolbar: the panel, the layout, linked cameras (`linkable`: the scene has several 3D
/// views) and the keys.
fn toolbar(ui: &mut egui::Ui, slots: &[ViewSlot], layout: &mut Layout, side: &mut SidePanel, linkable: bool) {
    ui.horizontal(|ui| {
        ui.toggle_value(&mut side.open, "Panel");
        ui.separator();
        ui.selectable_value(layout, Layout::Tiles, "All views");
        for (i, slot) in slots.iter().enumerate() {
            ui.selectable_value(layout, Layout::Tab(i), &slot.name);
        }
        if linkable {
            ui.separator();
            let mut linked = cameras_linked(ui.ctx());
            // L toggles it, unless a text field has the keyboard.
            let typing = ui.ctx().memory(|m| m.focused().is_some());
            linked ^= !typing && ui.input(|i| i.key_pressed(egui::Key::L));
            ui.toggle_value(&mut linked, "Link 3D (L)")
                .on_hover_text("Orbiting, panning or zooming one 3D view moves every 3D view the same way");
            ui.ctx().data_mut(|d| d.insert_temp(linked_cameras_id(), linked));
        }
        ui.separator();
        // The keys are in their own window (F1 or ?): a hint line did not fit the toolbar.
        let id = egui::Id::NULL.with("keyboard help");
        let mut open = ui.ctx().data(|d| d.get_temp::<bool>(id)).unwrap_or(false);
        let asked = ui.input(|i| {
            i.key_pressed(egui::Key::F1) || i.events.iter().any(|e| matches!(e, egui::Event::Text(t) if t == "?"))
        });
        open ^= asked;
        ui.toggle_value(&mut open, "Keys (F1)").on_hover_text("The mouse and the keys in the views");
        navigate::keys_window(ui.ctx(), &mut open);
        ui.ctx().data_mut(|d| d.insert_temp(id, open));
    });
}

/// `n` cells filling `area`, in a grid as square as the count allows.
fn tiles(area: Rect, n: usize) -> Vec<Rect> {
    let columns = (n as f32).sqrt().ceil().max(1.0) as usize;
    let rows = n.div_ceil(columns).max(1);
    let size = Vec2::new(area.width() / columns as f32, area.height() / rows as f32);
    (0..n)
        .map(|i| {
            let min = area.min + Vec2::new((i % columns) as f32 * size.x, (i / columns) as f32 * size.y);
            Rect::from_min_size(min, size).shrink(2.0)
        })
        .collect()
}

/// Draws view `index` in `cell` and applies the user's input to it. Returns whether a dragged
/// mesh point moved (a uniform every view may read).
fn view_cell(
    ui: &mut egui::Ui,
    live: &mut LiveScene,
    slot: &mut ViewSlot,
    index: usize,
    cell: Rect,
    pixels_per_point: f32,
    now: Instant,
) -> bool {
    let caption_height = 18.0;
    let mut image = Rect::from_min_max(cell.min + Vec2::new(0.0, caption_height), cell.max);
    let is_slice = live.slice(index).is_some();
    if is_slice {
        // A slice maps the unit square of the plane to the image: keep it square.
        let side = image.width().min(image.height());
        image = Rect::from_center_size(image.center(), Vec2::splat(side));
    }
    let size = [(image.width() * pixels_per_point) as u32, (image.height() * pixels_per_point) as u32];
    // A size the device cannot hold keeps the last size and picture (drawn scaled), and says so.
    let refused = (size[0] >= 8 && size[1] >= 8).then(|| live.set_size(index, size).err()).flatten();
    let response = ui.interact(image, ui.scope_id().with(("view", index)), Sense::click_and_drag());
    let mut moved = is_slice && drag_handle(ui, live, slot, index, image, &response);
    if is_slice
        && slot.drag.is_none()
        && response.clicked_by(egui::PointerButton::Primary)
        && let Some(at) = response.interact_pointer_pos()
    {
        moved |= cross_at(live, index, image_coords(at, image));
    }
    let mut changed = handle_input(ui, live, index, &response);
    if is_slice {
        response.context_menu(|ui| changed |= window_menu(ui, live, index));
    }
    if changed || moved {
        slot.frames.input(now);
    }
    // Linked cameras: the other 3D views follow, and are interacted with too.
    moved |= changed && cameras_linked(ui.ctx()) && follow_camera(live, index);
    ui.painter().rect_filled(image, 0.0, Color32::from_gray(12));
    let uv = Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0));
    let probe = slot.probe.as_ref().and_then(|p| p.shown.as_ref());
    match (probe, &slot.texture) {
        (Some((texture, _, _)), _) => {
            ui.painter().image(texture.id(), image, uv, Color32::WHITE);
        }
        (None, Some((id, _))) => {
            ui.painter().image(*id, image, uv, Color32::WHITE);
        }
        (None, None) => {}
    }
    paint_slice_labels(ui, live, index, image);
    if is_slice {
        paint_cuts(ui, live, index, image);
        let grabbed = slot.drag.as_ref().map(|(drag, _)| drag.uniform.as_str());
        paint_markers(ui, &handles::slice_markers(live, index), image, grabbed, &response);
    }
    if let Some(p) = &slot.probe {
        let legend = match (&p.error, &p.shown) {
            (Some(e), _) => e.clone(),
            (None, Some((_, legend, _))) => legend.clone(),
            (None, None) => format!("probing `{}`…", p.field),
        };
        let at = image.left_bottom() + Vec2::new(4.0, -4.0);
        let font = egui::FontId::monospace(11.0);
        ui.painter().text(at, egui::Align2::LEFT_BOTTOM, legend, font, Color32::from_rgb(255, 230, 150));
    }
    // E exports the view under the mouse; Shift+E, the whole window (app.rs).
    if response.hovered() && ui.input(|i| pressed(i, egui::Key::E, false)) {
        slot.exported = Some((now, export(live, index)));
    }
    let recent = slot.exported.as_ref().filter(|(at, _)| now.duration_since(*at) < EXPORT_SHOWN);
    let caption = match (refused, recent) {
        (Some(e), _) => format!("{} — {e}", slot.name),
        (None, Some((_, said))) => format!("{} — {said}", slot.name),
        (None, None) => format!("{} — {}", slot.name, describe(&slot.frames, size)),
    };
    let menu = Rect::from_min_max(
        egui::pos2(cell.max.x - 150.0, cell.min.y),
        egui::pos2(cell.max.x, cell.min.y + caption_height),
    );
    // Clipped to its own cell, left of the probe menu: two views' captions never run together.
    let caption_area = Rect::from_min_max(cell.min, egui::pos2(menu.left() - 4.0, menu.bottom()));
    let font = egui::FontId::proportional(13.0);
    ui.painter_at(caption_area).text(cell.min, egui::Align2::LEFT_TOP, caption, font, Color32::LIGHT_GRAY);
    ui.scope_builder(egui::UiBuilder::new().max_rect(menu), |ui| probe_menu(ui, live, slot, index));
    moved
}

/// The letters of the patient's directions at a slice view's edges and its position in its
/// corner (nothing for a raycast view).
fn paint_slice_labels(ui: &egui::Ui, live: &LiveScene, index: usize, image: Rect) {
    if let Some([left, right, top, bottom]) = live.renderer().slice_geometry(index).map(|g| g.edge_labels()) {
        // The patient's directions at the image's edges (radiological or neurological).
        let font = egui::FontId::proportional(15.0);
        let colour = Color32::from_rgb(120, 220, 255);
        let painter = ui.painter();
        painter.text(image.left_center() + Vec2::new(6.0, 0.0), egui::Align2::LEFT_CENTER, left, font.clone(), colour);
        painter.text(
            image.right_center() - Vec2::new(6.0, 0.0),
            egui::Align2::RIGHT_CENTER,
            right,
            font.clone(),
            colour,
        );
        painter.text(image.center_top() + Vec2::new(0.0, 6.0), egui::Align2::CENTER_TOP, top, font.clone(), colour);
        painter.text(image.center_bottom() - Vec2::new(0.0, 6.0), egui::Align2::CENTER_BOTTOM, bottom, font, colour);
    }
    if let (Some(plane), Some((dims, grid_to_world))) = (live.slice(index), live.renderer().primary_grid())
        && let Some(position) = navigate::slice_position_text(&plane, dims, grid_to_world)
    {
        // Where the slice is, in the image's corner as reading software puts it, and the
        // view's window above it.
        let at = image.right_bottom() - Vec2::new(6.0, 6.0);
        let font = egui::FontId::proportional(13.0);
        let text = match view_window_text(live, index) {
            Some(window) => format!("{window}\n{position}"),
            None => position,
        };
        ui.painter().text(at, egui::Align2::RIGHT_BOTTOM, text, font, Color32::from_rgb(120, 220, 255));
    }
}

/// Window/level by a right (or middle) drag in a slice view, as in 3D Slicer's window/level
/// mode: across widens (right) or narrows (left) the primary volume's transfer function, down
/// raises its level (a drag over the view's height moves it by its width). The transfer function
/// is the volume's, so every view of the volume follows. Whether it changed.
fn window_level(live: &mut LiveScene, index: usize, drag: glam::Vec2, height: f32) -> bool {
    let Some((name, window, curve)) = view_curve(live, index, true) else { return false };
    let (shift, scale) = navigate::window_level_change(drag, height, window[1] - window[0]);
    live.set_view_tf_curve(index, &name, curve.window_levelled(window, shift, scale)).is_ok()
}

/// The primary volume as view `index` shows it: its name, its window (the data values of its
/// texture) and the curve the view uses: its own (unless `own` is false), else the volume's,
/// else a grey ramp.
fn view_curve(live: &LiveScene, index: usize, own: bool) -> Option<(String, [f32; 2], vrs_runtime::tf::TfCurve)> {
    let primary = live.renderer().volumes().into_iter().next()?;
    let name = primary.name.to_string();
    let curve = live
        .view_tf_curve(index, &name)
        .filter(|_| own)
        .or(primary.curve)
        .cloned()
        .or_else(|| vrs_runtime::tf::preset_curve("grayscale").ok())?;
    Some((name, primary.window, curve))
}

/// The window view `index` shows the primary volume through, as reading software writes it.
fn view_window_text(live: &LiveScene, index: usize) -> Option<String> {
    let primary = live.renderer().volumes().into_iter().next()?;
    // No curve: the grey ramp over the volume's window.
    let curve = live.view_tf_curve(index, primary.name).or(primary.curve);
    Some(navigate::window_text(curve.map_or(primary.window, |c| c.data_domain(primary.window))))
}

/// Puts slice view `index` on CT window `preset` of [`navigate::CT_WINDOWS`] (from the volume's
/// curve), or with `None` back on the volume's own transfer function; whether it changed.
fn window_preset(live: &mut LiveScene, index: usize, preset: Option<usize>) -> bool {
    let Some((name, window, base)) = view_curve(live, index, false) else { return false };
    let Some(preset) = preset else { return live.reset_view_tf_curve(index, &name).is_ok() };
    let Some(&(_, level, width)) = navigate::CT_WINDOWS.get(preset) else { return false };
    live.set_view_tf_curve(index, &name, navigate::windowed_at(&base, window, level, width)).is_ok()
}

/// The right-click menu of a slice view: the CT windows and the volume's own.
fn window_menu(ui: &mut egui::Ui, live: &mut LiveScene, index: usize) -> bool {
    let mut changed = false;
    for (k, (label, level, width)) in navigate::CT_WINDOWS.iter().enumerate() {
        if ui.button(format!("{}  {label} (W {width} L {level})", k + 1)).clicked() {
            changed |= window_preset(live, index, Some(k));
            ui.close();
        }
    }
    ui.separator();
    if ui.button("0  The volume's window").clicked() {
        changed |= window_preset(live, index, None);
        ui.close();
    }
    changed
}

/// Whether `key` went down this frame with Shift held (`shift`) or not: the modifiers the key
/// event carries, which a synthetic event (xdotool's `shift+e`) sets without a separate
/// modifier change.
pub fn pressed(input: &egui::InputState, key: egui::Key, shift: bool) -> bool {
    input.events.iter().any(|e| {
        matches!(e, egui::Event::Key { key: k, pressed: true, repeat: false, modifiers, .. }
            if *k == key && modifiers.shift == shift)
    })
}

/// How long a view's caption says where its export went.
const EXPORT_SHOWN: std::time::Duration = std::time::Duration::from_secs(6);

/// Exports view `index` as `vrsc render` would write it, beside the scene file as
/// `SCENE-VIEW.png`; what to say of it.
fn export(live: &mut LiveScene, index: usize) -> String {
    let scene = live.renderer().path().to_path_buf();
    let name = live.renderer().views().get(index).map(|v| v.name.clone()).unwrap_or_default();
    let stem = scene.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "scene".into());
    let path = scene.with_file_name(format!("{stem}-{name}.png"));
    let said = match live.export_view(index, &path) {
        Ok([w, h]) => format!("exported {w}x{h} to {}", path.display()),
        Err(e) => format!("export failed: {e}"),
    };
    eprintln!("view `{name}`: {said}");
    said
}

/// The colour of the crosshair: where the other slice views cut a slice view.
const CROSSHAIR: Color32 = Color32::from_rgba_premultiplied(200, 180, 60, 160);

/// Moves every other slice view's plane through the point under `pixel` of slice view `index`
/// (the crosshair); whether any moved.
fn cross_at(live: &mut LiveScene, index: usize, pixel: glam::Vec2) -> bool {
    let (Some(point), Some(patient)) =
        (live.renderer().slice_geometry(index).map(|g| g.pixel_to_world(pixel.to_array())), primary_box(live))
    else {
        return false;
    };
    let others = other_slices(live, index);
    let planes: Vec<_> = others.iter().map(|(_, p)| *p).collect();
    let mut changed = false;
    for ((j, before), after) in others.into_iter().zip(crosshair::through(point, &planes, &patient)) {
        if after != before {
            live.set_slice(j, after);
            changed = true;
        }
    }
    changed
}

/// The planes of the slice views other than view `index`, with their view indices.
fn other_slices(live: &LiveScene, index: usize) -> Vec<(usize, vrs_runtime::SlicePlane)> {
    (0..live.renderer().views().len()).filter(|&j| j != index).filter_map(|j| Some((j, live.slice(j)?))).collect()
}

/// The primary volume's box in patient space, which slice planes are placed in.
fn primary_box(live: &LiveScene) -> Option<PatientBox> {
    let (dims, grid_to_world) = live.renderer().primary_grid()?;
    Some(PatientBox::of(volume_to_world(dims, grid_to_world)))
}

/// Lines where the other slice views cut slice view `index`'s image.
fn paint_cuts(ui: &egui::Ui, live: &LiveScene, index: usize, image: Rect) {
    let geometry = live.renderer().slice_geometry(index);
    let corner = |x: f32, y: f32| Some(geometry?.pixel_to_world([x, y]));
    let (Some(top_left), Some(top_right), Some(bottom_left), Some(patient)) =
        (corner(0.0, 0.0), corner(1.0, 0.0), corner(0.0, 1.0), primary_box(live))
    else {
        return;
    };
    let others: Vec<_> = other_slices(live, index).into_iter().map(|(_, plane)| plane).collect();
    let painter = ui.painter_at(image);
    let stroke = egui::Stroke::new(1.0, CROSSHAIR);
    for cut in crosshair::cuts([top_left, top_right, bottom_left], &others, &patient) {
        let points = match cut {
            crosshair::Cut::Vertical(x) => {
                let x = image.left() + x * image.width();
                [egui::pos2(x, image.top()), egui::pos2(x, image.bottom())]
            }
            crosshair::Cut::Horizontal(y) => {
                let y = image.top() + y * image.height();
                [egui::pos2(image.left(), y), egui::pos2(image.right(), y)]
            }
        };
        painter.line_segment(points, stroke);
    }
}

/// The colour of the markers of mesh points in slice views.
const MARKER: Color32 = Color32::from_rgb(60, 255, 120);

/// A ring at each mesh point a slice view can drag, filled when the point lies in the slice;
/// larger under the pointer and while dragged, with a grab cursor.
fn paint_markers(ui: &egui::Ui, markers: &[Marker], image: Rect, grabbed: Option<&str>, response: &egui::Response) {
    let size = glam::Vec2::new(image.width(), image.height());
    let hovered =
        response.hover_pos().and_then(|p| handles::hit(markers, image_coords(p, image), size, handles::GRAB_RADIUS));
    let painter = ui.painter_at(image);
    for (i, marker) in markers.iter().enumerate() {
        let centre = image.min + Vec2::new(marker.image.x * image.width(), marker.image.y * image.height());
        let active = hovered == Some(i) || grabbed == Some(marker.uniform.as_str());
        let radius = if active { 9.0 } else { 7.0 };
        painter.circle_stroke(centre, radius, egui::Stroke::new(2.0, MARKER));
        if marker.in_plane() {
            painter.circle_filled(centre, 2.5, MARKER);
        }
    }
    if grabbed.is_some() {
        ui.ctx().set_cursor_icon(egui::CursorIcon::Grabbing);
    } else if hovered.is_some() {
        ui.ctx().set_cursor_icon(egui::CursorIcon::Grab);
    }
}

/// A screen position's image coordinates in the view's `image` rectangle ([0, 1]^2, y down).
fn image_coords(position: egui::Pos2, image: Rect) -> glam::Vec2 {
    let v = |p: egui::Pos2| glam::Vec2::new(p.x, p.y);
    handles::to_image(v(position), v(image.min), glam::Vec2::new(image.width(), image.height()))
}

/// A left-button drag that starts on a mesh point's marker of a slice view moves the point in
/// the plane (its uniform follows the cursor); other presses keep their meaning. Returns
/// whether the point moved.
fn drag_handle(
    ui: &egui::Ui,
    live: &mut LiveScene,
    slot: &mut ViewSlot,
    index: usize,
    image: Rect,
    response: &egui::Response,
) -> bool {
    let size = glam::Vec2::new(image.width(), image.height());
    if response.drag_started_by(egui::PointerButton::Primary) {
        // Where the button went down, not where the drag was recognised.
        let origin = ui.input(|i| i.pointer.press_origin()).or(response.interact_pointer_pos());
        slot.drag = origin.and_then(|o| Some((handles::grab(live, index, image_coords(o, image), size)?, o)));
    }
    let Some((drag, last)) = &mut slot.drag else { return false };
    let active = response.dragged_by(egui::PointerButton::Primary) || response.drag_stopped();
    let mut moved = false;
    if let Some(at) = response.interact_pointer_pos().filter(|at| active && at != last) {
        moved = handles::drag_to(live, index, drag, image_coords(at, image)).is_ok();
        *last = at;
    }
    if !response.dragged() {
        slot.drag = None;
    }
    moved
}

/// The field menu of a view: the picture, or any state field as a probe.
fn probe_menu(ui: &mut egui::Ui, live: &LiveScene, slot: &mut ViewSlot, index: usize) {
    let current = slot.probe.as_ref().map_or("picture", |p| p.field.as_str()).to_string();
    egui::ComboBox::from_id_salt(("probe", index)).selected_text(format!("show: {current}")).show_ui(ui, |ui| {
        if ui.selectable_label(slot.probe.is_none(), "picture").clicked() {
            slot.probe = None;
        }
        for (name, ty) in probe_fields(live, &mut slot.fields, index) {
            if ui.selectable_label(current == *name, format!("{name}: {ty}")).clicked() {
                slot.probe = Some(ProbeView { field: name.clone(), shown: None, error: None });
            }
        }
    });
}

/// The showable fields of view `index` (name, type), kept in `cache` while its shaders stay the
/// same: every field its placed functions declare, of its ray pipeline and its filter passes
/// (those of its tree's filters named `GROUP-K.FIELD`), found by composing the scene when the
/// menu opens; where that fails, the fields its shader keeps.
fn probe_fields<'c>(
    live: &LiveScene,
    cache: &'c mut Option<(String, Vec<(String, String)>)>,
    index: usize,
) -> &'c [(String, String)] {
    let Some(view) = live.renderer().views().get(index) else { return &[] };
    let key: Vec<&str> = view.renderer.reflections().map(|r| r.structural_hash.as_str()).collect();
    let key = key.join(" ");
    if cache.as_ref().is_none_or(|(k, _)| *k != key) {
        let fields = match live.renderer().probe_fields(index) {
            Ok(fields) => fields.iter().filter(|f| f.showable()).map(|f| (f.name.clone(), f.ty.to_string())).collect(),
            Err(_) => {
                view.renderer.shader().reflection.state.fields.iter().map(|f| (f.name.clone(), f.ty.clone())).collect()
            }
        };
        *cache = Some((key, fields));
    }
    cache.as_ref().map_or(&[], |(_, fields)| fields.as_slice())
}

/// The quality of the picture and the time of the last piece of work, for the caption.
fn describe(frames: &ViewFrames, size: [u32; 2]) -> String {
    let quality = match frames.refiner().quality() {
        Quality::None => "rendering…".to_string(),
        Quality::Full if frames.refiner().wants_more() || frames.refiner().frames_done() > 1 => {
            format!("full {}×{}, {} samples", size[0], size[1], frames.refiner().frames_done())
        }
        Quality::Full => format!("full {}×{}", size[0], size[1]),
        Quality::Stale => "full (updating)".to_string(),
        Quality::Preview { scale, refined } if refined > 0.0 => {
            format!("preview 1/{:.0}, refining {:.0}%", 1.0 / scale, refined * 100.0)
        }
        Quality::Preview { scale, .. } => format!("preview 1/{:.0}", 1.0 / scale),
    };
    let timing = match frames.shown_last() {
        Some((Work::Preview { .. }, t)) => format!(" · preview frame {:.0} ms", t.as_secs_f64() * 1e3),
        Some((Work::Tile { region, .. }, t)) => {
            format!(" · tile of {} rows {:.0} ms", region.y1 - region.y0, t.as_secs_f64() * 1e3)
        }
        None => String::new(),
    };
    let estimate = frames
        .refiner()
        .full_frame_estimate()
        .map(|t| format!(" · full frame ≈ {:.0} ms", t.as_secs_f64() * 1e3))
        .unwrap_or_default();
    format!("{quality}{timing}{estimate}")
}

/// Mouse and keys over a view. Returns whether the user changed it (interaction in progress).
fn handle_input(ui: &egui::Ui, live: &mut LiveScene, index: usize, response: &egui::Response) -> bool {
    let hovered = response.hovered() || response.dragged();
    let (scroll, notches, keys) = ui.input(|i| {
        let mut keys = Vec::new();
        let (mut scroll, mut notches) = (0.0, 0);
        for event in &i.events {
            match event {
                egui::Event::Key { key, pressed: true, .. } => keys.push(*key),
                egui::Event::MouseWheel { unit, delta, .. } if delta.y != 0.0 => {
                    scroll += delta.y
                        * match unit {
                            egui::MouseWheelUnit::Point => 1.0,
                            egui::MouseWheelUnit::Line => 40.0,
                            egui::MouseWheelUnit::Page => 400.0,
                        };
                    notches += delta.y.signum() as i32;
                }
                _ => {}
            }
        }
        (scroll, notches, keys)
    });
    let mut changed = false;
    if let Some(camera) = live.camera(index) {
        let delta = response.drag_delta();
        let drag = glam::Vec2::new(delta.x, delta.y);
        let mut next = camera;
        if response.dragged_by(egui::PointerButton::Primary) {
            next = navigate::orbit(next, drag);
        } else if response.dragged_by(egui::PointerButton::Secondary)
            || response.dragged_by(egui::PointerButton::Middle)
        {
            next = navigate::pan(next, drag, response.rect.height());
        }
        if hovered && scroll != 0.0 {
            next = navigate::zoom(next, scroll);
        }
        if next != camera {
            live.set_camera(index, next);
            changed = true;
        }
        if hovered && keys.contains(&egui::Key::R) {
            live.reset_view(index);
            changed = true;
        }
    }
    if let (Some(plane), Some((dims, grid_to_world))) = (live.slice(index), live.renderer().primary_grid()) {
        let mut next = plane;
        // One wheel notch, whatever its size in points, is one voxel.
        let mut steps = if hovered { notches } else { 0 };
        if hovered {
            for key in &keys {
                match key {
                    egui::Key::ArrowUp | egui::Key::PageUp => steps += 1,
                    egui::Key::ArrowDown | egui::Key::PageDown => steps -= 1,
                    egui::Key::X => next = navigate::turn_slice(next, SliceAxis::X),
                    egui::Key::Y => next = navigate::turn_slice(next, SliceAxis::Y),
                    egui::Key::Z => next = navigate::turn_slice(next, SliceAxis::Z),
                    egui::Key::R => {
                        live.reset_view(index);
                        return true;
                    }
                    _ => {}
                }
            }
        }
        if steps != 0 {
            next = navigate::step_slice(next, steps, dims, grid_to_world);
        }
        if response.dragged_by(egui::PointerButton::Secondary) || response.dragged_by(egui::PointerButton::Middle) {
            let delta = response.drag_delta();
            changed |= window_level(live, index, glam::Vec2::new(delta.x, delta.y), response.rect.height());
        }
        if hovered {
            let digits =
                [egui::Key::Num0, egui::Key::Num1, egui::Key::Num2, egui::Key::Num3, egui::Key::Num4, egui::Key::Num5];
            if let Some(digit) = digits.iter().position(|d| keys.contains(d)) {
                changed |= window_preset(live, index, digit.checked_sub(1));
            }
        }
        if next != plane {
            live.set_slice(index, next);
            changed = true;
        }
    }
    changed
}

#[cfg(test)]
mod tests {
    use super::*;
    use vrs_runtime::bricks::Residency;

    #[test]
    fn the_brick_line_says_what_is_resident_loading_and_of_one_value() {
        let residency = Residency { resident: 65, slots: 512, pending: 12, constant: 227, ..Residency::default() };
        let progress = BrickProgress { residency, ..BrickProgress::default() };
        assert_eq!(brick_line(&progress), "bricks: 65 of 512 slots resident · 12 loading · 227 of one value");
        let settled = Residency { pending: 0, refused: 3, ..residency };
        let line = brick_line(&BrickProgress { residency: settled, ..progress });
        assert!(!line.contains("loading") && line.ends_with("parts shown coarser"), "{line}");
        let coarse = Residency { floor: 2, ..settled };
        let line = brick_line(&BrickProgress { residency: coarse, asked: 4, ..progress });
        assert!(line.contains("4 requested") && line.ends_with("level 2 and coarser shown (memory budget)"), "{line}");
    }
}
