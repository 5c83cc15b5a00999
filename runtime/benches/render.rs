//! Rendering speed on the software adapter (lavapipe): the default scene's 3D view
//! (examples/basic/scene.toml) at 512x512, composed shader against a hand-written raycaster
//! doing the same work (benches/handwritten_raycaster.wgsl; both without empty-space skipping),
//! with and without early ray termination, then the scene as it is (with skipping). Run:
//! `cargo bench -p vrs-runtime --bench render`. The comparison with other renderers is
//! `benches/peers/`.
//!
//! Frames are timed from submit to completion (no read-back); the two shaders take turns for
//! several rounds and each reports its median, in one run so the ratios compare like with like.
//! Wall-clock times on a shared 2-core machine vary by 10-20% between runs:
//! `scripts/bench-instructions.sh` counts the instructions lavapipe executes per frame instead
//! (deterministic, under valgrind). Samples per second counts the samples the rays take
//! without early termination (computed on the CPU from the same camera).

#[path = "timing.rs"]
mod timing;

use std::path::Path;
use timing::{frame_times, median};
use vrs_runtime::reflection::{Reflection, content_hash};
use vrs_runtime::{AdapterChoice, Gpu, RenderOptions, SceneRenderer, ViewShader};

/// Settings from the environment: `VRS_BENCH_SIZE` (512), `VRS_BENCH_ROUNDS` (4),
/// `VRS_BENCH_FRAMES` (frames per round, 2), `VRS_BENCH_ONLY` (`composed` or `hand-written`: time
/// that shader alone, without early termination, and skip the rest; for instruction counts).
struct Config {
    size: u32,
    rounds: usize,
    frames: usize,
    only: Option<String>,
}

impl Config {
    fn from_env() -> Config {
        let number = |name: &str, default: usize| {
            std::env::var(name).ok().and_then(|v| v.parse().ok()).filter(|&n| n > 0).unwrap_or(default)
        };
        Config {
            size: number("VRS_BENCH_SIZE", 512) as u32,
            rounds: number("VRS_BENCH_ROUNDS", 4),
            frames: number("VRS_BENCH_FRAMES", 2),
            only: std::env::var("VRS_BENCH_ONLY").ok(),
        }
    }
}

/// Median frame time of each shader, the shaders taking turns round after round so that a slow
/// spell of a shared machine hits them alike.
fn compare(scene: &mut SceneRenderer, shaders: &[ViewShader], ert_threshold: f32, config: &Config) -> Vec<f64> {
    let mut times = vec![Vec::new(); shaders.len()];
    for _ in 0..config.rounds {
        for (shader, times) in shaders.iter().zip(&mut times) {
            scene.replace_shader(0, shader.clone()).expect("pipeline");
            scene.views_mut()[0].renderer.set_uniform("ert_threshold", ert_threshold).expect("ert uniform");
            times.extend(frame_times(scene, config.frames));
        }
    }
    times.into_iter().map(median).collect()
}

/// Samples of every ray without early termination: ceil((exit - entry) / step) per pixel.
fn samples_per_frame(scene: &SceneRenderer, size: u32) -> f64 {
    let view = &scene.views()[0];
    let camera = view.camera.expect("a raycast view");
    // Steps of `step_size` mm through `volume_to_world`, as `std::raycast` takes them (the
    // uniforms as the last encoded frame left them).
    let floats = |name: &str| match view.renderer.uniforms().get(name) {
        Some(vrs_runtime::Value::Float(v)) => v,
        other => panic!("uniform {name}: {other:?}"),
    };
    let step = floats("step_size")[0];
    let to_world = glam::Mat4::from_cols_slice(&floats("volume_to_world"));
    let m = camera.inv_view_proj(to_world, 1.0);
    let mut total = 0f64;
    for y in 0..size {
        for x in 0..size {
            let ndc =
                glam::Vec2::new((x as f32 + 0.5) / size as f32 * 2.0 - 1.0, 1.0 - (y as f32 + 0.5) / size as f32 * 2.0);
            let near = m.project_point3(ndc.extend(0.0));
            let dir = (m.project_point3(ndc.extend(1.0)) - near).normalize();
            let inv = dir.recip();
            let (t0, t1) = (-near * inv, (glam::Vec3::ONE - near) * inv);
            let entry = t0.min(t1).max_element().max(0.0);
            let exit = t0.max(t1).min_element();
            let dt = step / to_world.transform_vector3(dir).length().max(1e-6);
            if exit > entry {
                total += f64::from(((exit - entry) / dt).ceil());
            }
        }
    }
    total
}

fn handwritten(composed: &ViewShader) -> ViewShader {
    let wgsl = include_str!("handwritten_raycaster.wgsl").to_string();
    let mut reflection: Reflection = (*composed.reflection).clone();
    reflection.wgsl_hash = content_hash(&wgsl);
    reflection.structural_hash = format!("handwritten-{}", reflection.wgsl_hash);
    ViewShader::new(wgsl, reflection, Path::new("handwritten_raycaster.wgsl")).expect("hash matches")
}

fn main() {
    let config = Config::from_env();
    let size = config.size;
    let gpu = Gpu::headless(AdapterChoice::Software).expect("the software adapter (mesa-vulkan-drivers)");
    println!("adapter: {}", gpu.adapter);
    let scene_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/basic/scene.toml");
    // The hand-written shader does not skip empty space: compare it with the composed one with
    // skipping off (the same samples), and time the scene as it is (skipping on) below.
    let dir = std::env::temp_dir().join(format!("vrs-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let text = std::fs::read_to_string(&scene_path)
        .expect("scene")
        .replace("[render]", "[render]\nempty_space_skipping = false");
    let plain_path = dir.join("scene.toml");
    std::fs::write(&plain_path, text).expect("temp scene");
    let options = RenderOptions { size: Some([size, size]), ..RenderOptions::default() };
    let mut scene = SceneRenderer::open(gpu, &plain_path, options, &mut |_, _, _| {}).expect("scene");
    let composed = scene.views()[0].renderer.shader().clone();
    let shaders = [composed.clone(), handwritten(&composed)];
    let labels = ["composed", "hand-written"];

    if let Some(only) = &config.only {
        let k = labels.iter().position(|l| l == only).expect("VRS_BENCH_ONLY is composed or hand-written");
        let ms = compare(&mut scene, &shaders[k..=k], 2.0, &config)[0];
        println!("{only}: {ms:.1} ms/frame without early termination ({size}x{size})");
        return;
    }

    let with_ert = compare(&mut scene, &shaders, 0.99, &config);
    let samples = samples_per_frame(&scene, size);
    let without_ert = compare(&mut scene, &shaders, 2.0, &config);
    for (k, label) in labels.iter().enumerate() {
        println!(
            "{label:>12}: {:7.1} ms/frame with early termination, {:7.1} ms without ({:.2}x); {:.1} M samples/s \
             without",
            with_ert[k],
            without_ert[k],
            without_ert[k] / with_ert[k],
            samples / without_ert[k] / 1e3
        );
    }
    println!(
        "composed / hand-written: {:.3} with early termination, {:.3} without",
        with_ert[0] / with_ert[1],
        without_ert[0] / without_ert[1]
    );
    println!("samples per frame without early termination: {samples:.0}");
    println!("mean |composed - hand-written| (RGBA, 0-255): {:.3}", image_difference(&mut scene, &shaders));

    // Empty-space skipping: the scene as it is (skipping is on by default).
    let options = RenderOptions { size: Some([size, size]), ..RenderOptions::default() };
    let gpu = scene.gpu().clone();
    let mut skipping = SceneRenderer::open(gpu, &scene_path, options, &mut |_, _, _| {}).expect("skipping scene");
    let skipping_shader = [skipping.views()[0].renderer.shader().clone()];
    let skip_ert = compare(&mut skipping, &skipping_shader, 0.99, &config)[0];
    let skip_no_ert = compare(&mut skipping, &skipping_shader, 2.0, &config)[0];
    println!(
        "empty-space skipping: {skip_ert:7.1} ms/frame with early termination ({:.2}x faster), {skip_no_ert:7.1} ms \
         without ({:.2}x faster)",
        with_ert[0] / skip_ert,
        without_ert[0] / skip_no_ert
    );

    gradient_floor(&mut scene, &composed, &dir, &plain_path, options_of(size), &config);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The mean absolute channel difference of the two shaders' images of view 0: the shaders do the
/// same work when it is (nearly) 0.
fn image_difference(scene: &mut SceneRenderer, shaders: &[ViewShader; 2]) -> f64 {
    let mut images = shaders.iter().map(|shader| {
        scene.replace_shader(0, shader.clone()).expect("pipeline");
        scene.render_all().expect("render").remove(0).1
    });
    let (a, b) = (images.next().expect("composed"), images.next().expect("hand-written"));
    let total: u64 = a.as_raw().iter().zip(b.as_raw()).map(|(x, y)| u64::from(x.abs_diff(*y))).sum();
    total as f64 / a.as_raw().len() as f64
}

fn options_of(size: u32) -> RenderOptions {
    RenderOptions { size: Some([size, size]), ..RenderOptions::default() }
}

/// The gradient replaced by one fetch of the volume: not a gradient (the image differs), but no
/// precomputed gradient texture can cost less than one (four-channel) trilinear fetch per
/// shaded sample, so the time saved here bounds what such a texture could save over six fetches.
const ONE_FETCH_GRADIENT: &str = r#"
pipeline one_fetch_gradient replace sampling.gradient[sample_gradient] {
    uniform volume: volume;
    state pos: vec3f = vec3f(0.0);
    state gradient: vec3f = vec3f(0.0);
    state.gradient = vec3f(sample(volume, state.pos + vec3f(0.001)) - 0.5, 0.5, 0.5);
}
"#;

/// Times the composed shader without skipping (six fetches per gradient) against the same scene
/// whose gradient is [`ONE_FETCH_GRADIENT`], with early termination.
fn gradient_floor(
    scene: &mut SceneRenderer,
    composed: &ViewShader,
    dir: &Path,
    plain: &Path,
    options: RenderOptions,
    config: &Config,
) {
    std::fs::write(dir.join("one_fetch.vrs"), ONE_FETCH_GRADIENT).expect("module");
    let text = std::fs::read_to_string(plain).expect("scene") + "\n[[module]]\npath = \"one_fetch.vrs\"\n";
    let path = dir.join("one_fetch.toml");
    std::fs::write(&path, text).expect("scene");
    let one = SceneRenderer::open(scene.gpu().clone(), &path, options, &mut |_, _, _| {}).expect("one-fetch scene");
    let shaders = [composed.clone(), one.views()[0].renderer.shader().clone()];
    let times = compare(scene, &shaders, 0.99, config);
    println!(
        "gradient: six fetches {:7.1} ms/frame, one fetch (the floor of a gradient texture) {:7.1} ms ({:.2}x)",
        times[0],
        times[1],
        times[0] / times[1]
    );
}
