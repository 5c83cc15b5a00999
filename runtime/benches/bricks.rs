//! The cost of bricked sampling on the software adapter (lavapipe): the same volume rendered
//! from one texture and from bricks all resident, in one run with the variants taking turns
//! round after round. Rays march the bricked volume brick by brick (the full lookup once per
//! brick a ray crosses, the brick's pool slot read directly in between); the row "full lookup
//! every sample" is the standard lookup without its segment functions, as before that march.
//! Rows 0 and 1 skip no empty space, rows 2 and 3 do (a bricked volume skips the bricks it has
//! read and found invisible). Target: bricked over single texture at most 1.15x at 512^2, either
//! way.
//!
//! A row's time is the median over rounds of each round's median frame; its ratio to row 0 is
//! printed twice: as the ratio of the medians and as the median of the per-round ratios.
//!
//! The volume is the MNI152 T1 of `../shared/data` when it is there, else the built-in head
//! phantom at 256^3 (said in the output). Run: `cargo bench -p vrs-runtime --bench bricks`;
//! settings: `VRS_BENCH_SIZE` (512), `VRS_BENCH_ROUNDS` (4), `VRS_BENCH_FRAMES` (2),
//! `VRS_BENCH_SHADING` (0; 1 for shaded DVR), `VRS_BENCH_COMPOSITING` (`dvr`; `mip` for maximum
//! intensity projection), `VRS_BENCH_LOOKUP` (lookup files, comma
//! separated: a bricked row each with the scene's `lookup = FILE`, to weigh one's own lookup
//! against the standard one), `VRS_BENCH_NO_ERT` (1: no early ray termination, so every ray
//! takes the same samples whatever a lookup answers), `VRS_BENCH_ERT` (the early termination
//! threshold; 0.99 unless set), `VRS_BENCH_ONLY` (a row's number: time
//! that row alone, for instruction counts: `bash scripts/bench-instructions.sh bricks ROWS`).

#[path = "timing.rs"]
mod timing;

use std::path::Path;
use timing::{frame_times, median};
use vrs_runtime::{AdapterChoice, Gpu, RenderOptions, SceneRenderer};

const MNI_T1: &str = "../shared/data/mni152/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz";

fn number(name: &str, default: usize) -> usize {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).filter(|&n| n > 0).unwrap_or(default)
}

/// One row of the table: how its volume is kept.
struct Variant {
    name: String,
    bricks: bool,
    skipping: bool,
    /// A lookup file replacing the standard one.
    lookup: Option<String>,
}

impl Variant {
    fn new(name: &str, bricks: bool, skipping: bool) -> Variant {
        Variant { name: name.to_string(), bricks, skipping, lookup: None }
    }
}

fn flag(name: &str) -> bool {
    std::env::var(name).is_ok_and(|v| v != "0" && v != "false")
}

/// `VRS_BENCH_COMPOSITING`: the scene's compositing (`dvr` unless set).
fn compositing() -> String {
    std::env::var("VRS_BENCH_COMPOSITING").unwrap_or_else(|_| "dvr".to_string())
}

fn scene(volume: &str, size: u32, shading: bool, variant: &Variant) -> String {
    let Variant { bricks, skipping, .. } = variant;
    let compositing = compositing();
    let no_ert = flag("VRS_BENCH_NO_ERT");
    let ert = std::env::var("VRS_BENCH_ERT").ok();
    let uniforms = match (no_ert, ert) {
        (true, _) => "[uniforms]\nert_threshold = 2.0\n\n".to_string(),
        (false, Some(ert)) => format!("[uniforms]\nert_threshold = {ert}\n\n"),
        (false, None) => String::new(),
    };
    let lookup = variant.lookup.as_ref().map(|file| format!("lookup = {file:?}\n")).unwrap_or_default();
    format!(
        "[render]\ncompositing = {compositing:?}\nshading = {shading}\njitter = 1.0\nempty_space_skipping = {skipping}\n\n\
         [[volume]]\nname = \"t1\"\nrole = \"primary\"\n{volume}\nbricks = {bricks}\n{lookup}\n\
         [[view]]\nname = \"3d\"\nkind = \"raycast\"\nsize = [{size}, {size}]\n\
         camera = {{ azimuth = 35.0, elevation = 15.0, distance = 2.4 }}\n\n{uniforms}"
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
    let shading = flag("VRS_BENCH_SHADING");
    let gpu = Gpu::headless(AdapterChoice::Software).expect("the software adapter");
    let dir = tempfile::tempdir().expect("a folder");
    let compositing = compositing();
    println!(
        "adapter: {}, {size}x{size}, {rounds} rounds of {frames} frames, {compositing}, shading {shading}",
        gpu.adapter
    );
    let mut variants = vec![
        Variant::new("single texture, no skipping", false, false),
        Variant::new("bricked, all resident", true, false),
        Variant::new("single texture, skipping", false, true),
        Variant::new("bricked, skipping", true, true),
    ];
    // The standard lookup without its segment functions: every sample takes the full lookup,
    // as before rays marched brick by brick.
    let standard = std::fs::read_to_string(root.join("stdlib/bricks.wgsl")).expect("stdlib/bricks.wgsl");
    let segments = standard.find("// Opens a segment").expect("the segment functions of stdlib/bricks.wgsl");
    let per_sample = dir.path().join("per_sample.wgsl");
    std::fs::write(&per_sample, &standard[..segments]).expect("lookup written");
    let name = "bricked, full lookup every sample";
    variants.push(Variant { lookup: Some(per_sample.display().to_string()), ..Variant::new(name, true, false) });
    let name = "bricked, full lookup every sample, skipping";
    variants.push(Variant { lookup: Some(per_sample.display().to_string()), ..Variant::new(name, true, true) });
    let lookups = std::env::var("VRS_BENCH_LOOKUP").unwrap_or_default();
    for file in lookups.split(',').filter(|f| !f.is_empty()) {
        let path = std::fs::canonicalize(file).expect("the lookup file exists");
        let name = format!("bricked, {}", path.file_name().unwrap_or_default().to_string_lossy());
        variants.push(Variant { lookup: Some(path.display().to_string()), ..Variant::new(&name, true, false) });
    }
    let only =
        std::env::var("VRS_BENCH_ONLY").ok().map(|n| n.parse::<usize>().expect("VRS_BENCH_ONLY is a row number"));
    if let Some(row) = only {
        assert!(row < variants.len(), "VRS_BENCH_ONLY: there are {} rows", variants.len());
        variants = vec![variants.swap_remove(row)];
    }
    let mut renderers: Vec<SceneRenderer> = variants
        .iter()
        .enumerate()
        .map(|(i, variant)| {
            let path = dir.path().join(format!("scene{i}.toml"));
            std::fs::write(&path, scene(&volume, size, shading, variant)).expect("scene written");
            let mut renderer =
                SceneRenderer::open(gpu.clone(), &path, options.clone(), &mut |_, _, _| {}).expect("opens");
            // Streams every brick the view needs: the timed frames find them resident.
            renderer.render_all().expect("renders");
            renderer
        })
        .collect();
    // Each bricked row's residency: a lookup that asks for no bricks (one that writes no
    // requests) renders from the coarsest level alone, which is cheaper and not comparable.
    for (row, renderer) in renderers.iter().enumerate() {
        if let Some(residency) = renderer.brick_residency() {
            println!(
                "row {row} bricks: {} resident, {} of one value, {} pending",
                residency.resident, residency.constant, residency.pending
            );
        }
    }
    // Each round's frames of each row, rows taking turns: a row's ratio to another is also taken
    // round by round (the median of the per-round ratios), which a machine whose speed drifts
    // over a run moves less than the ratio of the medians.
    let mut rounds_of = vec![Vec::new(); variants.len()];
    for _ in 0..rounds {
        for (renderer, rounds_of) in renderers.iter_mut().zip(&mut rounds_of) {
            rounds_of.push(median(frame_times(renderer, frames)));
        }
    }
    let medians: Vec<f64> = rounds_of.iter().map(|r| median(r.clone())).collect();
    if only.is_some() {
        println!("{}: {:.1} ms", variants[0].name, medians[0]);
        return;
    }
    let paired =
        |row: usize, base: usize| median(rounds_of[row].iter().zip(&rounds_of[base]).map(|(a, b)| a / b).collect());
    println!("row, median frame time, over row 0 (ratio of medians; median of per-round ratios)");
    for (row, (variant, ms)) in variants.iter().zip(&medians).enumerate() {
        println!("{row:>2} {:<40} {ms:8.1} ms {:6.3}x {:6.3}x", variant.name, ms / medians[0], paired(row, 0));
    }
    println!(
        "bricked over single texture: {:.3}x, per round {:.3}x (target <= 1.15)",
        medians[1] / medians[0],
        paired(1, 0)
    );
    println!(
        "bricked over single texture, both skipping: {:.3}x, per round {:.3}x (target <= 1.15)",
        medians[3] / medians[2],
        paired(3, 2)
    );
}
