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

use crate::common;

use common::{MIN_MATCHING, compare};
use image::RgbaImage;
use std::path::PathBuf;
use vrs_runtime::{RenderOptions, SceneRenderer};

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
            count += 1;
            if let Err(e) = common::check_golden(&name, &image) {
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
