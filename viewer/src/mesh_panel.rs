//! The mesh panel: each `[[mesh]]` of the scene with its colour, opacity and placement (a
//! translation in millimetres, patient space), and a reset to the scene's; then each occlusion
//! group the views draw, with the opacity it shows what it hides with. The tab shows only when
//! the scene has meshes.

use crate::actions::Action;
use egui::{DragValue, RichText, Slider};
use vrs_live::{LiveScene, MeshStyle};

/// One mesh as the panel shows it.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshRow {
    /// The `[[mesh]]`'s name.
    pub name: String,
    /// What it is drawn with now.
    pub style: MeshStyle,
    /// Whether the user changed it (it can be reset).
    pub changed: bool,
}

/// An occlusion group as the panel shows it.
#[derive(Clone, Debug, PartialEq)]
pub struct GroupRow {
    /// The `[[group]]`'s name.
    pub name: String,
    /// The opacity its hidden children show with now.
    pub opacity: f32,
    /// Whether the user changed it (it can be reset).
    pub changed: bool,
}

/// Every occlusion group `live`'s views draw, in scene order.
pub fn group_rows(live: &LiveScene) -> Vec<GroupRow> {
    let groups = live.occlusion_groups().into_iter();
    groups.map(|(name, opacity)| GroupRow { changed: live.is_user_group(&name), name, opacity }).collect()
}

/// Every mesh of `live`'s scene, in scene order.
pub fn rows(live: &LiveScene) -> Vec<MeshRow> {
    live.meshes().into_iter().map(|(name, style)| MeshRow { changed: live.is_user_mesh(&name), name, style }).collect()
}

/// Shows the panel; returns what the user asked for.
pub fn show(ui: &mut egui::Ui, rows: &[MeshRow], groups: &[GroupRow], message: &str) -> Vec<Action> {
    let mut actions = Vec::new();
    ui.weak("Colour, opacity and placement (mm, patient space) of the scene's meshes");
    ui.weak("In a slice view, drag a green ring to move the point a mesh follows (a needle's tip)");
    if !message.is_empty() {
        ui.weak(message);
    }
    ui.separator();
    egui::ScrollArea::vertical().id_salt("meshes").show(ui, |ui| {
        for row in rows {
            ui.push_id(&row.name, |ui| mesh_row(ui, row, &mut actions));
            ui.separator();
        }
        if !groups.is_empty() {
            ui.strong("Occlusion groups");
            ui.weak("How what the first child hides shows through it (1: whole)");
        }
        for group in groups {
            ui.push_id(("group", &group.name), |ui| group_row(ui, group, &mut actions));
        }
    });
    actions
}

fn group_row(ui: &mut egui::Ui, row: &GroupRow, actions: &mut Vec<Action>) {
    if heading(ui, &row.name, row.changed, "Back to the scene's opacity") {
        actions.push(Action::ResetGroupOpacity(row.name.clone()));
    }
    let mut opacity = row.opacity;
    let hover = format!("{}: the opacity of what its first child hides", row.name);
    if unit_slider(ui, "hidden opacity", &mut opacity, hover) && opacity != row.opacity {
        actions.push(Action::SetGroupOpacity(row.name.clone(), opacity));
    }
}

/// A row's name, with a reset button (hovered with `reset`) when `changed`; whether it was
/// clicked.
fn heading(ui: &mut egui::Ui, name: &str, changed: bool, reset: &str) -> bool {
    ui.horizontal(|ui| {
        ui.label(RichText::new(name).monospace().strong());
        changed && ui.small_button("reset").on_hover_text(reset).clicked()
    })
    .inner
}

fn mesh_row(ui: &mut egui::Ui, row: &MeshRow, actions: &mut Vec<Action>) {
    if heading(ui, &row.name, row.changed, "Back to the scene's colour and placement") {
        actions.push(Action::ResetMeshStyle(row.name.clone()));
    }
    let mut style = row.style;
    let mut changed = colour(ui, &row.name, &mut style.color);
    let hover = format!("{}: 1 is opaque (rays end at it), below 1 it is blended", row.name);
    changed |= unit_slider(ui, "opacity", &mut style.opacity, hover);
    changed |= translation(ui, &row.name, &mut style.model[3]);
    if changed && style != row.style {
        actions.push(Action::SetMeshStyle(row.name.clone(), style));
    }
}

/// An sRGB colour picker over the mesh's colour (0 to 1 per component).
fn colour(ui: &mut egui::Ui, mesh: &str, color: &mut [f32; 3]) -> bool {
    let to_byte = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
    ui.horizontal(|ui| {
        let label = ui.label("colour").id;
        let mut rgb = color.map(to_byte);
        let picked = ui.color_edit_button_srgb(&mut rgb).labelled_by(label).on_hover_text(format!("{mesh}'s colour"));
        if picked.changed() && rgb != color.map(to_byte) {
            *color = rgb.map(|b| f32::from(b) / 255.0);
            return true;
        }
        false
    })
    .inner
}

/// A slider of `value` from 0 to 1 labelled `label`; whether the user moved it.
fn unit_slider(ui: &mut egui::Ui, label: &str, value: &mut f32, hover: String) -> bool {
    ui.horizontal(|ui| {
        let label = ui.label(label).id;
        ui.add(Slider::new(value, 0.0..=1.0)).labelled_by(label).on_hover_text(hover).changed()
    })
    .inner
}

/// The placement's translation column, one drag value per patient axis.
fn translation(ui: &mut egui::Ui, mesh: &str, column: &mut [f32; 4]) -> bool {
    ui.horizontal(|ui| {
        ui.label("move")
            .on_hover_text(format!("{mesh}'s translation in mm (patient space: right, anterior, superior)"));
        let mut changed = false;
        for (i, axis) in ["x", "y", "z"].into_iter().enumerate() {
            let label = ui.label(axis).id;
            let value = DragValue::new(&mut column[i]).speed(0.5).suffix(" mm").range(-1000.0..=1000.0);
            changed |= ui.add(value).labelled_by(label).changed();
        }
        changed
    })
    .inner
}
