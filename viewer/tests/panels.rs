//! The side panel headless: controls for every uniform of every example and fixture scene, and
//! the panels drawn by egui_kittest (through AccessKit, as a screen reader sees them) with
//! clicks that must come back as the right actions.

use egui_kittest::kittest::{NodeT, Queryable};
use egui_kittest::{Harness, HarnessBuilder};
use std::path::{Path, PathBuf};
use vrs_runtime::Value;
use vrs_runtime::reflection::{FunctionInfo, FunctionStatus, Reflection};
use vrs_runtime::tf::preset_curve;
use vrs_viewer::actions::Action;
use vrs_viewer::controls::{Control, control_for};
use vrs_viewer::inspector::{self, InspectorState, Sources};
use vrs_viewer::params;
use vrs_viewer::tf_editor::{self, EditedVolume, TfEditorState};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

/// Every scene file under `dir`.
fn scenes(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let path = entry.path();
        if path.is_dir() {
            scenes(&path, out);
        } else if path.extension().is_some_and(|e| e == "toml") {
            out.push(path);
        }
    }
}

/// The reflection of every view of every scene that composes, and of every filter pass.
fn reflections() -> Vec<(PathBuf, Reflection)> {
    let mut files = Vec::new();
    scenes(&root().join("examples"), &mut files);
    scenes(&root().join("tests/fixtures"), &mut files);
    let mut out = Vec::new();
    for file in files {
        let Ok(built) = vrsc::compose::build::build_scene(&file, None) else { continue };
        for view in &built.views {
            let filter = view.filter.as_ref().and_then(|f| f.shader.as_ref());
            for shader in view.shader.iter().chain(filter) {
                out.push((file.clone(), shader.reflection.clone()));
            }
        }
    }
    out
}

#[test]
fn every_uniform_of_every_example_and_fixture_view_gets_a_control_of_its_kind() {
    let all = reflections();
    assert!(all.len() >= 10, "only {} views composed", all.len());
    let mut kinds = std::collections::BTreeSet::new();
    for (file, reflection) in &all {
        let groups = params::groups(&[reflection], |_| None, |_| None, |_| false);
        for u in &reflection.uniforms {
            let shown = groups.iter().flat_map(|g| &g.rows).filter(|r| r.info.name == u.name).count();
            assert_eq!(shown, 1, "{}: `{}` is shown {shown} times", file.display(), u.name);
            let control = control_for(u);
            let scalar = ["f32", "i32", "u32"].contains(&u.ty.as_str());
            let right = match &control {
                Control::Slider { .. } => scalar && u.range.is_some(),
                Control::Drag => scalar && u.range.is_none(),
                Control::Checkbox => u.ty == "bool",
                Control::Vector { components, .. } => u.ty.starts_with("vec") && u.ty[3..4] == components.to_string(),
                Control::Colour { alpha } => ["vec3f", "vec4f"][usize::from(*alpha)] == u.ty,
                Control::Matrix { columns, rows } => u.ty == format!("mat{columns}x{rows}f"),
                Control::Resource => ["volume", "tf", "image"].contains(&u.ty.as_str()),
                Control::SetByRenderer => vrs_runtime::scene::is_set_by_renderer(&u.name),
            };
            assert!(right, "{}: `{}: {}` got {control:?}", file.display(), u.name, u.ty);
            kinds.insert(format!("{control:?}").split([' ', '{']).next().unwrap_or_default().to_string());
        }
    }
    for kind in ["Slider", "Vector", "Colour", "Resource", "SetByRenderer"] {
        assert!(kinds.contains(kind), "no example has a {kind}: {kinds:?}");
    }
    let filters = all.iter().filter(|(_, r)| r.pipeline.iter().any(|s| s.step == "filter.apply"));
    let edges =
        filters.flat_map(|(_, r)| params::groups(&[r], |_| None, |_| None, |_| false)).find(|g| g.function == "edges");
    let rows: Vec<&str> = edges.iter().flat_map(|g| &g.rows).map(|r| r.info.name.as_str()).collect();
    assert!(rows.contains(&"edge_threshold") && rows.contains(&"edge_color"), "the liver's edges filter: {rows:?}");
}

/// The groups of the clip-plane example's 3D view, with `clip_plane_gm` changed by the user.
fn clip_plane_groups() -> Vec<params::Group> {
    let built = vrsc::compose::build::build_scene(&root().join("examples/clip_plane/basic.toml"), None).unwrap();
    let reflection = built.views[0].shader.as_ref().unwrap().reflection.clone();
    let value = |name: &str| {
        let u = reflection.uniform(name)?;
        let json = u.value.as_ref().or(u.default.as_ref())?;
        let flat: Vec<f32> = match json {
            serde_json::Value::Array(items) => items
                .iter()
                .flat_map(|v| v.as_array().cloned().unwrap_or_else(|| vec![v.clone()]))
                .filter_map(|v| v.as_f64())
                .map(|f| f as f32)
                .collect(),
            scalar => vec![scalar.as_f64()? as f32],
        };
        u.ty.ends_with('f').then_some(Value::Float(flat))
    };
    params::groups(&[&reflection], value, |_| None, |name| name == "clip_plane_gm")
}

#[test]
fn the_parameter_panel_shows_each_function_with_its_uniforms_and_reports_a_reset() {
    let groups = clip_plane_groups();
    let clip = groups.iter().find(|g| g.function == "clip_gm").expect("the clip function's group");
    assert_eq!(clip.instance.as_deref(), Some("gm"));
    assert_eq!(clip.rows.iter().map(|r| r.info.name.as_str()).collect::<Vec<_>>(), ["clip_plane_gm"]);
    // Tall enough to show every group without scrolling.
    let mut harness = HarnessBuilder::default().with_size(egui::Vec2::new(600.0, 3000.0)).build_ui_state(
        |ui, (show_all, actions): &mut (bool, Vec<Action>)| actions.extend(params::show(ui, &groups, show_all, "")),
        (false, Vec::new()),
    );
    harness.run();
    harness.get_by_label("clip_gm (instance gm)");
    harness.get_by_label("clip_plane_gm");
    harness.get_by_label("Save to scene");
    harness.get_by_label("1 changed");
    assert!(harness.query_by_label("inv_view_proj").is_none(), "set by the viewer: listed only on request");
    harness.get_by_label("reset").click();
    harness.run();
    assert!(harness.state().1.contains(&Action::ResetUniform("clip_plane_gm".into())), "{:?}", harness.state().1);
    harness.get_by_label("Save to scene").click();
    harness.get_by_label("all").click();
    harness.run();
    assert!(harness.state().1.contains(&Action::SaveUniforms));
    harness.get_by_label("inv_view_proj");
}

/// A scene's value beyond its uniform's declared range widens the slider and says so (a slider
/// clamps what it shows: the light example's `light_color_key = [3.2, 3.0, 2.7]` read 2.00 when
/// its range was 0 .. 2), and a value the renderer derives says how.
#[test]
fn a_value_beyond_its_range_widens_the_slider_and_derived_values_say_how() {
    let built = vrsc::compose::build::build_scene(&root().join("examples/clip_plane/basic.toml"), None).unwrap();
    let reflection = built.views[0].shader.as_ref().unwrap().reflection.clone();
    let jitter = reflection.uniform("jitter").expect("a raycast view has `jitter`").clone();
    assert_eq!(control_for(&jitter), Control::Slider { lo: 0.0, hi: 1.0 });
    let scene = |name: &str| (name == "jitter").then(|| Value::Float(vec![1.5]));
    let value = |name: &str| match name {
        "step_size" => Some(Value::Float(vec![0.5])),
        _ => scene(name),
    };
    let groups = params::groups(&[&reflection], value, scene, |_| false);
    let row = |name: &str| groups.iter().flat_map(|g| &g.rows).find(|r| r.info.name == name).cloned().unwrap();
    assert_eq!(row("jitter").control, Control::Slider { lo: 0.0, hi: 1.5 });
    let widened = "a value lies beyond the declared range 0 .. 1: the slider is widened to show it";
    assert_eq!(row("jitter").notes, [widened]);
    let derived =
        "set by the renderer where the scene leaves it open: half the primary volume's smallest voxel spacing";
    assert_eq!(row("step_size").notes, [derived]);
    let mut harness = HarnessBuilder::default()
        .with_size(egui::Vec2::new(600.0, 3000.0))
        .build_ui_state(|ui, show_all: &mut bool| drop(params::show(ui, &groups, show_all, "")), false);
    harness.run();
    harness.get_by_label(widened);
    harness.get_by_label(derived);
}

#[test]
fn the_transfer_function_editor_adds_a_colour_stop_and_resets() {
    let window = [-1024.0, 3071.0];
    let volume = EditedVolume {
        name: "ct".into(),
        window,
        histogram: (0..256).map(|i| (i * 37 % 101) as u64).collect(),
        curve: preset_curve("ct_bone").unwrap().in_data_units(window),
    };
    let stops = volume.curve.color.len();
    let volumes = vec![volume];
    let mut harness = Harness::new_ui_state(
        |ui, (state, actions): &mut (TfEditorState, Vec<Action>)| {
            actions.extend(tf_editor::show(ui, state, &volumes, Path::new("/scenes/ct.toml")))
        },
        (TfEditorState::default(), Vec::new()),
    );
    harness.run();
    harness.get_by_label("ct_bone over [-1024, 3071]");
    // The preset menu names the curve in use (it said "choose…").
    let menu = harness.get_by_label("preset");
    let shown = format!("{:?} {:?}", menu.accesskit_node().value(), menu.accesskit_node().label());
    assert!(shown.contains("ct_bone"), "the preset menu shows `ct_bone`: {shown}");
    assert_eq!(tf_editor::nice_ticks([-1024.0, 3071.0], 6), [-1000.0, 0.0, 1000.0, 2000.0, 3000.0]);
    assert_eq!(tf_editor::nice_ticks([0.0, 1.0], 6), [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]);
    assert!(tf_editor::nice_ticks([5.0, 5.0], 6).is_empty());
    // The histogram is log-scaled unless the box is cleared.
    assert!(!harness.state().0.linear_histogram);
    harness.get_by_label("log histogram").click();
    harness.run();
    assert!(harness.state().0.linear_histogram, "clearing `log histogram` shows linear counts");
    harness.get_by_label("+ colour stop").click();
    harness.run();
    let added = harness.state().1.iter().find_map(|a| match a {
        Action::SetCurve(v, c) if v == "ct" => Some(c.clone()),
        _ => None,
    });
    assert_eq!(added.expect("a new curve").color.len(), stops + 1);
    harness.get_by_label("reset").click();
    harness.get_by_label("Save as ParaView JSON").click();
    harness.run();
    let actions = &harness.state().1;
    assert!(actions.contains(&Action::ResetCurve("ct".into())), "{actions:?}");
    assert!(actions.contains(&Action::SaveCurve("ct".into(), PathBuf::from("/scenes/ct_tf.json"))), "{actions:?}");
}

struct FakeSources;

impl Sources for FakeSources {
    fn function_source(&self, f: &FunctionInfo) -> Option<String> {
        Some(format!("pipeline {} {{ /* source */ }}", f.name))
    }

    fn explained(&mut self) -> Result<String, String> {
        Ok("// from clip.vrs:6\nfn clip_gm() {}".into())
    }
}

#[test]
fn the_inspector_shows_status_and_the_selected_functions_source() {
    let built = vrsc::compose::build::build_scene(&root().join("examples/clip_plane/basic.toml"), None).unwrap();
    let mut reflection = built.views[0].shader.as_ref().unwrap().reflection.clone();
    // A removed function, as a later `remove` leaves it.
    let step = reflection.pipeline.iter_mut().find(|s| s.step == "classification.additional").unwrap();
    let mut removed = step.functions[0].clone();
    (removed.name, removed.status) = ("clip_wm".into(), FunctionStatus::Removed);
    step.not_placed.push(removed);
    let mut harness = HarnessBuilder::default().with_size(egui::Vec2::new(900.0, 3000.0)).build_ui_state(
        |ui, state: &mut InspectorState| inspector::show(ui, state, &reflection, &mut FakeSources),
        InspectorState::default(),
    );
    harness.run();
    let labels: Vec<String> =
        harness.query_all_by_label_contains("clip").filter_map(|n| n.accesskit_node().label()).collect();
    assert!(labels.iter().any(|l| l.contains("clip_plane.vrs:11  (instance gm)")), "{labels:?}");
    let clip = harness.get_by_label_contains("clip_plane.vrs:11  (instance gm)");
    assert!(clip.accesskit_node().label().is_some_and(|l| l.contains("(instance gm)")));
    let removed = harness.get_by_label_contains("clip_wm").accesskit_node().label();
    assert!(removed.as_ref().is_some_and(|l| l.ends_with("removed")), "{removed:?}");
    harness.get_by_label_contains("clip_plane.vrs:11  (instance gm)").click();
    harness.run();
    harness.get_by_label("pipeline clip_gm { /* source */ }");
    harness.get_by_label("composed WGSL (explain)").click();
    harness.run();
    harness.get_by_label_contains("// from clip.vrs:6");
}

/// The renderer's notices show in the window (a phantom standing in for an absent file was
/// said only on the terminal): the light example without its data says so in the status bar.
#[test]
fn a_fallback_phantom_is_announced_in_the_window() {
    let dir = tempfile::tempdir().unwrap();
    for file in ["scene.toml", "skin.json"] {
        std::fs::copy(root().join("examples/light").join(file), dir.path().join(file)).unwrap();
    }
    let gpu = vrs_runtime::Gpu::headless(vrs_runtime::AdapterChoice::Software).expect("the software adapter");
    let options = vrs_runtime::RenderOptions { phantom_size: [32; 3], ..Default::default() };
    let renderer =
        vrs_runtime::SceneRenderer::open(gpu, &dir.path().join("scene.toml"), options, &mut |_, _, _| {}).unwrap();
    let fallback = renderer.notices.iter().find(|n| n.contains("phantom")).expect("a notice of the fallback").clone();
    let notices = renderer.notices.clone();
    let mut harness = Harness::new_ui(move |ui| vrs_viewer::notices(ui, &notices));
    harness.run();
    harness.get_by_label(&format!("note: {fallback}"));
}

/// The keyboard help lists what the mouse and keys do, and closes.
#[test]
fn the_keys_window_lists_the_views_keys() {
    let mut harness =
        Harness::new_ui_state(|ui, open: &mut bool| vrs_viewer::navigate::keys_window(ui.ctx(), open), true);
    harness.run();
    for (input, action) in vrs_viewer::navigate::KEYS {
        harness.get_by_label(input);
        harness.get_by_label(action);
    }
    harness.get_by_label("Close window").click();
    harness.run();
    assert!(!*harness.state(), "closed");
}
