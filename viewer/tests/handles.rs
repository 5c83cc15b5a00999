//! Dragging the ablation needle in the axial view without a window: the markers the viewer
//! draws, a press that grabs needle A's tip, and a drag that moves its zone's centre in the
//! plane (the needle follows), on the software adapter.

use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use glam::{Vec2, Vec3};
use std::path::{Path, PathBuf};
use vrs_live::{LiveScene, MeshStyle};
use vrs_runtime::{AdapterChoice, Gpu, RenderOptions, SceneRenderer, Value};
use vrs_viewer::actions::Action;
use vrs_viewer::handles::{self, GRAB_RADIUS};
use vrs_viewer::mesh_panel::{self, GroupRow, MeshRow};

fn ablation() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/ablation/scene.toml")
}

fn open() -> LiveScene {
    let gpu = Gpu::headless(AdapterChoice::Software).expect("the software adapter (lavapipe) is required");
    // The phantom's extent follows its size: the default one, where the example places its zones.
    let renderer =
        SceneRenderer::open(gpu, &ablation(), RenderOptions::default(), &mut |_, _, _| {}).expect("the example opens");
    LiveScene::new(renderer)
}

fn vec3(live: &LiveScene, uniform: &str) -> Vec3 {
    match live.uniform(uniform) {
        Some(Value::Float(v)) if v.len() == 3 => Vec3::new(v[0], v[1], v[2]),
        other => panic!("`{uniform}` is {other:?}"),
    }
}

#[test]
fn dragging_needle_a_in_the_axial_view_moves_its_zone_in_the_plane() {
    let mut live = open();
    let axial = live.view_names().iter().position(|n| n == "axial").expect("the axial view");
    assert!(handles::slice_markers(&live, 0).is_empty(), "a 3D view has no markers");
    let markers = handles::slice_markers(&live, axial);
    let uniforms: Vec<&str> = markers.iter().map(|m| m.uniform.as_str()).collect();
    assert_eq!(uniforms, ["zone_centre_a", "zone_centre_b"], "tips only, not directions");
    let a = markers[0].clone();
    let before = vec3(&live, "zone_centre_a");
    assert!((a.shown - before).length() < 1e-4);

    // A press 5 points off the marker grabs it; one 20 points off does not.
    let size = Vec2::splat(400.0);
    let near = a.image + Vec2::new(5.0, 0.0) / size;
    let far = a.image + Vec2::new(0.0, 3.0 * GRAB_RADIUS) / size;
    assert!(handles::grab(&live, axial, far, size).is_none());
    let drag = handles::grab(&live, axial, near, size).expect("needle A's tip is grabbed");
    assert_eq!((drag.mesh.as_str(), drag.uniform.as_str()), ("needle_a", "zone_centre_a"));

    // 40 points right and 20 down on a 400-point image.
    let target = a.image + Vec2::new(40.0, 20.0) / size;
    let moved = handles::drag_to(&mut live, axial, &drag, target).expect("the drag applies");
    assert_eq!(vec3(&live, "zone_centre_a"), moved);
    // In the plane, at the depth it had: the axial plane's normal is the patient's z.
    assert!((moved.z - before.z).abs() < 1e-3, "{before} -> {moved}");
    let (pixel, depth) = live.renderer().slice_geometry(axial).unwrap().world_to_pixel(moved);
    assert!((Vec2::from(pixel) - target).length() < 1e-4, "the tip is under the cursor: {pixel:?}");
    assert!((depth - a.depth).abs() < 1e-3);
    // Radiological axial view: image right is the patient's left (-x), image down posterior (-y).
    assert!(moved.x < before.x - 1.0 && moved.y < before.y - 0.5, "{before} -> {moved}");
    // The needle follows; zone B stays.
    let again = handles::slice_markers(&live, axial);
    assert!((again[0].image - target).length() < 1e-4 && again[1] == markers[1]);
    let images = live.render_all().expect("renders");
    assert_eq!(images.len(), 2);
    let needle = live.renderer().meshes().iter().find(|m| m.name == "needle_a").unwrap();
    let (low, high) = needle.mesh.bounds().unwrap();
    let inside = |p: Vec3| (0..3).all(|i| p[i] >= low[i] - 1e-3 && p[i] <= high[i] + 1e-3);
    assert!(inside(moved) && !inside(before), "the needle's tip moved: {low:?} {high:?}");
}

fn row(name: &str) -> MeshRow {
    MeshRow {
        name: name.into(),
        style: MeshStyle { color: [0.82, 0.84, 0.88], opacity: 1.0, model: MeshStyle::IDENTITY },
        changed: name == "needle_b",
    }
}

#[test]
fn the_mesh_panel_sets_opacity_and_placement_and_resets() {
    let rows = vec![row("needle_a"), row("needle_b")];
    let mut harness = Harness::new_ui_state(
        |ui, actions: &mut Vec<Action>| actions.extend(mesh_panel::show(ui, &rows, &[], "")),
        Vec::new(),
    );
    harness.run();
    harness.get_by_label("needle_a");
    let opacity: Vec<_> = harness.query_all_by_role_and_label(Role::Slider, "opacity").collect();
    assert_eq!(opacity.len(), 2);
    opacity[0].set_value_accesskit(0.25);
    harness.run();
    let xs: Vec<_> = harness.query_all_by_role_and_label(Role::SpinButton, "x").collect();
    assert_eq!(xs.len(), 2);
    xs[1].set_value_accesskit(12.5);
    harness.run();
    // Only needle_b was changed by the user: one reset.
    harness.get_by_label("reset").click();
    harness.run();
    let actions = harness.state();
    let expected_a = MeshStyle { opacity: 0.25, ..row("needle_a").style };
    assert!(actions.contains(&Action::SetMeshStyle("needle_a".into(), expected_a)), "{actions:?}");
    let mut model = MeshStyle::IDENTITY;
    model[3][0] = 12.5;
    let expected_b = MeshStyle { model, ..row("needle_b").style };
    assert!(actions.contains(&Action::SetMeshStyle("needle_b".into(), expected_b)), "{actions:?}");
    assert!(actions.contains(&Action::ResetMeshStyle("needle_b".into())), "{actions:?}");
}

#[test]
fn the_mesh_panel_sets_an_occlusion_groups_opacity_and_resets_it() {
    let groups = vec![GroupRow { name: "liver".into(), opacity: 0.5, changed: true }];
    let mut harness = Harness::new_ui_state(
        |ui, actions: &mut Vec<Action>| actions.extend(mesh_panel::show(ui, &[row("needle_a")], &groups, "")),
        Vec::new(),
    );
    harness.run();
    harness.get_by_role_and_label(Role::Slider, "hidden opacity").set_value_accesskit(0.8);
    harness.run();
    harness.get_by_label("reset").click();
    harness.run();
    let actions = harness.state();
    assert!(actions.contains(&Action::SetGroupOpacity("liver".into(), 0.8)), "{actions:?}");
    assert!(actions.contains(&Action::ResetGroupOpacity("liver".into())), "{actions:?}");
}

#[test]
fn panel_actions_apply_to_the_live_scene() {
    let mut live = open();
    let rows = mesh_panel::rows(&live);
    assert_eq!(rows.iter().map(|r| r.name.as_str()).collect::<Vec<_>>(), ["needle_a", "needle_b"]);
    let style = MeshStyle { color: [1.0, 0.0, 0.0], ..rows[0].style };
    vrs_viewer::actions::apply(&mut live, Action::SetMeshStyle("needle_a".into(), style)).unwrap();
    assert_eq!(mesh_panel::rows(&live)[0], MeshRow { name: "needle_a".into(), style, changed: true });
    let message = vrs_viewer::actions::apply(&mut live, Action::ResetMeshStyle("needle_a".into())).unwrap();
    assert!(message.contains("needle_a"), "{message}");
    assert_eq!(mesh_panel::rows(&live)[0], rows[0]);
}
