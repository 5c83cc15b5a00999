//! Empty-space skipping (`std::skip`, `std::skip_mip`, `std::skip_iso`) changes nothing but the
//! work: for each compositing mode that skips, the image with skipping is the one without (up to
//! the rounding of the sample positions the jumps land on), and the rays take fewer samples;
//! with DVR, an additional volume's content is never skipped, whatever its grid.

use crate::common;

use vrs_runtime::{RenderOptions, SceneRenderer};

/// The head phantom under a bone transfer function, in compositing mode `MODE`, skipping `SKIP`
/// (the iso value, 0.35 of the CT presets' window, is 409 HU: the 64^3 phantom's band-limited
/// skull peaks at 735 HU).
const SCENE: &str = r#"
[render]
compositing = "MODE"
iso_value = 0.35
empty_space_skipping = SKIP
jitter = 0.0

[[volume]]
name = "head"
role = "primary"
phantom = "head"
tf = "ct_bone"

[[view]]
name = "3d"
kind = "raycast"
size = [64, 64]
camera = { azimuth = 30.0, elevation = 20.0, distance = 2.2 }
"#;

/// Replaces the pixel's colour by its ray's number of samples over 1000 (in red).
const COUNT: &str = r#"
pipeline count_sample in start {
    @ray state n_samples: f32 = 0.0;
    state.n_samples += 1.0;
}
pipeline show_count after ray.finish {
    @ray state n_samples: f32 = 0.0;
    @ray state out_color: vec4f = vec4f(0.0);
    state.out_color = vec4f(state.n_samples / 1000.0, 0.0, 0.0, 1.0);
}
"#;

/// The image of view `3d`, and whether its shader skips (holds a skipping function); `skip`
/// sets `empty_space_skipping` (`None`: the default).
fn render(mode: &str, skip: Option<bool>, count: bool) -> (image::RgbaImage, bool) {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut text = match skip {
        Some(skip) => SCENE.replace("MODE", mode).replace("SKIP", &skip.to_string()),
        None => SCENE.replace("MODE", mode).replace("empty_space_skipping = SKIP\n", ""),
    };
    if mode != "iso" {
        text = text.replace("iso_value = 0.45\n", "");
    }
    if count {
        std::fs::write(dir.path().join("count.vrs"), COUNT).expect("module");
        text.push_str("\n[[module]]\npath = \"count.vrs\"\n");
    }
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).expect("scene");
    let options = RenderOptions { phantom_size: [64, 64, 64], ..RenderOptions::default() };
    let mut scene = SceneRenderer::open(common::software_gpu(), &path, options, &mut |_, _, _| {}).expect("scene");
    let wgsl = scene.views()[0].renderer.shader().wgsl.clone();
    let skips = ["skip_empty(", "skip_below_max(", "skip_below_surface("].iter().any(|f| wgsl.contains(f));
    (scene.render_all().expect("render").remove(0).1, skips)
}

fn mean_samples(image: &image::RgbaImage) -> f64 {
    image.pixels().map(|p| f64::from(p[0]) / 255.0 * 1000.0).sum::<f64>() / f64::from(image.width() * image.height())
}

fn assert_skipping_keeps_the_image(mode: &str) {
    let (with, skips) = render(mode, Some(true), false);
    let (without, skips_without) = render(mode, Some(false), false);
    assert!(skips && !skips_without, "{mode}: skipping is selected by the key");
    assert!(without.pixels().filter(|p| p[0] > 0).count() > 500, "{mode}: the head is visible");
    let worst = with.pixels().zip(without.pixels()).flat_map(|(a, b)| (0..4).map(move |c| a[c].abs_diff(b[c]))).max();
    assert!(worst.unwrap_or(0) <= 2, "{mode}: largest channel difference {worst:?}");
    let (taken, all) =
        (mean_samples(&render(mode, Some(true), true).0), mean_samples(&render(mode, Some(false), true).0));
    assert!(taken < 0.8 * all, "{mode}: {taken:.1} samples per ray with skipping, {all:.1} without");
}

#[test]
fn dvr_skipping_keeps_the_image_with_fewer_samples() {
    assert_skipping_keeps_the_image("dvr");
}

#[test]
fn mip_skipping_keeps_the_image_with_fewer_samples() {
    assert_skipping_keeps_the_image("mip");
}

#[test]
fn iso_skipping_keeps_the_image_with_fewer_samples() {
    assert_skipping_keeps_the_image("iso");
}

#[test]
fn skipping_is_on_by_default_where_it_is_exact() {
    for mode in ["dvr", "mip", "iso"] {
        assert!(render(mode, None, false).1, "{mode}: no skipping by default");
    }
    assert!(!render("minip", None, false).1, "MinIP reads every sample");
}

/// An additional volume on a coarser grid turned 30 degrees, holding a bright ball off the
/// centre, appended to `SCENE` in DVR with a primary the transfer function makes transparent
/// everywhere: DVR may skip only where neither is visible, so the ball must show exactly as
/// without skipping.
const BALL: &str = r#"
[[volume]]
name = "ball"
role = "additional"
path = "ball.nrrd"
tf = "ct_bone"
"#;

fn ball_scene(skip: bool) -> String {
    let primary = SCENE.replace("MODE", "dvr").replace("SKIP", &skip.to_string()).replace("iso_value = 0.45\n", "");
    primary.replace("tf = \"ct_bone\"", "tf = \"transparent.json\"") + BALL
}

/// Writes `ball.nrrd` (20^3 voxels of 5 mm, turned 30 degrees about the patient's z axis, a
/// ball of 1000 HU in -1000) and `transparent.json` (no opacity anywhere) into `dir`.
fn write_ball_files(dir: &std::path::Path) {
    let n = 20u32;
    let values: Vec<f32> = (0..n * n * n)
        .map(|i| {
            let p = glam::Vec3::new((i % n) as f32, (i / n % n) as f32, (i / (n * n)) as f32);
            if p.distance(glam::Vec3::new(13.0, 8.0, 10.0)) < 4.0 { 1000.0 } else { -1000.0 }
        })
        .collect();
    let (c, s) = (30f32.to_radians().cos() * 5.0, 30f32.to_radians().sin() * 5.0);
    let directions = [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 5.0]];
    common::write_nrrd(
        &dir.join("ball.nrrd"),
        "right-anterior-superior",
        [n; 3],
        directions,
        [-45.0, -55.0, -50.0],
        &values,
    );
    let transparent = r#"[{"Name": "transparent", "RGBPoints": [-1024, 1, 1, 1, 3071, 1, 1, 1], "Points": [-1024, 0, 0.5, 0, 3071, 0, 0.5, 0]}]"#;
    std::fs::write(dir.join("transparent.json"), transparent).expect("tf");
}

#[test]
fn dvr_skipping_never_skips_an_additional_volume() {
    let dir = tempfile::tempdir().expect("temp dir");
    write_ball_files(dir.path());
    let render = |skip: bool| {
        let path = dir.path().join(format!("scene_{skip}.toml"));
        std::fs::write(&path, ball_scene(skip)).expect("scene");
        let options = RenderOptions { phantom_size: [64, 64, 64], ..RenderOptions::default() };
        let mut scene = SceneRenderer::open(common::software_gpu(), &path, options, &mut |_, _, _| {})
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(scene.views()[0].renderer.shader().wgsl.contains("skip_empty("), skip);
        scene.render_all().expect("render").remove(0).1
    };
    let (with, without) = (render(true), render(false));
    let ball = without.pixels().filter(|p| p[0] > 0).count();
    assert!(ball > 20, "the ball is visible: {ball} pixels");
    let worst = with.pixels().zip(without.pixels()).flat_map(|(a, b)| (0..4).map(move |c| a[c].abs_diff(b[c]))).max();
    assert!(worst.unwrap_or(0) <= 2, "largest channel difference {worst:?}");
}
