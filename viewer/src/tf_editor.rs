//! The transfer-function editor: a volume's opacity curve as draggable points over its
//! histogram (log counts by default, linear on request), its colour stops, the presets as a menu, and saving as a ParaView
//! colormap. Values are data units over the volume's window; the opacity axis is square-root
//! scaled so the small opacities of see-through tissue (a few hundredths) can be set.

use crate::actions::Action;
use egui::{Color32, Pos2, Rect, Sense, Stroke, Vec2};
use std::path::{Path, PathBuf};
use vrs_runtime::tf::{PRESETS, TfCurve, preset_curve};

/// A volume as the editor shows it.
#[derive(Clone, Debug)]
pub struct EditedVolume {
    /// The `[[volume]]`'s name.
    pub name: String,
    /// The value axis (data units).
    pub window: [f32; 2],
    /// Voxel counts in equal bins over `window` (voxels outside it in the end bins).
    pub histogram: Vec<u64>,
    /// In data units over the window ([`TfCurve::in_data_units`]).
    pub curve: TfCurve,
}

/// What the editor remembers between frames.
#[derive(Clone, Debug, Default)]
pub struct TfEditorState {
    /// The volume being edited, by name.
    pub volume: Option<String>,
    /// Where "Save" writes, per volume (defaults next to the scene).
    pub save_paths: Vec<(String, String)>,
    /// The histogram's counts on a linear scale (the default is logarithmic, so the few voxels
    /// of dense structures show beside the many of air and soft tissue).
    pub linear_histogram: bool,
}

/// Height of the curve's canvas, in points.
const CANVAS_HEIGHT: f32 = 150.0;

/// Shows the editor for one of `volumes`; returns what the user asked for.
pub fn show(ui: &mut egui::Ui, state: &mut TfEditorState, volumes: &[EditedVolume], scene: &Path) -> Vec<Action> {
    let mut actions = Vec::new();
    if volumes.is_empty() {
        ui.weak("this scene has no volume with a transfer function");
        return actions;
    }
    let selected = state.volume.clone().filter(|n| volumes.iter().any(|v| &v.name == n));
    let name = selected.unwrap_or_else(|| volumes[0].name.clone());
    egui::ComboBox::from_label("volume").selected_text(&name).show_ui(ui, |ui| {
        for v in volumes {
            if ui.selectable_label(v.name == name, &v.name).clicked() {
                state.volume = Some(v.name.clone());
            }
        }
    });
    let Some(volume) = volumes.iter().find(|v| v.name == name) else { return actions };
    let mut curve = volume.curve.clone();
    let mut changed = false;
    ui.horizontal(|ui| {
        // The curve's own name: a preset's, a colormap file's, or an edited curve's origin.
        egui::ComboBox::from_label("preset").selected_text(curve.name.clone()).show_ui(ui, |ui| {
            for &preset in PRESETS {
                if ui.selectable_label(curve.name == preset, preset).clicked()
                    && let Ok(p) = preset_curve(preset)
                {
                    curve = p.in_data_units(volume.window);
                    changed = true;
                }
            }
        });
        if ui.button("reset").on_hover_text("Back to the scene's transfer function").clicked() {
            actions.push(Action::ResetCurve(volume.name.clone()));
        }
        let mut log = !state.linear_histogram;
        ui.checkbox(&mut log, "log histogram")
            .on_hover_text("Voxel counts on a logarithmic scale (off: linear, the largest bin full height)");
        state.linear_histogram = !log;
    });
    ui.weak(format!("{} over [{}, {}]", curve.name, volume.window[0], volume.window[1]));
    changed |= canvas(ui, volume, &mut curve, !state.linear_histogram);
    changed |= colour_stops(ui, volume.window, &mut curve);
    if changed {
        actions.push(Action::SetCurve(volume.name.clone(), curve));
    }
    ui.separator();
    save_row(ui, state, volume, scene, &mut actions);
    actions
}

/// Data value ↔ canvas position.
struct Axes {
    rect: Rect,
    window: [f32; 2],
}

impl Axes {
    fn x(&self, value: f32) -> f32 {
        let [lo, hi] = self.window;
        self.rect.left() + (value - lo) / (hi - lo).max(f32::MIN_POSITIVE) * self.rect.width()
    }

    fn y(&self, opacity: f32) -> f32 {
        self.rect.bottom() - opacity.clamp(0.0, 1.0).sqrt() * self.rect.height()
    }

    fn point(&self, (value, opacity): (f32, f32)) -> Pos2 {
        Pos2::new(self.x(value), self.y(opacity))
    }

    /// The (value, opacity) under canvas position `p`.
    fn at(&self, p: Pos2) -> (f32, f32) {
        let [lo, hi] = self.window;
        let t = ((p.x - self.rect.left()) / self.rect.width()).clamp(0.0, 1.0);
        let up = ((self.rect.bottom() - p.y) / self.rect.height()).clamp(0.0, 1.0);
        (lo + t * (hi - lo), up * up)
    }
}

/// The histogram, the colour bar, the opacity curve and its points. Drag a point to move it,
/// double-click to add one, right-click a point to delete it.
fn canvas(ui: &mut egui::Ui, volume: &EditedVolume, curve: &mut TfCurve, log: bool) -> bool {
    let width = ui.available_width().max(120.0);
    let (rect, background) = ui.allocate_exact_size(Vec2::new(width, CANVAS_HEIGHT), Sense::click());
    let axes = Axes { rect, window: volume.window };
    let painter = ui.painter_at(rect.expand(4.0));
    painter.rect_filled(rect, 2.0, Color32::from_gray(24));
    histogram(&painter, rect, &volume.histogram, log);
    let table = curve.table().over_window(volume.window);
    let bar = Rect::from_min_size(rect.left_bottom() + Vec2::new(0.0, 2.0), Vec2::new(rect.width(), 8.0));
    // The colour bar and the value axis lie under the canvas: a painter of their own (the
    // canvas's clips them).
    let below = Rect::from_min_max(bar.left_top() - Vec2::new(24.0, 0.0), bar.right_bottom() + Vec2::new(24.0, 16.0));
    let axis_painter = ui.painter_at(below);
    let steps = 128;
    for i in 0..steps {
        let entry = table.sample((i as f32 + 0.5) / steps as f32);
        let [r, g, b] = [entry[0], entry[1], entry[2]].map(|c| (c * 255.0) as u8);
        let x0 = bar.left() + bar.width() * i as f32 / steps as f32;
        let cell = Rect::from_min_max(
            Pos2::new(x0, bar.top()),
            Pos2::new(x0 + bar.width() / steps as f32 + 0.5, bar.bottom()),
        );
        axis_painter.rect_filled(cell, 0.0, Color32::from_rgb(r, g, b));
    }
    // The value axis under the colour bar, in the volume's data units.
    let font = egui::FontId::proportional(10.0);
    for value in nice_ticks(volume.window, 6) {
        let tick = [Pos2::new(axes.x(value), bar.bottom()), Pos2::new(axes.x(value), bar.bottom() + 3.0)];
        axis_painter.line_segment(tick, (1.0, Color32::GRAY));
        axis_painter.text(tick[1], egui::Align2::CENTER_TOP, tick_text(value), font.clone(), Color32::GRAY);
    }
    ui.add_space(24.0);
    let line: Vec<Pos2> = (0..table.rgba.len())
        .step_by(4)
        .map(|i| {
            // Entry i stands for the value at its texel's centre.
            let t = (i as f32 + 0.5) / table.rgba.len() as f32;
            let value = volume.window[0] + t * (volume.window[1] - volume.window[0]);
            axes.point((value, table.rgba[i][3]))
        })
        .collect();
    painter.add(egui::Shape::line(line, Stroke::new(1.5, Color32::from_rgb(240, 200, 90))));
    let mut changed = false;
    let mut delete = None;
    for (i, point) in curve.opacity.iter_mut().enumerate() {
        let centre = axes.point(*point);
        let handle = Rect::from_center_size(centre, Vec2::splat(12.0));
        let response = ui.interact(handle, ui.scope_id().with(("opacity point", i)), Sense::click_and_drag());
        if response.dragged()
            && let Some(p) = response.interact_pointer_pos()
        {
            *point = axes.at(p);
            changed = true;
        }
        if response.secondary_clicked() {
            delete = Some(i);
        }
        let colour = if response.hovered() || response.dragged() { Color32::WHITE } else { Color32::from_gray(200) };
        painter.circle(centre, 4.0, colour, Stroke::new(1.0, Color32::BLACK));
        response.on_hover_text(format!("value {:.1}, opacity {:.3}", point.0, point.1));
    }
    if let Some(i) = delete.filter(|_| curve.opacity.len() > 1) {
        curve.opacity.remove(i);
        changed = true;
    }
    if background.double_clicked()
        && let Some(p) = background.interact_pointer_pos()
    {
        curve.opacity.push(axes.at(p));
        changed = true;
    }
    changed
}

/// Bars of each bin's height (see [`bar_heights`]).
fn histogram(painter: &egui::Painter, rect: Rect, bins: &[u64], log: bool) {
    let width = rect.width() / bins.len().max(1) as f32;
    for (i, share) in bar_heights(bins, log).into_iter().enumerate() {
        let h = share * rect.height();
        let x = rect.left() + i as f32 * width;
        let bar = Rect::from_min_max(Pos2::new(x, rect.bottom() - h), Pos2::new(x + width, rect.bottom()));
        painter.rect_filled(bar, 0.0, Color32::from_gray(70));
    }
}

/// Each bin's bar as a share of the canvas's height: log(1 + count) (or the count, when not
/// `log`) over the highest bin's; all 0 for an empty histogram.
fn bar_heights(bins: &[u64], log: bool) -> Vec<f32> {
    let scale = |c: u64| if log { (c as f32).ln_1p() } else { c as f32 };
    let top = bins.iter().map(|&c| scale(c)).fold(0.0, f32::max);
    bins.iter().map(|&c| if top > 0.0 { scale(c) / top } else { 0.0 }).collect()
}

/// At most `most` round values (1, 2 or 5 times a power of ten apart) within `[lo, hi]`, for
/// the value axis.
pub fn nice_ticks([lo, hi]: [f32; 2], most: usize) -> Vec<f32> {
    let span = hi - lo;
    if !(span.is_finite() && span > 0.0) || most == 0 {
        return Vec::new();
    }
    let rough = span / most as f32;
    let power = 10f32.powf(rough.log10().floor());
    let step =
        [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * power).find(|&s| span / s <= most as f32).unwrap_or(10.0 * power);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|k| k as f32 * step).collect()
}

/// A tick's label: no decimals where the value is whole.
fn tick_text(value: f32) -> String {
    if value.fract() == 0.0 { format!("{value:.0}") } else { format!("{value}") }
}

/// The colour stops as rows: value, colour, delete; and a button adding one.
fn colour_stops(ui: &mut egui::Ui, window: [f32; 2], curve: &mut TfCurve) -> bool {
    let mut changed = false;
    let speed = f64::from((window[1] - window[0]).abs() / 500.0);
    let mut delete = None;
    egui::ScrollArea::vertical().id_salt("colour stops").max_height(140.0).show(ui, |ui| {
        for (i, (value, rgb)) in curve.color.iter_mut().enumerate() {
            ui.horizontal(|ui| {
                changed |= ui.add(egui::DragValue::new(value).speed(speed).prefix("at ")).changed();
                let mut bytes = rgb.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8);
                if ui.color_edit_button_srgb(&mut bytes).changed() {
                    *rgb = bytes.map(|b| f32::from(b) / 255.0);
                    changed = true;
                }
                if ui.small_button("×").on_hover_text("Delete this colour stop").clicked() {
                    delete = Some(i);
                }
            });
        }
    });
    if let Some(i) = delete.filter(|_| curve.color.len() > 1) {
        curve.color.remove(i);
        changed = true;
    }
    if ui.small_button("+ colour stop").clicked() {
        let middle = (window[0] + window[1]) / 2.0;
        let table = curve.table().over_window(window);
        let [r, g, b, _] = table.rgba[table.rgba.len() / 2];
        curve.color.push((middle, [r, g, b]));
        changed = true;
    }
    changed
}

fn save_row(
    ui: &mut egui::Ui,
    state: &mut TfEditorState,
    volume: &EditedVolume,
    scene: &Path,
    actions: &mut Vec<Action>,
) {
    let index = match state.save_paths.iter().position(|(v, _)| v == &volume.name) {
        Some(i) => i,
        None => {
            let folder = scene.parent().unwrap_or(Path::new("."));
            let path = folder.join(format!("{}_tf.json", volume.name));
            state.save_paths.push((volume.name.clone(), path.display().to_string()));
            state.save_paths.len() - 1
        }
    };
    let path = &mut state.save_paths[index].1;
    ui.horizontal(|ui| {
        let label = ui.label("save as");
        ui.add(egui::TextEdit::singleline(path).desired_width(f32::INFINITY)).labelled_by(label.id);
    });
    let save = ui.button("Save as ParaView JSON");
    if save.on_hover_text("Write the colormap and point the volume's `tf` in the scene at it").clicked() {
        actions.push(Action::SaveCurve(volume.name.clone(), PathBuf::from(path.as_str())));
    }
}

#[cfg(test)]
mod tests {
    use super::bar_heights;

    #[test]
    fn the_histogram_is_log_scaled_unless_asked_for_linear_counts() {
        let bins = [0, 9, 99, 999];
        let linear = bar_heights(&bins, false);
        assert_eq!(linear, [0.0, 9.0 / 999.0, 99.0 / 999.0, 1.0]);
        // log(1 + count): a bin of 9 voxels stands a third as high as one of 999.
        let log = bar_heights(&bins, true);
        assert_eq!(log[3], 1.0);
        assert!((log[1] - 10f32.ln() / 1000f32.ln()).abs() < 1e-6, "{log:?}");
        assert!(bar_heights(&[0, 0], true).iter().all(|&h| h == 0.0));
    }
}
