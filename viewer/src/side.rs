//! The side panel of `vrsc view`: parameters, transfer functions and the inspector as tabs,
//! fed from the live scene and applying what the user does to it.

use crate::actions::{self, Action};
use crate::inspector::{self, InspectorState, Sources};
use crate::tf_editor::{self, EditedVolume, TfEditorState};
use crate::{mesh_panel, params};
use vrs_live::LiveScene;
use vrs_runtime::reflection::{FunctionInfo, Reflection};

/// The panel's tabs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tab {
    Parameters,
    TransferFunctions,
    /// Only while the scene has meshes.
    Meshes,
    Inspector,
}

/// The side panel's state.
pub struct SidePanel {
    pub open: bool,
    pub tab: Tab,
    tf: TfEditorState,
    inspector: InspectorState,
    /// The view the inspector shows, by index.
    inspected: usize,
    /// The annotated WGSL, by the structural hash of the shader it explains.
    explained: Option<(String, Result<String, String>)>,
    /// What the last action did, and the tab it was done in (where it is shown).
    message: (Tab, String),
    /// List every uniform, not only the editable ones.
    show_all: bool,
}

impl Default for SidePanel {
    fn default() -> SidePanel {
        SidePanel {
            open: true,
            tab: Tab::Parameters,
            tf: TfEditorState::default(),
            inspector: InspectorState::default(),
            inspected: 0,
            explained: None,
            message: (Tab::Parameters, String::new()),
            show_all: false,
        }
    }
}

impl SidePanel {
    /// Shows the panel (when open) and applies what the user did. Returns whether anything
    /// changed the pictures.
    pub fn show(&mut self, ui: &mut egui::Ui, live: &mut LiveScene) -> bool {
        if !self.open {
            return false;
        }
        let mut todo = Vec::new();
        let meshes = mesh_panel::rows(live);
        if meshes.is_empty() && self.tab == Tab::Meshes {
            self.tab = Tab::Parameters;
        }
        egui::Panel::right("side panel").resizable(true).default_size(360.0).show(ui, |ui| {
            ui.horizontal(|ui| {
                ui.selectable_value(&mut self.tab, Tab::Parameters, "Parameters");
                ui.selectable_value(&mut self.tab, Tab::TransferFunctions, "Transfer functions");
                if !meshes.is_empty() {
                    ui.selectable_value(&mut self.tab, Tab::Meshes, "Meshes");
                }
                ui.selectable_value(&mut self.tab, Tab::Inspector, "Inspector");
            });
            ui.separator();
            // The last action's message belongs to the tab it came from.
            let message = if self.message.0 == self.tab { self.message.1.as_str() } else { "" };
            todo = match self.tab {
                Tab::Parameters => params::show(ui, &parameter_groups(live), &mut self.show_all, message),
                Tab::TransferFunctions => {
                    let volumes = edited_volumes(live);
                    let scene = live.renderer().path().to_path_buf();
                    let actions = tf_editor::show(ui, &mut self.tf, &volumes, &scene);
                    ui.weak(message);
                    actions
                }
                Tab::Meshes => mesh_panel::show(ui, &meshes, &mesh_panel::group_rows(live), message),
                Tab::Inspector => {
                    self.show_inspector(ui, live);
                    Vec::new()
                }
            };
        });
        let changed = todo.iter().any(|a| !matches!(a, Action::SaveUniforms | Action::SaveCurve(..)));
        for action in todo {
            match actions::apply(live, action) {
                Ok(message) if message.is_empty() => {}
                Ok(message) | Err(message) => self.message = (self.tab, message),
            }
        }
        changed
    }

    fn show_inspector(&mut self, ui: &mut egui::Ui, live: &LiveScene) {
        let names = live.view_names();
        self.inspected = self.inspected.min(names.len().saturating_sub(1));
        egui::ComboBox::from_label("view")
            .selected_text(names.get(self.inspected).cloned().unwrap_or_default())
            .show_ui(ui, |ui| {
                for (i, name) in names.iter().enumerate() {
                    ui.selectable_value(&mut self.inspected, i, name);
                }
            });
        let Some(view) = live.renderer().views().get(self.inspected) else { return };
        // The filter pass's steps follow the view's in the map.
        let mut reflections = view.renderer.reflections();
        let Some(mut reflection) = reflections.next().cloned() else { return };
        reflection.pipeline.extend(reflections.flat_map(|r| r.pipeline.iter().cloned()));
        let mut sources =
            LiveSources { live, index: self.inspected, reflection: &reflection, cache: &mut self.explained };
        inspector::show(ui, &mut self.inspector, &reflection, &mut sources);
    }
}

/// Every view's uniforms in groups, with their current values.
fn parameter_groups(live: &LiveScene) -> Vec<params::Group> {
    // A view's filter pass has uniforms of its own (its `filters`' sliders).
    let reflections: Vec<&Reflection> = live.renderer().views().iter().flat_map(|v| v.renderer.reflections()).collect();
    params::groups(
        &reflections,
        |name| live.uniform(name),
        |name| live.scene_uniform_value(name),
        |name| live.is_user_uniform(name),
    )
}

/// Every volume with a transfer function, its curve in data units.
fn edited_volumes(live: &LiveScene) -> Vec<EditedVolume> {
    live.renderer()
        .volumes()
        .into_iter()
        .filter_map(|v| {
            Some(EditedVolume {
                name: v.name.to_string(),
                window: v.window,
                histogram: v.histogram.to_vec(),
                curve: v.curve?.in_data_units(v.window),
            })
        })
        .collect()
}

struct LiveSources<'a> {
    live: &'a LiveScene,
    index: usize,
    reflection: &'a Reflection,
    cache: &'a mut Option<(String, Result<String, String>)>,
}

impl Sources for LiveSources<'_> {
    fn function_source(&self, function: &FunctionInfo) -> Option<String> {
        self.live.function_source(function)
    }

    fn explained(&mut self) -> Result<String, String> {
        let hash = &self.reflection.structural_hash;
        if self.cache.as_ref().is_none_or(|(h, _)| h != hash) {
            *self.cache = Some((hash.clone(), self.live.explain(self.index)));
        }
        self.cache.as_ref().map(|(_, text)| text.clone()).unwrap_or_else(|| Err("not composed".into()))
    }
}
