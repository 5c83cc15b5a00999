//! The inspector: a view's pipeline map (every step, each function with its origin, instance
//! and whether it runs, was removed, or was left out by `when active`), the VRS source of the
//! selected function, and the composed WGSL annotated as `vrsc explain` prints it.

use egui::{Color32, RichText};
use vrs_runtime::reflection::{FunctionInfo, FunctionStatus, Reflection};

/// What the inspector remembers between frames.
#[derive(Clone, Debug, Default)]
pub struct InspectorState {
    /// The selected function: (step, name).
    pub selected: Option<(String, String)>,
    /// Show the composed WGSL instead of the selected function's source.
    pub show_wgsl: bool,
}

/// What the inspector needs from the live scene, asked for lazily (sources and the annotated
/// WGSL cost a lookup or a composition).
pub trait Sources {
    /// The VRS source of `function` (its span in the last composition's files), if there.
    fn function_source(&self, function: &FunctionInfo) -> Option<String>;
    /// The annotated WGSL of the view, or why there is none.
    fn explained(&mut self) -> Result<String, String>;
}

/// Shows the inspector for the view of `reflection`.
pub fn show(ui: &mut egui::Ui, state: &mut InspectorState, reflection: &Reflection, sources: &mut dyn Sources) {
    ui.horizontal(|ui| {
        ui.selectable_value(&mut state.show_wgsl, false, "pipeline");
        ui.selectable_value(&mut state.show_wgsl, true, "composed WGSL (explain)");
    });
    ui.separator();
    if state.show_wgsl {
        let text = sources.explained().unwrap_or_else(|e| e);
        code(ui, "wgsl", &text);
        return;
    }
    egui::ScrollArea::vertical().id_salt("pipeline map").max_height(ui.available_height() * 0.55).show(ui, |ui| {
        for step in &reflection.pipeline {
            if step.functions.is_empty() && step.not_placed.is_empty() {
                ui.weak(format!("{} (empty)", step.step));
                continue;
            }
            ui.label(RichText::new(&step.step).strong());
            for f in step.functions.iter().chain(&step.not_placed) {
                let key = (step.step.clone(), f.name.clone());
                let selected = state.selected.as_ref() == Some(&key);
                if ui.selectable_label(selected, entry(f)).on_hover_text(details(f)).clicked() {
                    state.selected = Some(key);
                }
            }
        }
    });
    ui.separator();
    let selected = state.selected.as_ref().and_then(|(step, name)| {
        let step = reflection.pipeline.iter().find(|s| &s.step == step)?;
        step.functions.iter().chain(&step.not_placed).find(|f| &f.name == name)
    });
    match selected {
        Some(f) => {
            ui.weak(format!("{}:{}", f.file, f.line));
            let source = sources.function_source(f).unwrap_or_else(|| "(source not available)".into());
            code(ui, "source", &source);
        }
        None => {
            ui.weak("select a function to see its VRS source");
        }
    }
}

/// One line of the map: name, origin, instance and status.
fn entry(f: &FunctionInfo) -> RichText {
    let instance = f.instance.as_ref().map(|i| format!("  (instance {i})")).unwrap_or_default();
    let status = match f.status {
        FunctionStatus::Active => "",
        FunctionStatus::Removed => "  removed",
        FunctionStatus::LeftOut => "  left out (when active)",
    };
    let text = RichText::new(format!("  {}  {}:{}{instance}{status}", f.name, f.file, f.line)).monospace();
    match f.status {
        FunctionStatus::Active => text,
        _ => text.strikethrough().color(Color32::GRAY),
    }
}

/// The tooltip: what the function declares.
fn details(f: &FunctionInfo) -> String {
    let list = |names: &[String]| if names.is_empty() { "none".to_string() } else { names.join(", ") };
    format!("state: {}\nuniforms: {}", list(&f.fields), list(&f.uniforms))
}

fn code(ui: &mut egui::Ui, id: &str, text: &str) {
    egui::ScrollArea::both().id_salt(id).show(ui, |ui| {
        ui.label(RichText::new(text).monospace().size(11.0));
    });
}
