//! The cost of light transport on the software adapter (lavapipe), each against the frame it
//! adds to, in one run with the variants taking turns round after round: HDR with Reinhard's
//! tone mapping over plain shaded DVR (target 1.15x at most), shadows from light volumes over
//! the shaded frame at a preview resolution (target 2x at most; the light-volume pass, which
//! runs once when the light or the transfer function changes, timed on its own), shadow rays
//! (the reference), pre-integration over point sampling at the same step, pre-integrated
//! lighting over pre-integrated classification, ambient occlusion over the shaded frame, and
//! one frame of the path tracer (one sample per pixel, its lights' shadow rays included).
//!
//! The volume is the MNI152 T1 of `../shared/data` when it is there, else the built-in head
//! phantom (said in the output). Run: `cargo bench -p vrs-runtime --bench light`; settings:
//! `VRS_BENCH_SIZE` (256), `VRS_BENCH_ROUNDS` (4), `VRS_BENCH_FRAMES` (2).

#[path = "timing.rs"]
mod timing;

use std::path::Path;
use std::time::Instant;
use timing::{frame_times_of, median};
use vrs_runtime::{AdapterChoice, Gpu, RenderOptions, SceneRenderer};

const MNI_T1: &str = "../shared/data/mni152/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz";

/// The light example's scene with one 3D view whose render table is `render`.
fn scene(volume: &str, size: u32, render: &str) -> String {
    let light = "[uniforms]\nlight_dir_key = [0.8, 0.3, 0.6]\nlight_color_key = [2.0, 2.0, 2.0]\n";
    let uniforms = if render.contains("shading = false") { "" } else { light };
    format!(
        "[render]\ncompositing = \"dvr\"\nshading = true\nlights = [\"key\"]\njitter = 1.0\n\n\
         [[volume]]\nname = \"t1\"\nrole = \"primary\"\n{volume}\ntf = \"skin.json\"\n\n{uniforms}\n\
         [[view]]\nname = \"3d\"\nkind = \"raycast\"\nsize = [{size}, {size}]\n\
         camera = {{ azimuth = 35.0, elevation = 15.0, distance = 2.4 }}\nrender = {{ {render} }}\n"
    )
}

fn number(name: &str, default: usize) -> usize {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).filter(|&n| n > 0).unwrap_or(default)
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mni = root.join(MNI_T1);
    let volume = if mni.exists() {
        println!("volume: the MNI152 T1 (197 x 233 x 189)");
        format!("path = {:?}", mni.display().to_string())
    } else {
        println!("volume: the head phantom (128^3; {} is absent)", mni.display());
        "phantom = \"head\"".to_string()
    };
    let (size, rounds, frames) =
        (number("VRS_BENCH_SIZE", 256) as u32, number("VRS_BENCH_ROUNDS", 4), number("VRS_BENCH_FRAMES", 2));
    let gpu = Gpu::headless(AdapterChoice::Software).expect("the software adapter");
    println!("adapter: {}, {size}x{size}, {rounds} rounds of {frames} frames", gpu.adapter);
    let dir = tempfile::tempdir().expect("a folder");
    std::fs::copy(root.join("examples/light/skin.json"), dir.path().join("skin.json")).expect("the example's tf");
    let variants = [
        ("shaded", ""),
        ("shaded + HDR (Reinhard)", "tone_mapping = \"reinhard\""),
        ("shaded + light-volume shadows", "shadows = \"volume\""),
        ("shaded + shadow rays", "shadows = \"rays\""),
        ("shaded, step 2 mm", "step_size = 2.0"),
        ("shaded, step 2 mm, pre-integrated", "step_size = 2.0, preintegration = true"),
        ("unshaded", "shading = false"),
        ("unshaded + HDR (Reinhard)", "shading = false, tone_mapping = \"reinhard\""),
        ("unshaded + HDR, automatic exposure", "shading = false, tone_mapping = \"reinhard\", auto_exposure = true"),
        ("shaded + ambient occlusion", "ambient_occlusion = true"),
        ("shaded, step 2 mm, pre-integrated lighting", "step_size = 2.0, preintegration = \"lighting\""),
        ("path-traced, one sample per pixel", "compositing = \"pathtrace\""),
    ];
    let mut renderers: Vec<SceneRenderer> = variants
        .iter()
        .enumerate()
        .map(|(i, (_, render))| {
            let path = dir.path().join(format!("scene{i}.toml"));
            std::fs::write(&path, scene(&volume, size, render)).expect("scene written");
            SceneRenderer::open(gpu.clone(), &path, RenderOptions::default(), &mut |_, _, _| {}).expect("opens")
        })
        .collect();
    let mut times = vec![Vec::new(); variants.len()];
    for _ in 0..rounds {
        for (renderer, times) in renderers.iter_mut().zip(&mut times) {
            times.extend(frame_times_of(renderer, 0, frames));
        }
    }
    let medians: Vec<f64> = times.into_iter().map(median).collect();
    for ((name, _), ms) in variants.iter().zip(&medians) {
        println!("{name:<44} {ms:8.1} ms");
    }
    println!("HDR over shaded:                     {:.3}x (target <= 1.15)", medians[1] / medians[0]);
    println!("HDR over unshaded DVR:               {:.3}x (target <= 1.15)", medians[7] / medians[6]);
    println!("HDR + automatic exposure over DVR:   {:.3}x", medians[8] / medians[6]);
    println!("light-volume shadows over shaded:    {:.3}x (target <= 2)", medians[2] / medians[0]);
    println!("shadow rays over shaded:             {:.3}x", medians[3] / medians[0]);
    println!("pre-integrated over point (2 mm):    {:.3}x", medians[5] / medians[4]);
    println!("ambient occlusion over shaded:       {:.3}x", medians[9] / medians[0]);
    println!("pre-integrated lighting over classification only (2 mm): {:.3}x", medians[10] / medians[5]);
    println!("pre-integrated lighting over point (2 mm):               {:.3}x", medians[10] / medians[4]);
    println!("one path-traced sample per pixel over shaded:            {:.3}x", medians[11] / medians[0]);
    // The light-volume pass: a frame after the light moved, less a frame.
    let shadowed = &mut renderers[2];
    let mut passes = Vec::new();
    for round in 0..rounds {
        let direction = glam::Vec3::new(0.8, 0.3 + 0.01 * (round + 1) as f32, 0.6);
        shadowed.set_uniform("light_dir_key", direction).expect("the light's direction");
        let start = Instant::now();
        frame_times_of(shadowed, 0, 0);
        passes.push(start.elapsed().as_secs_f64() * 1e3 - medians[2]);
    }
    println!("light-volume pass (once per light or TF change): {:.1} ms", median(passes));
}
