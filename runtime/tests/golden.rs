//! Golden images: the scenes in `tests/fixtures/render/` rendered on the software adapter and
//! compared with `tests/golden/SCENE__VIEW.png`.
//!
//! Tolerance: a pixel matches when every channel is within 8/255 of the golden image, and 99.5%
//! of the pixels must match, with a mean absolute difference under 1.0/255. Lavapipe's results
//! depend on the LLVM version and the CPU's vector width (rounding in the trilinear filter and
//! in `pow`/`exp`), which moves a few pixels on steep edges by a few levels; a real change
//! (another transfer function, a moved camera, a broken step) changes far more pixels by far
//! more. On a mismatch the actual image and a difference image are written to
//! `target/golden-failures/`. `VRS_UPDATE_GOLDEN=1` writes new golden images instead.

mod common;

use image::RgbaImage;
use std::path::{Path, PathBuf};
use vrs_runtime::{RenderOptions, SceneRenderer};

const CHANNEL_TOLERANCE: u8 = 8;
const MIN_MATCHING: f64 = 0.995;
const MAX_MEAN_DIFF: f64 = 1.0;

fn scenes() -> Vec<PathBuf> {
    let dir = common::root().join("tests/fixtures/render");
    let mut out: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("render fixtures")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    out.sort();
    out
}

/// How far `actual` is from `golden`: (fraction of matching pixels, mean absolute difference,
/// difference image).
fn compare(actual: &RgbaImage, golden: &RgbaImage) -> (f64, f64, RgbaImage) {
    let mut matching = 0usize;
    let mut total_diff = 0u64;
    let mut diff = RgbaImage::new(actual.width(), actual.height());
    for ((a, g), d) in actual.pixels().zip(golden.pixels()).zip(diff.pixels_mut()) {
        let worst = (0..4).map(|c| a[c].abs_diff(g[c])).max().unwrap_or(0);
        total_diff += (0..4).map(|c| u64::from(a[c].abs_diff(g[c]))).sum::<u64>();
        if worst <= CHANNEL_TOLERANCE {
            matching += 1;
        }
        let shown = worst.saturating_mul(8);
        *d = image::Rgba([shown, if worst > CHANNEL_TOLERANCE { 0 } else { shown }, 0, 255]);
    }
    let pixels = (actual.width() * actual.height()).max(1) as f64;
    (matching as f64 / pixels, total_diff as f64 / (pixels * 4.0), diff)
}

fn check(name: &str, actual: &RgbaImage, golden_path: &Path) -> Result<(), String> {
    if std::env::var_os("VRS_UPDATE_GOLDEN").is_some() {
        actual.save(golden_path).map_err(|e| e.to_string())?;
        return Ok(());
    }
    let golden = image::open(golden_path)
        .map_err(|e| format!("{name}: cannot read {}: {e} (VRS_UPDATE_GOLDEN=1 writes it)", golden_path.display()))?
        .to_rgba8();
    if golden.dimensions() != actual.dimensions() {
        return Err(format!("{name}: size {:?}, golden {:?}", actual.dimensions(), golden.dimensions()));
    }
    let (matching, mean, diff) = compare(actual, &golden);
    if matching >= MIN_MATCHING && mean <= MAX_MEAN_DIFF {
        return Ok(());
    }
    let out = common::root().join("target/golden-failures");
    let _ = std::fs::create_dir_all(&out);
    let _ = actual.save(out.join(format!("{name}.actual.png")));
    let _ = diff.save(out.join(format!("{name}.diff.png")));
    Err(format!(
        "{name}: {:.2}% of pixels within {CHANNEL_TOLERANCE}/255 (need {:.1}%), mean difference {mean:.2}/255 \
         (at most {MAX_MEAN_DIFF}); actual and difference images in {}",
        matching * 100.0,
        MIN_MATCHING * 100.0,
        out.display()
    ))
}

#[test]
fn phantom_scenes_match_their_golden_images() {
    let gpu = common::software_gpu();
    let mut failures = Vec::new();
    let mut count = 0;
    for scene in scenes() {
        let stem = scene.file_stem().and_then(|s| s.to_str()).unwrap_or("scene").to_string();
        let options = RenderOptions { phantom_size: [64, 64, 64], ..RenderOptions::default() };
        let mut renderer = SceneRenderer::open(gpu.clone(), &scene, options, &mut |_, _, _| {})
            .unwrap_or_else(|e| panic!("{}: {e}", scene.display()));
        for (view, image) in renderer.render_all().unwrap_or_else(|e| panic!("{}: {e}", scene.display())) {
            let name = format!("{stem}__{view}");
            let golden = common::root().join(format!("tests/golden/{name}.png"));
            count += 1;
            if let Err(e) = check(&name, &image, &golden) {
                failures.push(e);
            }
        }
    }
    assert!(count >= 6, "expected at least six golden views, found {count}");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn the_comparison_catches_a_real_change() {
    let golden = RgbaImage::from_pixel(16, 16, image::Rgba([100, 100, 100, 255]));
    let mut shifted = golden.clone();
    for x in 0..16 {
        shifted.put_pixel(x, 0, image::Rgba([140, 100, 100, 255]));
    }
    let (matching, _, _) = compare(&shifted, &golden);
    assert!(matching < MIN_MATCHING, "one changed row of 16 must fail");
    let (matching, mean, _) = compare(&golden, &golden);
    assert_eq!((matching, mean), (1.0, 0.0));
}
