//! The path tracer (`compositing = "pathtrace"`) on lavapipe, against the ray marcher of the
//! same volume, transfer function and samples: its mean picture converges to what the ray
//! marcher computes in the two cases where both compute the same integral, within the Monte
//! Carlo error each pixel's estimator allows; and its history starts again on any change.
//!
//! The error bound needs no second render: every frame's estimate X of a channel lies in
//! [0, M] (M the largest value a collision can return), so its variance is at most
//! E[X^2] <= M E[X], and the mean of N frames differs from E[X] (the ray marcher's value, up to
//! its 8-bit rounding) by at most 5 sqrt(M E[X] / N) in all but a few in a million pixels
//! (E[X] taken at the top of the ray marcher's rounding interval).
//! Pixels are independent, so the picture's mean differs by at most 3 sqrt(M sum E[X] / N) /
//! pixels.

use crate::common;

use image::RgbaImage;
use std::path::Path;
use vrs_runtime::{RenderOptions, SceneRenderer};

/// Frames (samples per pixel) the path tracer's pictures are the mean of.
const SAMPLES: u32 = 64;

/// A ball of smooth data, 48^3 voxels of 1 mm: 1000 inside, 0 outside, the value falling over
/// about 10 mm around a radius of 16 mm.
fn write_ball(dir: &Path) {
    let centre = 23.5f32;
    let values: Vec<f32> = (0..48 * 48 * 48)
        .map(|i| {
            let [x, y, z] = [i % 48, (i / 48) % 48, i / (48 * 48)].map(|c| c as f32 - centre);
            let r = (x * x + y * y + z * z).sqrt();
            1000.0 / (1.0 + ((r - 16.0) / 2.5).exp())
        })
        .collect();
    let axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    common::write_nrrd(&dir.join("ball.nrrd"), "right-anterior-superior", [48, 48, 48], axes, [0.0; 3], &values);
    // Colours that change with the value, and an opacity that lets paths reach every depth.
    let tf = r#"[{"Name": "ball", "RGBPoints": [0, 0.9, 0.3, 0.2, 500, 0.3, 0.9, 0.4, 1000, 0.2, 0.4, 1.0],
        "Points": [0, 0, 0.5, 0, 200, 0, 0.5, 0, 600, 0.08, 0.5, 0, 1000, 0.2, 0.5, 0]}]"#;
    std::fs::write(dir.join("ball.json"), tf).expect("tf written");
}

/// The scene of the ball with `render` keys and `uniforms`, one 40x40 view, no jitter (so the
/// two renderers take the same samples), no early termination or skipping in the ray marcher.
fn scene(render: &str, uniforms: &str, modules: &str) -> String {
    format!(
        "[render]\n{render}\nstep_size = 1.0\njitter = 0.0\n\n\
         [[volume]]\nname = \"ball\"\nrole = \"primary\"\npath = \"ball.nrrd\"\nwindow = [0.0, 1000.0]\ntf = \"ball.json\"\n\n\
         {modules}\
         [uniforms]\nref_step = 1.0\n{uniforms}\n\n\
         [[view]]\nname = \"3d\"\nkind = \"raycast\"\nsize = [40, 40]\ncamera = {{ azimuth = 30.0, elevation = 20.0, distance = 1.8 }}\n"
    )
}

fn open(dir: &Path, text: &str) -> SceneRenderer {
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).expect("scene written");
    let options = RenderOptions { samples: SAMPLES, ..RenderOptions::default() };
    SceneRenderer::open(common::software_gpu(), &path, options, &mut |_, _, _| {}).unwrap_or_else(|e| panic!("{e}"))
}

fn render(dir: &Path, text: &str) -> RgbaImage {
    open(dir, text).render_all().expect("renders").remove(0).1
}

/// Checks the path tracer's picture against the ray marcher's, where each frame's estimate of
/// a channel lies in [0, `largest`] (in 1 of the display's range): every pixel within five of
/// its standard errors (bounded as in the module's documentation) and 1.5/255 of rounding, the
/// picture's mean within three. Returns the mean difference, in 1/255.
fn converges(traced: &RgbaImage, marched: &RgbaImage, largest: f64) -> f64 {
    let n = f64::from(SAMPLES);
    let (mut sum_diff, mut sum_var, mut count) = (0.0, 0.0, 0.0);
    for (x, y, p) in traced.enumerate_pixels() {
        let q = marched.get_pixel(x, y);
        assert_eq!(p[3], 255, "the background is opaque");
        for c in 0..3 {
            let expected = f64::from(q[c]) / 255.0;
            // The ray marcher's value is known to within its rounding: bound by the larger end.
            let variance = largest * (expected + 0.5 / 255.0) / n;
            let diff = f64::from(p[c]) / 255.0 - expected;
            let allowed = 5.0 * variance.sqrt() + 1.5 / 255.0;
            assert!(
                diff.abs() <= allowed,
                "pixel ({x}, {y}) channel {c}: {} against {} (allowed {allowed:.4})",
                p[c],
                q[c]
            );
            sum_diff += diff;
            sum_var += variance;
            count += 1.0;
        }
    }
    let mean = sum_diff / count;
    let allowed = 3.0 * sum_var.sqrt() / count + 0.5 / 255.0;
    assert!(mean.abs() <= allowed, "mean difference {:.3}/255 (allowed {:.3}/255)", mean * 255.0, allowed * 255.0);
    mean * 255.0
}

/// With albedo 0 a collision emits its colour and ends the path: the mean picture is the
/// emission-absorption integral the ray marcher computes (DVR, unshaded, no early termination).
#[test]
fn absorption_only_converges_to_the_ray_marched_dvr() {
    let dir = tempfile::tempdir().expect("a folder");
    write_ball(dir.path());
    let marched =
        render(dir.path(), &scene("compositing = \"dvr\"\nempty_space_skipping = false", "ert_threshold = 1.01", ""));
    let traced = render(dir.path(), &scene("compositing = \"pathtrace\"", "albedo = 0.0", ""));
    assert!(marched.pixels().filter(|p| p[0] > 40).count() > 400, "the ball shows");
    let mean = converges(&traced, &marched, 1.0);
    eprintln!("absorption only, {SAMPLES} samples: mean difference {mean:.3}/255");
}

/// Replaces the ray marcher's lighting by single scattering with the isotropic phase function:
/// a light of radiance L delivers L / 4 per unit of colour (`std::path_light`'s convention),
/// through the shadow ray's transmittance.
const PHASE_LIGHTING: &str = "pipeline phase_lighting replace compositing.shading[apply_lighting] {\n    \
    uniform light_color_key: vec3f = vec3f(1.0) in 0.0 .. 4.0;\n    state shadow_key: f32 = 1.0;\n    \
    state src: vec4f = vec4f(0.0);\n\n    \
    state.src = vec4f(state.src.rgb * light_color_key * state.shadow_key * 0.25, state.src.a);\n}\n";

/// Single scattering from a directional light with the isotropic phase function (albedo 1, no
/// bounce after the first collision, no surfaces) converges to the ray marcher lit the same way
/// through shadow rays of the same light.
#[test]
fn single_scattering_converges_to_the_ray_marcher_with_shadow_rays() {
    let dir = tempfile::tempdir().expect("a folder");
    write_ball(dir.path());
    std::fs::write(dir.path().join("phase.vrs"), PHASE_LIGHTING).expect("module written");
    let light = "light_dir_key = [0.9, -0.2, 0.4]\nlight_color_key = [3.0, 3.0, 3.0]";
    let marched = render(
        dir.path(),
        &scene(
            "compositing = \"dvr\"\nshading = true\nshadows = \"rays\"\nempty_space_skipping = false",
            &format!("{light}\nert_threshold = 1.01\nshadow_cutoff = 0.0"),
            "[[module]]\npath = \"phase.vrs\"\n\n",
        ),
    );
    let traced = render(
        dir.path(),
        &scene(
            "compositing = \"pathtrace\"\nshading = true",
            &format!("{light}\nalbedo = 1.0\nmax_bounces = 0\nsurface_sharpness = 0.0\nshadow_cutoff = 0.0"),
            "",
        ),
    );
    assert!(marched.pixels().filter(|p| p[1] > 30).count() > 300, "the lit ball shows");
    let mean = converges(&traced, &marched, 0.75);
    eprintln!("single scattering, {SAMPLES} samples: mean difference {mean:.3}/255");
}

/// The history starts again on a change: after frames of one camera, the first frame of
/// another equals a fresh renderer's first frame of it, pixel for pixel (the random numbers
/// follow the frame's number in the history); unchanged, frames add up.
#[test]
fn any_change_starts_the_history_again() {
    let dir = tempfile::tempdir().expect("a folder");
    write_ball(dir.path());
    let text = scene("compositing = \"pathtrace\"\nshading = true", "", "");
    let mut renderer = open(dir.path(), &text);
    let converged = renderer.render_all().expect("renders").remove(0).1;
    let view = &mut renderer.views_mut()[0];
    view.renderer.set_samples(1);
    let one_more = renderer.render_all().expect("renders").remove(0).1;
    let moved = common::difference::Difference::between(&converged, &one_more);
    assert!(moved.mean < 1.0, "one more frame on {SAMPLES} changes little: {moved}");

    let turn = |r: &mut SceneRenderer| {
        let camera = r.views_mut()[0].camera.as_mut().expect("a raycast view");
        camera.azimuth += 40.0;
    };
    turn(&mut renderer);
    let after_change = renderer.render_all().expect("renders").remove(0).1;
    let mut fresh = open(dir.path(), &text);
    turn(&mut fresh);
    fresh.views_mut()[0].renderer.set_samples(1);
    let first = fresh.render_all().expect("renders").remove(0).1;
    assert_eq!(after_change.as_raw(), first.as_raw(), "the first frame after a change is a first frame");
}
