//! The examples (the paper's `clip_plane`, `ablation` and `liver`, and the others) on the
//! software adapter: golden images of every scene, and tests of what the images mean. Each
//! example is copied to a temporary folder without its `data/`, so the clip-plane scenes use
//! their fallback phantom and give the same images on every machine.

use crate::common;

use image::RgbaImage;
use std::path::{Path, PathBuf};
use vrs_runtime::{RenderOptions, SceneRenderer};

/// Copies an example's scenes, modules and transfer functions (not its data or images) into `dir`.
fn copy_example(name: &str, dir: &Path) {
    let src = common::root().join("examples").join(name);
    for entry in std::fs::read_dir(&src).expect("example folder").filter_map(Result::ok) {
        let path = entry.path();
        if path.extension().is_some_and(|x| x == "toml" || x == "vrs" || x == "json") {
            std::fs::copy(&path, dir.join(entry.file_name())).expect("copy");
        }
    }
}

/// Small images; phantoms of 1 mm voxels at the size the example's patient-space positions
/// are written for: the examples with meshes (the ablation zones and needles, the meshes
/// example's needle) place them in millimetres in the 128^3 abdomen; 64^3 for the others.
fn small(scene: &Path) -> RenderOptions {
    let in_mm = std::fs::read_to_string(scene).is_ok_and(|text| text.contains("[[mesh]]"));
    let side = if in_mm { 128 } else { 64 };
    RenderOptions { size: Some([96, 96]), phantom_size: [side; 3], ..RenderOptions::default() }
}

fn open(scene: &Path) -> SceneRenderer {
    SceneRenderer::open(common::software_gpu(), scene, small(scene), &mut |_, _, _| {})
        .unwrap_or_else(|e| panic!("{}: {e}", scene.display()))
}

fn render(scene: &mut SceneRenderer, view: &str) -> RgbaImage {
    let images = scene.render_all().expect("render");
    images.into_iter().find(|(name, _)| name == view).expect("view").1
}

/// Pixels that differ between two images of one size.
fn differing(a: &RgbaImage, b: &RgbaImage) -> Vec<(u32, u32)> {
    a.enumerate_pixels().filter(|(x, y, p)| *p != b.get_pixel(*x, *y)).map(|(x, y, _)| (x, y)).collect()
}

#[test]
fn every_example_scene_renders_its_golden_images() {
    let mut failures = Vec::new();
    for example in ["clip_plane", "ablation", "light", "meshes", "cinematic", "liver"] {
        let dir = tempfile::tempdir().unwrap();
        copy_example(example, dir.path());
        let mut scenes: Vec<PathBuf> = std::fs::read_dir(dir.path())
            .unwrap()
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect();
        scenes.sort();
        for scene in scenes {
            let stem = scene.file_stem().unwrap().to_string_lossy().to_string();
            let mut renderer = open(&scene);
            for (view, image) in renderer.render_all().expect("render") {
                let name = format!("example_{example}_{stem}__{view}");
                if let Err(e) = common::check_golden(&name, &image) {
                    failures.push(e);
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn the_clip_plane_cuts_the_clipped_volume_and_spares_the_excluded_one() {
    let dir = tempfile::tempdir().unwrap();
    copy_example("clip_plane", dir.path());
    // With the fallback phantom all three volumes hold the same data; colour the grey matter
    // where the head phantom's brain is (hot_metal) and the white matter at its skull
    // (vessel_blue, as in the scene), so the two do not hide each other.
    let basic = dir.path().join("basic.toml");
    let text = std::fs::read_to_string(&basic).unwrap().replace("tf = \"vessel_red\"", "tf = \"hot_metal\"");
    std::fs::write(&basic, text).unwrap();
    let mut scene = open(&basic);
    let clipped = render(&mut scene, "axial");
    // The plane x = 0.5 cuts the side x < 0.5, the patient's left: the image's right half in the
    // radiological convention.
    let blue_on_cut_side = |image: &RgbaImage| {
        image.enumerate_pixels().filter(|(x, _, p)| *x >= 48 && p[2] > 120 && p[2] > p[0] + 40).count()
    };
    assert!(blue_on_cut_side(&clipped) > 10, "the white matter shows on the cut side: it is not clipped");
    // A plane with everything on its positive side: nothing is cut.
    scene.set_uniform("clip_plane_gm", [1.0f32, 0.0, 0.0, 2.0]).unwrap();
    let whole = render(&mut scene, "axial");
    let changed = differing(&clipped, &whole);
    assert!(changed.len() > 20, "the grey matter's colour is cut away ({} pixels changed)", changed.len());
    assert!(changed.iter().all(|&(x, _)| x >= 48), "only the cut side changes: {changed:?}");
    // Where the white matter shows, it shows with or without the cut (a few pixels at its
    // border blend with the grey matter behind it).
    let (cut, uncut) = (blue_on_cut_side(&clipped), blue_on_cut_side(&whole));
    assert!(cut.abs_diff(uncut) * 20 <= uncut, "white matter on the cut side: {cut} pixels cut, {uncut} whole");
    // The white matter has no clip function at all: it is excluded, so it stays whole.
    let err = scene.set_uniform("clip_plane_wm", [1.0f32, 0.0, 0.0, -0.5]).unwrap_err().to_string();
    assert!(err.contains("no uniform `clip_plane_wm`"), "{err}");

    // Scene (c): the grey matter is gone and `when active` left its clip function out.
    let without = open(&dir.path().join("without_gm.toml"));
    assert!(!without.views()[0].renderer.has_uniform("clip_plane_gm"));
    assert!(without.views()[0].renderer.has_uniform("clip_plane_wm"));
}

/// The pixel of view `index` (a slice view of `size` pixels) where patient-space point `p` (mm)
/// shows.
fn slice_pixel(scene: &SceneRenderer, index: usize, p: [f32; 3], size: u32) -> (f32, f32) {
    let ([x, y], _) = scene.slice_geometry(index).expect("a slice view").world_to_pixel(p.into());
    (x * size as f32, y * size as f32)
}

/// Pixels per millimetre of the axial view (96 pixels over the 128 mm phantom).
const AXIAL_PX_PER_MM: f32 = 96.0 / 128.0;

#[test]
fn toggling_an_applicator_changes_only_pixels_near_its_zone() {
    let dir = tempfile::tempdir().unwrap();
    copy_example("ablation", dir.path());
    let mut scene = open(&dir.path().join("scene.toml"));
    let both = render(&mut scene, "axial");
    scene.set_uniform("zone_enabled_a", false).unwrap();
    let without_a = render(&mut scene, "axial");
    let changed = differing(&both, &without_a);
    assert!(changed.len() > 30, "zone a is drawn ({} pixels)", changed.len());
    let (cx, cy) = slice_pixel(&scene, 1, [33.3, 7.7, 19.2], 96);
    let reach = 14.0 * AXIAL_PX_PER_MM + 2.0;
    for &(x, y) in &changed {
        let d = ((x as f32 + 0.5 - cx).powi(2) + (y as f32 + 0.5 - cy).powi(2)).sqrt();
        assert!(d <= reach, "pixel ({x}, {y}) changed, {d:.1} px from zone a's centre");
    }
    // And the 3D view changes too, since both views share the applicators.
    scene.set_uniform("zone_enabled_a", true).unwrap();
    let shell = render(&mut scene, "3d");
    scene.set_uniform("zone_enabled_a", false).unwrap();
    assert!(!differing(&shell, &render(&mut scene, "3d")).is_empty());
}

#[test]
fn moving_an_applicator_is_a_uniform_change_without_recompiling() {
    let dir = tempfile::tempdir().unwrap();
    copy_example("ablation", dir.path());
    let mut scene = open(&dir.path().join("scene.toml"));
    let before = render(&mut scene, "axial");
    let compiled = scene.pipeline_stats().misses;
    scene.set_uniform("zone_centre_b", [12.0f32, -6.0, 23.0]).unwrap();
    let after = render(&mut scene, "axial");
    assert!(!differing(&before, &after).is_empty(), "the zone moved");
    assert_eq!(scene.pipeline_stats().misses, compiled, "no new pipeline");

    // The same through the scene file: a reload with a moved centre composes nothing new.
    let path = dir.path().join("scene.toml");
    let text = std::fs::read_to_string(&path).unwrap().replace("[17.9, -10.2, 23.0]", "[12.0, -6.0, 23.0]");
    std::fs::write(&path, text).unwrap();
    assert!(!scene.reload().unwrap(), "a moved applicator needs no new shader");
    assert_eq!(scene.pipeline_stats().misses, compiled);
}

/// The needle follows its zone: moving `zone_centre_b` moves needle b's tip in the 3D view and
/// its crossing in the slice, and the zone with it; the mesh's colour shows where the needle
/// now is and no longer where it was.
#[test]
fn a_needle_follows_its_zone_in_both_views() {
    let dir = tempfile::tempdir().unwrap();
    copy_example("ablation", dir.path());
    let mut scene = open(&dir.path().join("scene.toml"));
    let handles = scene.mesh_handles();
    let tip = handles.iter().find(|h| h.uniform == "zone_centre_b").expect("needle b follows zone b");
    assert_eq!(tip.mesh, "needle_b");
    let before_3d = render(&mut scene, "3d");
    let generation = scene.meshes().iter().find(|m| m.name == "needle_b").map(|m| m.mesh.positions.clone());
    scene.set_uniform("zone_centre_b", [12.0f32, -6.0, 23.0]).unwrap();
    let after_3d = render(&mut scene, "3d");
    let moved = scene.meshes().iter().find(|m| m.name == "needle_b").map(|m| m.mesh.positions.clone());
    assert_ne!(generation, moved, "the needle was made again at its new tip");
    assert!(differing(&before_3d, &after_3d).len() > 20, "the needle and the zone moved in 3D");
    let h = scene.mesh_handles();
    let tip = h.iter().find(|h| h.uniform == "zone_centre_b").unwrap();
    assert_eq!(tip.point, glam::Vec3::new(12.0, -6.0, 23.0));
}

/// The liver example's occlusion group: its view differs from the view without the group only
/// where the applicators hide behind the organs, and there it shows their colour (its green
/// rises: both applicators are far greener than the organs).
#[test]
fn the_liver_example_shows_the_applicators_through_the_organs() {
    let dir = tempfile::tempdir().unwrap();
    copy_example("liver", dir.path());
    let mut scene = open(&dir.path().join("scene.toml"));
    let images = scene.render_all().expect("render");
    let view = |name: &str| images.iter().find(|(n, _)| n == name).expect("view").1.clone();
    let (occlusion, hidden) = (view("occlusion"), view("hidden"));
    let changed = differing(&occlusion, &hidden);
    assert!(changed.len() > 20, "the applicators show through the organs ({} pixels)", changed.len());
    let greener = changed.iter().filter(|&&(x, y)| occlusion.get_pixel(x, y)[1] > hidden.get_pixel(x, y)[1]).count();
    assert!(greener * 10 >= changed.len() * 9, "{greener} of {} changed pixels are greener", changed.len());
}
