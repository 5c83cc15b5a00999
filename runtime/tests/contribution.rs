//! Samples that do not contribute skip the rest of their sample (`compose::contribution`): the
//! images are the same, pixel for pixel, as when every function runs for every sample. Each scene
//! is rendered twice with empty-space skipping off (which moves sample positions by rounding):
//! as composed, and with the standard writer of `contributes` removed by a user module.

mod common;

use std::path::Path;
use vrs_runtime::{RenderOptions, SceneRenderer};

/// `scene` with skipping off and, when `remove` is given, a module holding that `remove` item;
/// written beside the scene (its relative paths stay valid) and deleted after rendering.
fn render_variant(scene: &Path, remove: Option<&str>, tag: &str) -> Vec<(String, image::RgbaImage, bool)> {
    let text = std::fs::read_to_string(scene).expect("scene");
    let mut text = if text.contains("[render]") {
        text.replacen("[render]", "[render]\nempty_space_skipping = false", 1)
    } else {
        format!("[render]\nempty_space_skipping = false\n{text}")
    };
    let dir = tempfile::tempdir().expect("temp dir");
    if let Some(item) = remove {
        let module = dir.path().join("remove.vrs");
        std::fs::write(&module, format!("{item}\n")).expect("module");
        text.push_str(&format!("\n[[module]]\npath = {:?}\n", module.display().to_string()));
    }
    let stem = scene.file_stem().and_then(|s| s.to_str()).unwrap_or("scene");
    let variant = scene.with_file_name(format!(".{stem}.contribution-{tag}-{}.toml", std::process::id()));
    std::fs::write(&variant, text).expect("variant scene");
    let options = RenderOptions { phantom_size: [64, 64, 64], ..RenderOptions::default() };
    let opened = SceneRenderer::open(common::software_gpu(), &variant, options, &mut |_, _, _| {});
    let _ = std::fs::remove_file(&variant);
    let mut renderer = opened.unwrap_or_else(|e| panic!("{}: {e}", scene.display()));
    let guarded: Vec<bool> =
        renderer.views.iter().map(|v| v.renderer.shader().wgsl.contains("state.contributes")).collect();
    let images = renderer.render_all().unwrap_or_else(|e| panic!("{}: {e}", scene.display()));
    images.into_iter().zip(guarded).map(|((view, image), g)| (view, image, g)).collect()
}

fn assert_same_with_and_without(scene: &str, remove: &str) {
    let scene = common::root().join(scene);
    let with = render_variant(&scene, None, "with");
    let without = render_variant(&scene, Some(remove), "without");
    assert!(with.iter().any(|(_, _, guarded)| *guarded), "{}: no view tests `contributes`", scene.display());
    for ((view, a, _), (_, b, guarded)) in with.iter().zip(&without) {
        assert!(!guarded, "{}: `{remove}` left a writer of `contributes` in view {view}", scene.display());
        let differing = a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count();
        assert_eq!(differing, 0, "{} view {view}: {differing} pixels differ", scene.display());
    }
}

#[test]
fn shaded_dvr_is_the_same_with_and_without_skipping_transparent_samples() {
    assert_same_with_and_without("examples/basic/scene.toml", "remove shading.lights[dvr_contributes];");
}

#[test]
fn dvr_with_additional_volumes_is_the_same_with_and_without_skipping() {
    // Three volumes (the MNI152 template or its phantom fallbacks), one clipped by a user module.
    assert_same_with_and_without("examples/clip_plane/shaded.toml", "remove shading.lights[dvr_contributes];");
}

#[test]
fn mip_is_the_same_with_and_without_classifying_only_new_maxima() {
    assert_same_with_and_without(
        "tests/fixtures/render/head_mip.toml",
        "remove classification.primary[mip_contributes];",
    );
}
