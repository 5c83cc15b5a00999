//! Probes on the software adapter: golden images of `t`, `gradient` and `accum` on the head
//! phantom and of a user's field (the ablation example's `zone_a`), exact values through the
//! GPU, and probe settings that change without a new pipeline. Golden images are
//! `tests/golden/probe_SCENE__VIEW.FIELD.png`, compared as `golden.rs` says.

use crate::common;

use vrs_runtime::{ProbeAt, ProbeSpec, RenderOptions, SceneRenderer};

/// Phantoms of 64^3 voxels of 1 mm, but for the ablation example, whose zones are placed in
/// millimetres in the 128^3 abdomen.
fn open(scene: &str) -> SceneRenderer {
    let gpu = common::software_gpu();
    let side = if scene.contains("ablation") { 128 } else { 64 };
    let options = RenderOptions { phantom_size: [side; 3], size: Some([96, 96]), ..RenderOptions::default() };
    let path = common::root().join(scene);
    SceneRenderer::open(gpu, &path, options, &mut |_, _, _| {}).unwrap_or_else(|e| panic!("{scene}: {e}"))
}

fn view_index(renderer: &SceneRenderer, name: &str) -> usize {
    renderer.views().iter().position(|v| v.name == name).expect("view")
}

#[test]
fn probes_match_their_golden_images() {
    let cases: &[(&str, &str, &str, &str, Option<ProbeAt>)] = &[
        ("head_dvr", "tests/fixtures/render/head_dvr.toml", "3d", "t", None),
        ("head_dvr", "tests/fixtures/render/head_dvr.toml", "3d", "gradient", None),
        ("head_dvr", "tests/fixtures/render/head_dvr.toml", "3d", "accum", None),
        ("head_dvr", "tests/fixtures/render/head_dvr.toml", "axial", "gradient", None),
        ("ablation", "examples/ablation/scene.toml", "3d", "zone_a", None),
        ("ablation", "examples/ablation/scene.toml", "axial", "zone_a", Some(ProbeAt::Sample(0))),
    ];
    let mut failures = Vec::new();
    let mut scene: Option<(&str, SceneRenderer)> = None;
    for &(stem, path, view, field, at) in cases {
        if scene.as_ref().is_none_or(|(s, _)| *s != stem) {
            scene = Some((stem, open(path)));
        }
        let Some((_, renderer)) = scene.as_mut() else { unreachable!("just opened") };
        let index = view_index(renderer, view);
        let probe = renderer
            .render_probe(index, &ProbeSpec { field: field.into(), at })
            .unwrap_or_else(|e| panic!("{stem} {view}.{field}: {e}"));
        let legend = probe.legend();
        assert!(probe.values.count() > 0, "{legend}");
        if let Err(e) = common::check_golden(&format!("probe_{stem}__{view}.{field}"), &probe.image) {
            failures.push(format!("{e}\n  {legend}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// `pixel` is the pixel's centre, which the entry point computes as (id + 0.5) / size in f32:
/// the probe must give back exactly those numbers.
#[test]
fn a_probe_carries_exact_values() {
    let mut renderer = open("tests/fixtures/render/head_dvr.toml");
    let index = view_index(&renderer, "3d");
    let probe = renderer.render_probe(index, &ProbeSpec::of("pixel")).expect("probe");
    let (w, h) = probe.image.dimensions();
    assert_eq!(probe.values.count(), (w * h) as usize, "every pixel has a pixel centre");
    for (x, y) in [(0, 0), (17, 3), (w - 1, h - 1)] {
        let want = [f64::from((x as f32 + 0.5) / w as f32), f64::from((y as f32 + 0.5) / h as f32)];
        assert_eq!(probe.values.at(x, y), Some(&want[..]), "pixel ({x}, {y})");
    }
}

/// Threshold and sample index are uniforms of the probe variant: changing them renders again
/// with the same pipeline, and gives another image.
#[test]
fn probe_settings_need_no_new_pipeline() {
    let mut renderer = open("tests/fixtures/render/head_dvr.toml");
    let index = view_index(&renderer, "3d");
    let at = |a| ProbeSpec { field: "t".into(), at: Some(ProbeAt::Opacity(a)) };
    let near = renderer.render_probe(index, &at(0.1)).expect("probe");
    let misses = renderer.pipeline_stats().misses;
    let far = renderer.render_probe(index, &at(0.9)).expect("probe");
    assert_eq!(renderer.pipeline_stats().misses, misses, "a threshold change compiled a pipeline");
    let (x, y) = (48, 48);
    let (Some(near), Some(far)) = (near.values.at(x, y), far.values.at(x, y)) else {
        panic!("the centre ray reaches both thresholds")
    };
    assert!(far[0] > near[0], "a higher threshold lies deeper: {} vs {}", far[0], near[0]);
    let first = renderer.render_probe(index, &ProbeSpec { field: "t".into(), at: Some(ProbeAt::Sample(0)) });
    assert!(first.expect("probe").values.at(x, y).is_some_and(|t| t[0] < near[0]));
}

#[test]
fn wrong_requests_are_errors() {
    let mut renderer = open("tests/fixtures/render/head_dvr.toml");
    let index = view_index(&renderer, "3d");
    let unknown = renderer.render_probe(index, &ProbeSpec::of("gradiant")).expect_err("an error").to_string();
    assert!(unknown.contains("E0801") && unknown.contains("did you mean `gradient`?"), "{unknown}");
    let at_finish = ProbeSpec { field: "t".into(), at: Some(ProbeAt::Finish) };
    let finish = renderer.render_probe(index, &at_finish).expect_err("an error").to_string();
    assert!(finish.contains("sample field"), "{finish}");
    let fields = renderer.probe_fields(index).expect("fields");
    assert!(fields.iter().any(|f| f.name == "gradient" && !f.ray));
}
