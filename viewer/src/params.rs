//! The parameter panel: every uniform of every view, grouped by the pipeline function (and
//! instance) that declares it, each with the control its reflection calls for
//! ([`crate::controls`]), its doc comment as tooltip and a reset to the scene's value.

use crate::actions::Action;
use crate::controls::{Control, control_for};
use egui::{DragValue, RichText, Slider};
use vrs_runtime::Value;
use vrs_runtime::reflection::{Reflection, UniformInfo};

/// One uniform as the panel shows it.
#[derive(Clone, Debug)]
pub struct UniformRow {
    pub info: UniformInfo,
    pub control: Control,
    /// The value in use (`None` for resources).
    pub value: Option<Value>,
    /// Whether the user changed it (it can be reset, and saved).
    pub changed: bool,
}

/// The uniforms a pipeline function declares first along the pipeline.
#[derive(Clone, Debug)]
pub struct Group {
    /// The function's (instantiated) name.
    pub function: String,
    pub instance: Option<String>,
    pub step: String,
    /// `file:line` of the function.
    pub origin: String,
    pub rows: Vec<UniformRow>,
}

/// The groups of every view's uniforms, in pipeline order; a uniform that several functions
/// or views read appears once, under the first function that declares it.
pub fn groups(
    reflections: &[&Reflection],
    value: impl Fn(&str) -> Option<Value>,
    changed: impl Fn(&str) -> bool,
) -> Vec<Group> {
    let mut shown: Vec<&str> = Vec::new();
    let mut out = Vec::new();
    for reflection in reflections {
        for step in &reflection.pipeline {
            for f in &step.functions {
                let rows: Vec<UniformRow> = f
                    .uniforms
                    .iter()
                    .filter_map(|name| reflection.uniform(name))
                    .filter(|u| !shown.contains(&u.name.as_str()))
                    .map(|u| UniformRow {
                        info: u.clone(),
                        control: control_for(u),
                        value: value(&u.name),
                        changed: changed(&u.name),
                    })
                    .collect();
                if rows.is_empty() {
                    continue;
                }
                shown.extend(f.uniforms.iter().map(String::as_str));
                out.push(Group {
                    function: f.name.clone(),
                    instance: f.instance.clone(),
                    step: step.step.clone(),
                    origin: format!("{}:{}", f.file, f.line),
                    rows,
                });
            }
        }
    }
    out
}

/// Shows the panel; returns what the user asked for.
pub fn show(ui: &mut egui::Ui, groups: &[Group], message: &str) -> Vec<Action> {
    let mut actions = Vec::new();
    ui.horizontal(|ui| {
        let changed = groups.iter().flat_map(|g| &g.rows).filter(|r| r.changed).count();
        let save = ui.add_enabled(changed > 0, egui::Button::new("Save to scene"));
        if save.on_hover_text("Write the values you changed into the scene's [uniforms] (comments kept)").clicked() {
            actions.push(Action::SaveUniforms);
        }
        ui.weak(format!("{changed} changed"));
    });
    if !message.is_empty() {
        ui.weak(message);
    }
    ui.separator();
    egui::ScrollArea::vertical().id_salt("parameters").show(ui, |ui| {
        for group in groups {
            let title = match &group.instance {
                Some(i) => format!("{} (instance {i})", group.function),
                None => group.function.clone(),
            };
            egui::CollapsingHeader::new(RichText::new(title).strong())
                .id_salt(("group", &group.function))
                .default_open(true)
                .show(ui, |ui| {
                    ui.weak(format!("{} · {}", group.step, group.origin));
                    for row in &group.rows {
                        uniform_row(ui, row, &mut actions);
                    }
                });
        }
    });
    actions
}

fn uniform_row(ui: &mut egui::Ui, row: &UniformRow, actions: &mut Vec<Action>) {
    let name = &row.info.name;
    ui.horizontal(|ui| {
        let label = ui.label(RichText::new(name).monospace());
        if let Some(doc) = &row.info.doc {
            label.on_hover_text(doc);
        }
        ui.weak(&row.info.ty);
        if row.changed && ui.small_button("reset").on_hover_text("Back to the scene's value").clicked() {
            actions.push(Action::ResetUniform(name.clone()));
        }
    });
    let Some(value) = &row.value else {
        let why = match row.control {
            Control::Resource => "edited in the transfer-function tab",
            _ => "no value",
        };
        ui.weak(why);
        return;
    };
    let mut edited = value.clone();
    let changed = ui.push_id(name, |ui| edit(ui, &row.control, &mut edited)).inner;
    if changed && &edited != value {
        actions.push(Action::SetUniform(name.clone(), edited));
    }
}

/// The control's widget(s) over `value`; whether the user changed it.
fn edit(ui: &mut egui::Ui, control: &Control, value: &mut Value) -> bool {
    match (control, value) {
        (Control::SetByRenderer, _) => {
            ui.weak("set by the viewer every frame (camera, slice, volume placement)");
            false
        }
        (Control::Checkbox, Value::Bool(v)) => v.iter_mut().any(|b| ui.checkbox(b, "").changed()),
        (Control::Colour { alpha }, Value::Float(v)) => colour(ui, v, *alpha),
        (Control::Slider { lo, hi }, v) => component(ui, v, 0, Some((*lo, *hi)), ""),
        (Control::Vector { components, ranges }, v) => {
            let mut changed = false;
            for i in 0..*components {
                let range = ranges.as_ref().and_then(|r| r.get(i).copied());
                changed |= component(ui, v, i, range, ["x", "y", "z", "w"][i.min(3)]);
            }
            changed
        }
        (Control::Matrix { columns, rows }, v) => {
            let mut changed = false;
            egui::Grid::new("matrix").show(ui, |ui| {
                for r in 0..*rows {
                    for c in 0..*columns {
                        changed |= component(ui, v, c * rows + r, None, "");
                    }
                    ui.end_row();
                }
            });
            changed
        }
        (_, v) => component(ui, v, 0, None, ""),
    }
}

/// One component of a value: a slider with a range, a drag value without.
fn component(ui: &mut egui::Ui, value: &mut Value, i: usize, range: Option<(f64, f64)>, label: &str) -> bool {
    let response = match value {
        Value::Float(v) => number(ui, &mut v[i], range, label, 0.01),
        Value::Int(v) => number(ui, &mut v[i], range, label, 1.0),
        Value::Uint(v) => number(ui, &mut v[i], range, label, 1.0),
        Value::Bool(v) => ui.checkbox(&mut v[i], label),
    };
    response.changed()
}

fn number<N: egui::emath::Numeric>(
    ui: &mut egui::Ui,
    n: &mut N,
    range: Option<(f64, f64)>,
    label: &str,
    speed: f64,
) -> egui::Response {
    match range {
        Some((lo, hi)) => ui.add(Slider::new(n, N::from_f64(lo)..=N::from_f64(hi)).text(label)),
        None => ui.horizontal(|ui| {
            if !label.is_empty() {
                ui.label(label);
            }
            ui.add(DragValue::new(n).speed(speed))
        })
        .inner,
    }
}

/// A colour picker over straight RGB(A) values in [0, 1] as the shader sees them (the output
/// image stores them unchanged, so they are display values).
fn colour(ui: &mut egui::Ui, v: &mut [f32], alpha: bool) -> bool {
    let to_byte = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
    let changed = if alpha && v.len() >= 4 {
        let mut rgba = [to_byte(v[0]), to_byte(v[1]), to_byte(v[2]), to_byte(v[3])];
        let changed = ui.color_edit_button_srgba_unmultiplied(&mut rgba).changed();
        if changed {
            v[..4].iter_mut().zip(rgba).for_each(|(c, b)| *c = f32::from(b) / 255.0);
        }
        changed
    } else {
        let mut rgb = [to_byte(v[0]), to_byte(v[1]), to_byte(v[2])];
        let changed = ui.color_edit_button_srgb(&mut rgb).changed();
        if changed {
            v[..3].iter_mut().zip(rgb).for_each(|(c, b)| *c = f32::from(b) / 255.0);
        }
        changed
    };
    let text: Vec<String> = v.iter().map(|c| format!("{c:.3}")).collect();
    ui.weak(text.join(", "));
    changed
}
