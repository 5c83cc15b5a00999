//! Rendering speed on the software adapter (lavapipe): the default scene's 3D view
//! (examples/basic/scene.toml) at 512x512, composed shader against a hand-written raycaster
//! doing the same work (benches/handwritten_raycaster.wgsl), with and without early ray
//! termination. Run: `cargo bench -p vrs-runtime --bench render`.
//!
//! Frames are timed from submit to completion (no read-back), median of `FRAMES`, in one run so
//! the ratios compare like with like. Samples per second counts the samples the rays take
//! without early termination (computed on the CPU from the same camera).

use std::path::Path;
use std::time::Instant;
use vrs_runtime::reflection::{Reflection, content_hash};
use vrs_runtime::{AdapterChoice, Gpu, RenderOptions, SceneRenderer, ViewShader};

const FRAMES: usize = 9;
const SIZE: u32 = 512;

fn median_frame_ms(scene: &mut SceneRenderer, view: usize) -> f64 {
    let mut times = Vec::with_capacity(FRAMES);
    for i in 0..=FRAMES {
        let mut encoder = scene.gpu().device.create_command_encoder(&Default::default());
        scene.encode_view(view, &mut encoder).expect("encode");
        let start = Instant::now();
        scene.gpu().queue.submit([encoder.finish()]);
        scene.gpu().wait();
        if i > 0 {
            times.push(start.elapsed().as_secs_f64() * 1e3);
        }
    }
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// Samples of every ray without early termination: ceil((exit - entry) / step) per pixel.
fn samples_per_frame(scene: &SceneRenderer) -> f64 {
    let view = &scene.views[0];
    let camera = view.camera.expect("a raycast view");
    let m = camera.inv_view_proj(glam::Vec3::ONE, 1.0);
    let step = 0.0025f32;
    let mut total = 0f64;
    for y in 0..SIZE {
        for x in 0..SIZE {
            let ndc =
                glam::Vec2::new((x as f32 + 0.5) / SIZE as f32 * 2.0 - 1.0, 1.0 - (y as f32 + 0.5) / SIZE as f32 * 2.0);
            let near = m.project_point3(ndc.extend(0.0));
            let dir = (m.project_point3(ndc.extend(1.0)) - near).normalize();
            let inv = dir.recip();
            let (t0, t1) = (-near * inv, (glam::Vec3::ONE - near) * inv);
            let entry = t0.min(t1).max_element().max(0.0);
            let exit = t0.max(t1).min_element();
            if exit > entry {
                total += f64::from(((exit - entry) / step).ceil());
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
    let gpu = Gpu::headless(AdapterChoice::Software).expect("the software adapter (mesa-vulkan-drivers)");
    println!("adapter: {}", gpu.adapter);
    let scene_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/basic/scene.toml");
    let options = RenderOptions { size: Some([SIZE, SIZE]), ..RenderOptions::default() };
    let mut scene = SceneRenderer::open(gpu, &scene_path, options, &mut |_, _, _| {}).expect("scene");
    let samples = samples_per_frame(&scene);
    let composed = scene.views[0].renderer.shader().clone();

    let mut results = Vec::new();
    for (label, shader) in [("composed", composed.clone()), ("hand-written", handwritten(&composed))] {
        scene.replace_shader(0, shader).expect("pipeline");
        let with_ert = median_frame_ms(&mut scene, 0);
        scene.views[0].renderer.set_uniform("ert_threshold", 2.0f32).expect("ert uniform");
        let without_ert = median_frame_ms(&mut scene, 0);
        println!(
            "{label:>12}: {with_ert:7.1} ms/frame with early termination, {without_ert:7.1} ms without \
             ({:.2}x); {:.1} M samples/s without",
            without_ert / with_ert,
            samples / without_ert / 1e3
        );
        results.push((with_ert, without_ert));
    }
    let (c, h) = (results[0], results[1]);
    println!("composed / hand-written: {:.3} with early termination, {:.3} without", c.0 / h.0, c.1 / h.1);
    println!("samples per frame without early termination: {samples:.0}");

    // Empty-space skipping: the same scene with `empty_space_skipping = true`.
    let dir = std::env::temp_dir().join(format!("vrs-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let text = std::fs::read_to_string(&scene_path)
        .expect("scene")
        .replace("[render]", "[render]\nempty_space_skipping = true");
    let skip_path = dir.join("scene.toml");
    std::fs::write(&skip_path, text).expect("temp scene");
    let options = RenderOptions { size: Some([SIZE, SIZE]), ..RenderOptions::default() };
    let gpu = scene.gpu().clone();
    let mut skipping = SceneRenderer::open(gpu, &skip_path, options, &mut |_, _, _| {}).expect("skipping scene");
    let skip_ert = median_frame_ms(&mut skipping, 0);
    skipping.views[0].renderer.set_uniform("ert_threshold", 2.0f32).expect("ert uniform");
    let skip_no_ert = median_frame_ms(&mut skipping, 0);
    println!(
        "empty-space skipping: {skip_ert:7.1} ms/frame with early termination ({:.2}x faster), {skip_no_ert:7.1} ms \
         without ({:.2}x faster)",
        c.0 / skip_ert,
        c.1 / skip_no_ert
    );
    let _ = std::fs::remove_dir_all(&dir);
}
