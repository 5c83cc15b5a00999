//! Samples that do not contribute skip the rest of their sample, and MIP classifies only the
//! sample it keeps, once per ray (`compose::contribution`): the images are the same, pixel for
//! pixel, as when every function runs for every sample. Each scene is rendered twice with
//! empty-space skipping off (which moves sample positions by rounding): as composed, and with
//! the standard writer of the flag removed by a user module (for MIP, which needs its flag, in
//! favour of the per-sample selection it replaced).

use crate::common;

use std::path::Path;
use vrs_runtime::{RenderOptions, SceneRenderer};

/// `scene` with skipping off and, when `module` is given, a module of that text;
/// written beside the scene (its relative paths stay valid) and deleted after rendering.
fn render_variant(scene: &Path, module: Option<&str>, tag: &str) -> Vec<(String, image::RgbaImage, bool)> {
    let text = std::fs::read_to_string(scene).expect("scene");
    let mut text = if text.contains("[render]") {
        text.replacen("[render]", "[render]\nempty_space_skipping = false", 1)
    } else {
        format!("[render]\nempty_space_skipping = false\n{text}")
    };
    let dir = tempfile::tempdir().expect("temp dir");
    if let Some(item) = module {
        let module = dir.path().join("variant.vrs");
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
    let flags = ["state.contributes", "state.selected"];
    let guarded: Vec<bool> =
        renderer.views().iter().map(|v| flags.iter().any(|f| v.renderer.shader().wgsl.contains(f))).collect();
    let images = renderer.render_all().unwrap_or_else(|e| panic!("{}: {e}", scene.display()));
    images.into_iter().zip(guarded).map(|((view, image), g)| (view, image, g)).collect()
}

fn assert_same_with_and_without(scene: &str, module: &str) {
    let scene = common::root().join(scene);
    let with = render_variant(&scene, None, "with");
    let without = render_variant(&scene, Some(module), "without");
    assert!(with.iter().any(|(_, _, guarded)| *guarded), "{}: no view tests a flag", scene.display());
    for ((view, a, _), (_, b, guarded)) in with.iter().zip(&without) {
        assert!(!guarded, "{}: `{module}` left a writer of a flag in view {view}", scene.display());
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

/// MIP as it was composited before the `selected` flag: every sample classified, the colour of
/// each new maximum kept as it comes.
const MIP_PER_SAMPLE: &str = r#"remove classification.primary[mip_keep];
pipeline mip_per_sample replace compositing.alpha[mip_select] {
    state value: f32 = 0.0;
    state src: vec4f = vec4f(0.0);
    @ray state mip_max: f32 = -1.0;
    @ray state accum: vec4f = vec4f(0.0);
    @ray state terminate: bool = false;
    if state.value > state.mip_max {
        state.mip_max = state.value;
        state.accum = vec4f(state.src.rgb * state.src.a, state.src.a);
    }
    if state.mip_max >= 1.0 {
        state.terminate = true;
    }
}"#;

#[test]
fn mip_classifying_its_maximum_once_per_ray_is_the_same_as_classifying_every_sample() {
    assert_same_with_and_without("tests/fixtures/render/head_mip.toml", MIP_PER_SAMPLE);
}

#[test]
fn shaded_mip_classifying_its_maximum_once_per_ray_is_the_same_as_classifying_every_sample() {
    assert_same_with_and_without("tests/fixtures/contribution/head_mip_shaded.toml", MIP_PER_SAMPLE);
}
