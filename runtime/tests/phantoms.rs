//! The built-in phantoms look smooth when lit: a shaded render of the head phantom (what a new
//! user sees when the MNI data is absent) has no terraces, measured as the mean absolute second
//! difference of luminance over the lit surface.

use crate::common;

use image::RgbaImage;
use vrs_runtime::{RenderOptions, SceneRenderer};

/// The head phantom at the default size (128^3) under the light example's transfer function,
/// lit by one key light, no shadows; no jitter (its noise would be measured as roughness) and
/// fine steps (a fixed step's wood-grain rings would be too: at the default 0.5 mm they add
/// about 6/255 to the measure, whatever the data).
const LIT_HEAD: &str = r#"
[render]
compositing = "dvr"
shading = true
lights = ["key"]
jitter = 0.0
step_size = 0.1

[[volume]]
name = "head"
role = "primary"
phantom = "head"
tf = "skin.json"

[uniforms]
light_dir_key = [0.8, 0.3, 0.6]
light_color_key = [1.0, 1.0, 1.0]
ambient = 0.15

[[view]]
name = "3d"
kind = "raycast"
size = [256, 256]
camera = { azimuth = 35.0, elevation = 15.0, distance = 2.4 }
"#;

/// Rec. 709 luminance of a pixel's bytes.
fn luminance(image: &RgbaImage, x: u32, y: u32) -> f64 {
    let p = image.get_pixel(x, y);
    0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])
}

/// The mean of |L(x - 1) - 2 L(x) + L(x + 1)| along rows and columns (in 255ths) over the
/// surface: pixels whose 5 x 5 neighbourhood is all brighter than the background (so the
/// silhouette, where the surface meets black, is not counted), and how many pixels that is.
fn roughness(image: &RgbaImage) -> (f64, usize) {
    let (w, h) = image.dimensions();
    let lit = |x: u32, y: u32| luminance(image, x, y) > 8.0;
    let (mut sum, mut count) = (0.0, 0usize);
    for y in 2..h - 2 {
        for x in 2..w - 2 {
            if !(y - 2..=y + 2).all(|j| (x - 2..=x + 2).all(|i| lit(i, j))) {
                continue;
            }
            let l = |i: u32, j: u32| luminance(image, i, j);
            let along_x = (l(x - 1, y) - 2.0 * l(x, y) + l(x + 1, y)).abs();
            let along_y = (l(x, y - 1) - 2.0 * l(x, y) + l(x, y + 1)).abs();
            sum += 0.5 * (along_x + along_y);
            count += 1;
        }
    }
    (sum / count.max(1) as f64, count)
}

/// A smooth shaded surface changes its luminance slowly from pixel to pixel; terraces show as
/// second differences of several 255ths. Measured (2026-12-07, lavapipe): 14.7/255 before
/// (one-voxel edges, and the window taken from `skin.json`'s domain, 0 to 100 HU, which
/// flattened the skull in the texture, so its gradient vanished at every voxel where it
/// saturated), 2.1/255 now (edges blurred by a Gaussian of 0.8 voxels, the window widened to
/// the phantom's range). A ball of the same edges renders at 0.8/255, the same ball with
/// sigma = 2 voxels at 0.5/255: what is left is the thin skull's partial volume.
#[test]
fn a_lit_head_phantom_has_no_terraces() {
    let dir = tempfile::tempdir().expect("a folder");
    std::fs::copy(common::root().join("examples/light/skin.json"), dir.path().join("skin.json")).expect("tf copied");
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, LIT_HEAD).expect("scene written");
    let mut renderer = SceneRenderer::open(common::software_gpu(), &path, RenderOptions::default(), &mut |_, _, _| {})
        .unwrap_or_else(|e| panic!("{e}"));
    let image = &renderer.render_all().expect("renders")[0].1;
    let (mean, pixels) = roughness(image);
    println!("roughness {mean:.3}/255 over {pixels} surface pixels");
    assert!(pixels > 10_000, "the head covers much of the view: {pixels} surface pixels");
    assert!(mean <= 3.0, "mean absolute second difference of luminance {mean:.3}/255, over 3/255");
}
