//! The live loop on the software adapter, without a window: recomposition after edits, the last
//! good state through a broken edit, and the user's settings across reloads.

use std::path::Path;
use vrs_live::{Failure, LiveScene, MeshStyle};
use vrs_runtime::{AdapterChoice, Gpu, OrbitCamera, RenderOptions, SceneRenderer, Value};

const MODULE: &str = "pipeline dim after classification.primary {\n    uniform k: f32 = 0.5 in 0.0 .. 1.0;\n    \
                      state color: vec4f;\n    state.color = state.color * k;\n}\n";

fn scene(k: f32, extra_view: bool) -> String {
    let mut text = format!(
        "[render]\ncompositing = \"dvr\"\n\n[[volume]]\nname = \"v\"\nrole = \"primary\"\nphantom = \"head\"\n\
         tf = \"ct_bone\"\n\n[[module]]\npath = \"dim.vrs\"\n\n[uniforms]\nk = {k:.2}\n\n\
         [[view]]\nname = \"3d\"\nkind = \"raycast\"\nsize = [32, 32]\n"
    );
    if extra_view {
        text.push_str("\n[[view]]\nname = \"axial\"\nkind = \"slice\"\naxis = \"z\"\nsize = [32, 32]\n");
    }
    text
}

fn open(dir: &Path) -> LiveScene {
    std::fs::write(dir.join("dim.vrs"), MODULE).unwrap();
    std::fs::write(dir.join("scene.toml"), scene(0.5, false)).unwrap();
    let gpu = Gpu::headless(AdapterChoice::Software).expect("the software adapter (lavapipe) is required");
    let options = RenderOptions { phantom_size: [32, 32, 32], ..RenderOptions::default() };
    let renderer = SceneRenderer::open(gpu, &dir.join("scene.toml"), options, &mut |_, _, _| {}).unwrap();
    LiveScene::new(renderer)
}

fn uniform(live: &LiveScene, name: &str) -> Option<Value> {
    let view = live.renderer().views().first()?;
    view.renderer.uniforms().get(name)
}

#[test]
fn the_watched_files_are_the_scene_and_its_modules() {
    let dir = tempfile::tempdir().unwrap();
    let live = open(dir.path());
    let names: Vec<String> =
        live.files().iter().filter_map(|p| p.file_name()).map(|n| n.to_string_lossy().into_owned()).collect();
    assert!(names.contains(&"scene.toml".to_string()) && names.contains(&"dim.vrs".to_string()), "{names:?}");
    assert!(live.files().iter().all(|p| p.exists()), "only real files: {:?}", live.files());
}

#[test]
fn a_uniform_edit_recompiles_nothing_and_a_structural_edit_swaps_the_pipeline() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = open(dir.path());
    let generation = live.generation(0);
    std::fs::write(dir.path().join("scene.toml"), scene(0.25, false)).unwrap();
    let rebuild = live.rebuild();
    let applied = rebuild.outcome.as_ref().expect("a good edit applies");
    assert!(!applied.composed && applied.compiled == 0, "{applied:?}");
    assert_eq!(uniform(&live, "k"), Some(Value::Float(vec![0.25])));
    assert!(live.generation(0) > generation, "the view must render again");

    std::fs::write(dir.path().join("dim.vrs"), MODULE.replace("* k;", "* k * k;")).unwrap();
    let applied = live.rebuild().outcome.expect("a good edit applies");
    assert!(applied.composed && applied.compiled == 1 && applied.recompiled == ["3d"], "{applied:?}");
}

#[test]
fn a_broken_edit_keeps_the_last_good_pipeline_and_a_fix_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = open(dir.path());
    let before = live.renderer().views()[0].renderer.shader().reflection.structural_hash.clone();
    std::fs::write(dir.path().join("dim.vrs"), MODULE.replace("* k;", "* kk;")).unwrap();
    let rebuild = live.rebuild();
    assert!(matches!(rebuild.outcome, Err(Failure::Compose)));
    let text = rebuild.error_text().unwrap();
    assert!(text.contains("E0502") && text.contains("dim.vrs:4"), "diagnostics with file:line: {text}");
    assert_eq!(live.last_error(), Some(text.as_str()));
    assert_eq!(live.renderer().views()[0].renderer.shader().reflection.structural_hash, before);
    let image = live.render_all().expect("the last good pipeline still renders");
    assert_eq!(image.len(), 1);

    std::fs::write(dir.path().join("dim.vrs"), MODULE).unwrap();
    assert!(live.rebuild().succeeded());
    assert_eq!(live.last_error(), None);
}

/// The viewer validates a scene as `vrsc build` does: a uniform renamed in `[uniforms]` (a
/// value change, which reuses the composition when it is valid) fails with build's E0702.
#[test]
fn a_renamed_uniform_value_fails_as_build_fails() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = open(dir.path());
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, scene(0.5, false).replace("k = 0.50", "kk = 0.50")).unwrap();
    let rebuild = live.rebuild();
    assert!(matches!(rebuild.outcome, Err(Failure::Compose)), "the viewer refuses it");
    let text = rebuild.error_text().unwrap();
    let built = vrsc::compose::build::build_scene(&path, None).unwrap();
    assert!(built.diags.has_errors(), "build refuses it");
    for d in built.diags.iter() {
        assert!(text.contains(&d.message), "build's `{}` is said in the viewer: {text}", d.message);
    }
    assert!(text.contains("E0702") && text.contains("`kk`"), "{text}");
    std::fs::write(&path, scene(0.5, false)).unwrap();
    assert!(live.rebuild().succeeded());
}

#[test]
fn user_uniforms_and_cameras_survive_a_reload_unless_the_scene_changes_them() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = open(dir.path());
    live.set_uniform("k", Value::Float(vec![0.9])).unwrap();
    let camera = OrbitCamera { azimuth: 123.0, ..live.camera(0).unwrap() };
    live.set_camera(0, camera);
    live.set_size(0, [48, 40]).expect("a size the device holds");

    // A structural edit elsewhere: the user's value, camera and size stay.
    std::fs::write(dir.path().join("dim.vrs"), MODULE.replace("* k;", "* k * 1.0;")).unwrap();
    assert!(live.rebuild().succeeded());
    assert_eq!(uniform(&live, "k"), Some(Value::Float(vec![0.9])));
    assert_eq!(live.camera(0), Some(camera));
    assert_eq!(live.size(0), Some([48, 40]));

    // The scene file changes the uniform itself: the file is the newer intent.
    std::fs::write(dir.path().join("scene.toml"), scene(0.1, false)).unwrap();
    assert!(live.rebuild().succeeded());
    assert_eq!(uniform(&live, "k"), Some(Value::Float(vec![0.1])));

    live.reset_view(0);
    assert_ne!(live.camera(0), Some(camera));
}

#[test]
fn adding_and_removing_a_view_follows_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = open(dir.path());
    std::fs::write(dir.path().join("scene.toml"), scene(0.5, true)).unwrap();
    assert!(live.rebuild().succeeded());
    assert_eq!(live.view_names(), ["3d", "axial"]);
    assert!(live.slice(1).is_some());
    std::fs::write(dir.path().join("scene.toml"), scene(0.5, false)).unwrap();
    assert!(live.rebuild().succeeded());
    assert_eq!(live.view_names(), ["3d"]);
}

#[test]
fn changing_a_volume_loads_it_again() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = open(dir.path());
    std::fs::write(
        dir.path().join("scene.toml"),
        scene(0.5, false).replace("phantom = \"head\"", "phantom = \"abdomen\""),
    )
    .unwrap();
    let applied = live.rebuild().outcome.expect("a good edit applies");
    assert!(applied.volumes_reloaded);
    assert!(live.render_all().is_ok());
}

#[test]
fn saved_uniforms_reload_to_the_same_values_and_keep_the_comments() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = open(dir.path());
    let path = dir.path().join("scene.toml");
    let commented = scene(0.5, false).replace("k = 0.50\n", "# how dim\nk = 0.50 # half\n");
    std::fs::write(&path, &commented).unwrap();
    live.rebuild().outcome.expect("a good edit applies");
    live.set_uniform("k", Value::Float(vec![0.125])).unwrap();
    live.set_uniform("jitter", Value::Float(vec![0.0])).unwrap();
    assert_eq!(live.save_uniforms().unwrap(), 2);
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("# how dim\nk = 0.125 # half\n"), "{text}");
    assert!(text.contains("[render]\ncompositing = \"dvr\"\njitter = 0.0\n"), "{text}");
    live.rebuild().outcome.expect("the saved scene loads");
    assert_eq!(uniform(&live, "k"), Some(Value::Float(vec![0.125])));
    assert_eq!(uniform(&live, "jitter"), Some(Value::Float(vec![0.0])));
    // The file now carries the values: a reset finds them there.
    live.reset_uniform("k").unwrap();
    assert_eq!(uniform(&live, "k"), Some(Value::Float(vec![0.125])));
}

#[test]
fn an_edited_transfer_function_saves_as_a_colormap_that_loads_back_to_the_same_table() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = open(dir.path());
    let status = live.renderer().volumes()[0];
    let (window, mut curve) = (status.window, status.curve.unwrap().in_data_units(status.window));
    curve.opacity.push((window[0] + 0.6 * (window[1] - window[0]), 0.35));
    curve.color[1].1 = [0.2, 0.9, 0.4];
    let edited = curve.table().over_window(window);
    live.set_tf_curve("v", curve.clone()).unwrap();
    let generation = live.generation(0);
    live.rebuild().outcome.expect("an unchanged scene applies");
    assert_eq!(live.renderer().volumes()[0].curve, Some(&curve), "the edit survives a reload");
    live.save_tf_curve("v", &dir.path().join("v_tf.json")).unwrap();
    let text = std::fs::read_to_string(dir.path().join("scene.toml")).unwrap();
    assert!(text.contains("tf = \"v_tf.json\""), "{text}");
    live.rebuild().outcome.expect("the saved colormap loads");
    let loaded = live.renderer().volumes()[0].curve.unwrap().table().over_window(window);
    assert_eq!(loaded.to_rgba16f(), edited.to_rgba16f());
    assert!(live.generation(0) > generation);
}

/// `step_size` of view `index`.
fn step_size(live: &LiveScene, index: usize) -> Option<Value> {
    live.renderer().views().get(index)?.renderer.uniforms().get("step_size")
}

/// A view's own `render` table is that view's scene value: changing it in the file beats the
/// user's value in that view only, and a structural change there recomposes that view alone.
#[test]
fn a_change_to_one_views_own_render_table_rebuilds_that_view() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = open(dir.path());
    let two_views = |own: &str| {
        format!(
            "{}\n[[view]]\nname = \"side\"\nkind = \"raycast\"\nsize = [32, 32]\nrender = {{ {own} }}\n",
            scene(0.5, false)
        )
    };
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, two_views("step_size = 0.5")).unwrap();
    live.rebuild().outcome.expect("a good edit applies");
    assert_eq!(step_size(&live, 1), Some(Value::Float(vec![0.5])));
    live.set_uniform("step_size", Value::Float(vec![2.0])).unwrap();
    assert_eq!(step_size(&live, 0), Some(Value::Float(vec![2.0])));

    // Only the second view's own table changes: the file wins there; the first view's scene
    // value did not change, so the user's value stays there.
    std::fs::write(&path, two_views("step_size = 1.0")).unwrap();
    let applied = live.rebuild().outcome.expect("a good edit applies");
    assert_eq!(applied.compiled, 0, "a uniform-only change compiles nothing: {applied:?}");
    assert_eq!(step_size(&live, 1), Some(Value::Float(vec![1.0])), "the view's own render table wins");
    assert_eq!(
        step_size(&live, 0),
        Some(Value::Float(vec![2.0])),
        "the user's value stays where the file is unchanged"
    );
    // A reset gives each view its own scene value.
    live.reset_uniform("step_size").unwrap();
    assert_eq!(step_size(&live, 1), Some(Value::Float(vec![1.0])));

    // Shading in the second view's own table: that view alone is composed and compiled anew.
    std::fs::write(&path, two_views("step_size = 1.0, shading = true")).unwrap();
    let applied = live.rebuild().outcome.expect("a good edit applies");
    assert_eq!(applied.recompiled, ["side"], "{applied:?}");
    assert!(live.renderer().views()[1].renderer.has_uniform("gradient_to_world"));
    assert!(!live.renderer().views()[0].renderer.has_uniform("gradient_to_world"));
}

/// A size the GPU refuses (beyond its 2D texture limit) is an error of `set_size`: the view
/// keeps its size, its output texture and so its last good picture, and renders as before.
#[test]
fn a_size_the_gpu_refuses_keeps_the_last_good_picture() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = open(dir.path());
    let before = live.render_all().expect("renders")[0].1.clone();
    let output = live.output(0).cloned();
    let refused = live.set_size(0, [65536, 16]).expect_err("beyond every device's limit");
    assert!(matches!(refused, vrs_runtime::RuntimeError::Device(_)), "{refused}");
    assert_eq!(live.size(0), Some([32, 32]));
    assert!(live.output(0) == output.as_ref(), "the output texture is the one with the last picture");
    assert_eq!(live.render_all().expect("still renders")[0].1, before);
    assert_eq!(live.renderer().gpu().take_fault(), None, "the error was captured, not left behind");
}

const MARK: &str = "pipeline mark after classification.primary {\n    \
                    uniform centre: vec3f = vec3f(0.0) in -150.0 .. 150.0;\n    \
                    uniform axis: vec3f = vec3f(0.0, 0.0, 1.0) in -1.0 .. 1.0;\n    \
                    state color: vec4f;\n    \
                    state.color = state.color * (1.0 + 0.0 * (centre.x + axis.x));\n}\n";

/// A scene with a needle and a ball following `centre` (the needle's direction follows `axis`)
/// and a fixed block of colour `block`.
fn mesh_scene(block: [f32; 3], ball_opacity: f32) -> String {
    format!(
        "[render]\ncompositing = \"dvr\"\n\n[[volume]]\nname = \"v\"\nrole = \"primary\"\nphantom = \"head\"\n\
         tf = \"ct_bone\"\n\n[[module]]\npath = \"mark.vrs\"\n\n[uniforms]\ncentre = [1.0, 2.0, 3.0]\n\n\
         [[mesh]]\nname = \"needle\"\nshape = \"needle\"\ntip = \"centre\"\ndirection = \"axis\"\nlength = 50.0\n\n\
         [[mesh]]\nname = \"ball\"\nshape = \"sphere\"\ncentre = \"centre\"\nradius = 5.0\nopacity = {ball_opacity:.2}\n\n\
         [[mesh]]\nname = \"block\"\nshape = \"box\"\nmin = [-5.0, -5.0, -5.0]\nmax = [5.0, 5.0, 5.0]\n\
         color = [{:.2}, {:.2}, {:.2}]\n\n[[view]]\nname = \"3d\"\nkind = \"raycast\"\nsize = [32, 32]\n",
        block[0], block[1], block[2]
    )
}

fn open_meshes(dir: &Path) -> LiveScene {
    std::fs::write(dir.join("mark.vrs"), MARK).unwrap();
    std::fs::write(dir.join("scene.toml"), mesh_scene([0.5, 0.5, 0.5], 1.0)).unwrap();
    let gpu = Gpu::headless(AdapterChoice::Software).expect("the software adapter (lavapipe) is required");
    let options = RenderOptions { phantom_size: [32, 32, 32], ..RenderOptions::default() };
    let renderer = SceneRenderer::open(gpu, &dir.join("scene.toml"), options, &mut |_, _, _| {}).unwrap();
    LiveScene::new(renderer)
}

fn style_of(live: &LiveScene, mesh: &str) -> MeshStyle {
    live.meshes().into_iter().find(|(name, _)| name == mesh).map(|(_, style)| style).expect("the mesh")
}

/// A red, half transparent style 10 mm to the right.
fn red_moved() -> MeshStyle {
    let mut model = MeshStyle::IDENTITY;
    model[3] = [10.0, 0.0, 0.0, 1.0];
    MeshStyle { color: [1.0, 0.0, 0.0], opacity: 0.5, model }
}

#[test]
fn a_mesh_style_survives_reloads_until_the_scene_changes_that_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = open_meshes(dir.path());
    let names: Vec<String> = live.meshes().into_iter().map(|(n, _)| n).collect();
    assert_eq!(names, ["needle", "ball", "block"]);
    let scene_ball = style_of(&live, "ball");
    assert_eq!(scene_ball.model, MeshStyle::IDENTITY);
    let generation = live.generation(0);
    live.set_mesh_style("ball", red_moved()).unwrap();
    assert_eq!(style_of(&live, "ball"), red_moved());
    assert!(live.is_user_mesh("ball") && !live.is_user_mesh("block"));
    assert!(live.generation(0) > generation, "the picture is out of date");
    assert!(live.set_mesh_style("nothing", red_moved()).is_err());
    let nan = MeshStyle { opacity: f32::NAN, ..red_moved() };
    assert!(live.set_mesh_style("ball", nan).is_err(), "a NaN is refused");
    let clamped = MeshStyle { opacity: 7.0, ..red_moved() };
    live.set_mesh_style("block", clamped).unwrap();
    assert_eq!(style_of(&live, "block").opacity, 1.0);
    live.reset_mesh_style("block").unwrap();
    assert_eq!(style_of(&live, "block").color, [0.5, 0.5, 0.5]);
    assert!(!live.is_user_mesh("block"));

    // Another mesh's table changes (all meshes are made again): the user's style comes back.
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, mesh_scene([0.0, 0.0, 1.0], 1.0)).unwrap();
    assert!(live.rebuild().succeeded());
    assert_eq!(style_of(&live, "block").color, [0.0, 0.0, 1.0]);
    assert_eq!(style_of(&live, "ball"), red_moved());

    // The scene file changes the ball itself: the file is the newer intent.
    std::fs::write(&path, mesh_scene([0.0, 0.0, 1.0], 0.75)).unwrap();
    assert!(live.rebuild().succeeded());
    assert_eq!(style_of(&live, "ball"), MeshStyle { opacity: 0.75, ..scene_ball });
    assert!(!live.is_user_mesh("ball"));
}

/// `mesh_scene` with the block hiding the ball in an occlusion group of `opacity` (0.5 without
/// it), under the view's volume.
fn occlusion_scene(block: [f32; 3], opacity: Option<f32>) -> String {
    let opacity = opacity.map_or(String::new(), |k| format!("opacity = {k:.2}\n"));
    let group =
        format!("[[group]]\nname = \"hidden\"\nkind = \"occlusion\"\n{opacity}children = [\"block\", \"ball\"]\n\n");
    mesh_scene(block, 1.0)
        .replace("[[view]]", &format!("{group}[[view]]"))
        .replace("size = [32, 32]\n", "size = [32, 32]\npicture = [\"hidden\", \"volume\"]\n")
}

#[test]
fn an_occlusion_groups_opacity_survives_reloads_until_the_scene_changes_it() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = open_meshes(dir.path());
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, occlusion_scene([0.5, 0.5, 0.5], None)).unwrap();
    assert!(live.rebuild().succeeded());
    assert_eq!(live.occlusion_groups(), [("hidden".to_string(), 0.5)]);
    let generation = live.generation(0);
    live.set_group_opacity("hidden", 0.8).unwrap();
    assert_eq!(live.occlusion_groups(), [("hidden".to_string(), 0.8)]);
    assert!(live.is_user_group("hidden") && live.generation(0) > generation);
    assert!(live.set_group_opacity("nothing", 0.5).is_err());

    // A mesh changes: the user's opacity stays.
    std::fs::write(&path, occlusion_scene([0.0, 0.0, 1.0], None)).unwrap();
    assert!(live.rebuild().succeeded());
    assert_eq!(live.occlusion_groups(), [("hidden".to_string(), 0.8)]);
    live.reset_group_opacity("hidden").unwrap();
    assert_eq!(live.occlusion_groups(), [("hidden".to_string(), 0.5)]);
    assert!(!live.is_user_group("hidden"));

    // The file changes the group's opacity: the file is the newer intent.
    live.set_group_opacity("hidden", 0.8).unwrap();
    std::fs::write(&path, occlusion_scene([0.0, 0.0, 1.0], Some(0.3))).unwrap();
    assert!(live.rebuild().succeeded());
    assert_eq!(live.occlusion_groups(), [("hidden".to_string(), 0.3)]);
    assert!(!live.is_user_group("hidden"));
}

#[test]
fn dragging_a_followed_point_moves_its_meshes_and_keeps_the_users_style() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = open_meshes(dir.path());
    // The needle's direction is not a point to drag.
    let handles: Vec<(String, String)> = live.mesh_handles().into_iter().map(|h| (h.mesh, h.uniform)).collect();
    let pairs = [("needle", "centre"), ("ball", "centre")].map(|(m, u)| (m.to_string(), u.to_string()));
    assert_eq!(handles, pairs);
    assert_eq!(live.mesh_handles()[0].point.to_array(), [1.0, 2.0, 3.0]);

    live.set_mesh_style("ball", red_moved()).unwrap();
    let generation = live.generation(0);
    live.set_uniform("centre", Value::Float(vec![20.0, 2.0, 3.0])).unwrap();
    assert!(live.generation(0) > generation);
    live.render_all().expect("renders");
    // The ball was made again around its new centre, and is still drawn in the user's style.
    let ball = live.renderer().meshes().iter().find(|m| m.name == "ball").unwrap();
    let (low, high) = ball.mesh.bounds().unwrap();
    assert!(((low[0] + high[0]) / 2.0 - 20.0).abs() < 0.01, "{low:?} {high:?}");
    assert_eq!(style_of(&live, "ball"), red_moved());
    assert_eq!(live.mesh_handles()[1].point.to_array(), [20.0, 2.0, 3.0]);
}

/// A view's own window (a slice view's window/level) changes that view's picture only, stays
/// through a reload, and a reset gives it the volume's transfer function again.
#[test]
fn a_views_own_window_changes_its_picture_only_and_survives_a_reload() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = open(dir.path());
    std::fs::write(dir.path().join("scene.toml"), scene(0.5, true)).unwrap();
    assert!(live.rebuild().succeeded());
    let before = live.render_all().unwrap();
    let volume = live.renderer().volumes()[0];
    let (name, window, curve) = (volume.name.to_string(), volume.window, volume.curve.cloned().unwrap());
    // The axial view (1) narrowed to half the width around the same level.
    live.set_view_tf_curve(1, &name, curve.window_levelled(window, 0.0, 0.5)).unwrap();
    let own = live.render_all().unwrap();
    assert_eq!(own[0].1, before[0].1, "the 3D view keeps the volume's transfer function");
    assert_ne!(own[1].1, before[1].1, "the axial view shows its own window");
    // A structural edit reloads the scene: the view's window stays.
    std::fs::write(dir.path().join("dim.vrs"), MODULE.replace("* k;", "* k * 1.0;")).unwrap();
    assert!(live.rebuild().succeeded());
    assert!(live.view_tf_curve(1, &name).is_some());
    assert_eq!(live.render_all().unwrap()[1].1, own[1].1, "the window survives the reload");
    live.reset_view_tf_curve(1, &name).unwrap();
    assert!(live.view_tf_curve(1, &name).is_none());
    assert_eq!(live.render_all().unwrap()[1].1, before[1].1, "reset: the volume's transfer function again");
}
