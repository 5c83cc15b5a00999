//! The cost of bricked sampling on the software adapter (lavapipe): the same volume rendered
//! from one texture and from bricks all resident (a page-table read and a pool sample for
//! every sample, and the request word rays write), in one run with the variants taking turns
//! round after round. Bricked volumes skip no empty space (their value ranges are not known
//! before their bricks load), so the single-texture row it is held to skips none either; the
//! single texture with skipping, the scene's default, is shown for context. Target: bricked
//! over single texture at most 1.3x at 512^2.
//!
//! The volume is the MNI152 T1 of `../shared/data` when it is there, else the built-in head
//! phantom at 256^3 (said in the output). Run: `cargo bench -p vrs-runtime --bench bricks`;
//! settings: `VRS_BENCH_SIZE` (512), `VRS_BENCH_ROUNDS` (4), `VRS_BENCH_FRAMES` (2),
//! `VRS_BENCH_SHADING` (0; 1 for shaded DVR).

#[path = "timing.rs"]
mod timing;

use std::path::Path;
use timing::{frame_times, median};
use vrs_runtime::{AdapterChoice, Gpu, RenderOptions, SceneRenderer};

const MNI_T1: &str = "../shared/data/mni152/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz";

fn number(name: &str, default: usize) -> usize {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).filter(|&n| n > 0).unwrap_or(default)
}

fn scene(volume: &str, size: u32, shading: bool, bricks: bool, skipping: bool) -> String {
    format!(
        "[render]\ncompositing = \"dvr\"\nshading = {shading}\njitter = 1.0\nempty_space_skipping = {skipping}\n\n\
         [[volume]]\nname = \"t1\"\nrole = \"primary\"\n{volume}\nbricks = {bricks}\n\n\
         [[view]]\nname = \"3d\"\nkind = \"raycast\"\nsize = [{size}, {size}]\n\
         camera = {{ azimuth = 35.0, elevation = 15.0, distance = 2.4 }}\n"
    )
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mni = root.join(MNI_T1);
    let (volume, options) = if mni.exists() {
        println!("volume: the MNI152 T1 (197 x 233 x 189)");
        (format!("path = {:?}", mni.display().to_string()), RenderOptions::default())
    } else {
        println!("volume: the head phantom at 256^3 ({} is absent)", mni.display());
        ("phantom = \"head\"".to_string(), RenderOptions { phantom_size: [256; 3], ..RenderOptions::default() })
    };
    let (size, rounds, frames) =
        (number("VRS_BENCH_SIZE", 512) as u32, number("VRS_BENCH_ROUNDS", 4), number("VRS_BENCH_FRAMES", 2));
    let shading = std::env::var("VRS_BENCH_SHADING").is_ok_and(|v| v != "0" && v != "false");
    let gpu = Gpu::headless(AdapterChoice::Software).expect("the software adapter");
    let dir = tempfile::tempdir().expect("a folder");
    println!("adapter: {}, {size}x{size}, {rounds} rounds of {frames} frames, shading {shading}", gpu.adapter);
    // (name, bricked, skipping)
    let variants = [
        ("single texture, no skipping", false, false),
        ("bricked, all resident", true, false),
        ("single texture, skipping", false, true),
    ];
    let mut renderers: Vec<SceneRenderer> = variants
        .iter()
        .enumerate()
        .map(|(i, &(_, bricks, skipping))| {
            let path = dir.path().join(format!("scene{i}.toml"));
            std::fs::write(&path, scene(&volume, size, shading, bricks, skipping)).expect("scene written");
            let mut renderer =
                SceneRenderer::open(gpu.clone(), &path, options.clone(), &mut |_, _, _| {}).expect("opens");
            // Streams every brick the view needs: the timed frames find them resident.
            renderer.render_all().expect("renders");
            renderer
        })
        .collect();
    let residency = renderers[1].brick_residency();
    println!(
        "bricks: {} resident, {} of one value, {} pending",
        residency.resident, residency.constant, residency.pending
    );
    let mut times = vec![Vec::new(); variants.len()];
    for _ in 0..rounds {
        for (renderer, times) in renderers.iter_mut().zip(&mut times) {
            times.extend(frame_times(renderer, frames));
        }
    }
    let medians: Vec<f64> = times.into_iter().map(median).collect();
    for ((name, _, _), ms) in variants.iter().zip(&medians) {
        println!("{name:<30} {ms:8.1} ms");
    }
    println!("bricked over single texture: {:.3}x (target <= 1.3)", medians[1] / medians[0]);
}
