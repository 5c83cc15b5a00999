//! Bricked volumes on lavapipe: the same volume rendered bricked and as one texture gives the
//! same picture (the apron hides the seams between bricks), in a raycast view and in slice
//! views whose planes lie on seams; every brick the rays need is loaded before `render_all`
//! returns.

use crate::common;

use common::difference::{Difference, Tolerance};
use std::collections::BTreeMap;
use std::path::Path;
use vrs_runtime::{RenderOptions, SceneRenderer};

/// Bricked against one texture, the same for every view. The two sample the same voxels (the apron
/// makes a brick's edge read its neighbour's voxels, as the whole texture does), so what differs is
/// rounding of the pool's texture coordinates. Every brick here has a slot of its own (its place in
/// the pyramid, not the order the loader threads finish in: with arrival order the maximum varied
/// from 1 to 5/255 between runs, where the rounding flipped a ray's early termination), so the
/// picture repeats exactly. Measured on lavapipe (6 runs, identical): a mean of at most
/// 0.0006/255, a 99th percentile of 0, at most 118 pixels of 384^2 differing, a maximum of 1/255.
/// The limits leave room for another driver's rounding (mean 0.05, 99th percentile 1, maximum 4)
/// and no more: a seam one voxel wide (a missing or wrong apron) passes the maximum along its
/// pixels.
const ALIKE: Tolerance = Tolerance { mean: 0.05, p99: 1, max: 4 };

/// The views of [`scene`], each compared under [`ALIKE`].
const VIEWS: [&str; 3] = ["3d", "seam", "sagittal"];

/// The abdomen phantom at 256^3 (bricks of 64: seams every 64 voxels), shaded DVR, and axial
/// slices on a seam (z = 128 of 256: the plane between bricks 1 and 2) and off it.
fn scene(bricks: bool) -> String {
    format!(
        r#"
[render]
compositing = "dvr"
shading = true
jitter = 0.0
memory = "256 MiB"

[[volume]]
name = "body"
role = "primary"
phantom = "abdomen"
bricks = {bricks}

[[view]]
name = "3d"
kind = "raycast"
size = [384, 384]
camera = {{ azimuth = 35.0, elevation = 20.0, distance = 2.2 }}

[[view]]
name = "seam"
kind = "slice"
axis = "axial"
position = 0.5
size = [192, 192]

[[view]]
name = "sagittal"
kind = "slice"
axis = "sagittal"
position = 0.37
size = [192, 192]
"#
    )
}

fn render(dir: &Path, name: &str, text: &str) -> (Vec<(String, image::RgbaImage)>, SceneRenderer) {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("scene written");
    let options = RenderOptions { phantom_size: [256, 256, 256], ..RenderOptions::default() };
    let mut renderer = SceneRenderer::open(common::software_gpu(), &path, options, &mut |_, _, _| {})
        .unwrap_or_else(|e| panic!("{e}"));
    let images = renderer.render_all().unwrap_or_else(|e| panic!("{e}"));
    (images, renderer)
}

/// The pictures of two renders matched by view name: a view missing from either, or one
/// neither expects, fails the test.
fn by_view<'a>(
    whole: &'a [(String, image::RgbaImage)],
    bricked: &'a [(String, image::RgbaImage)],
    expected: &[&'a str],
) -> Vec<(&'a str, &'a image::RgbaImage, &'a image::RgbaImage)> {
    let named = |images: &'a [(String, image::RgbaImage)]| -> BTreeMap<&'a str, &'a image::RgbaImage> {
        let map: BTreeMap<&str, &image::RgbaImage> = images.iter().map(|(n, i)| (n.as_str(), i)).collect();
        assert_eq!(map.len(), images.len(), "a view name repeats: {:?}", map.keys());
        map
    };
    let (whole, bricked) = (named(whole), named(bricked));
    let want: Vec<&str> = {
        let mut w = expected.to_vec();
        w.sort_unstable();
        w
    };
    assert_eq!(whole.keys().copied().collect::<Vec<_>>(), want, "the single-texture render's views");
    assert_eq!(bricked.keys().copied().collect::<Vec<_>>(), want, "the bricked render's views");
    expected.iter().map(|name| (*name, whole[name], bricked[name])).collect()
}

#[test]
fn bricked_and_single_texture_volumes_render_alike() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (whole, _) = render(dir.path(), "whole.toml", &scene(false));
    let (bricked, renderer) = render(dir.path(), "bricked.toml", &scene(true));
    let residency = renderer.brick_residency().expect("bricked volumes");
    assert!(residency.resident > 0 && residency.pending == 0, "{residency:?}");
    assert!(renderer.notices.iter().any(|n| n.contains("bricks loaded for this picture")), "{:?}", renderer.notices);
    let mut failures = Vec::new();
    for (name, a, b) in by_view(&whole, &bricked, &VIEWS) {
        let difference = Difference::between(a, b);
        println!("{name}: {difference} ({residency:?})");
        if std::env::var_os("VRS_KEEP_IMAGES").is_some() {
            a.save(format!("/tmp/bricks-{name}-whole.png")).ok();
            b.save(format!("/tmp/bricks-{name}-bricked.png")).ok();
        }
        // Not a blank picture: the comparison means something.
        assert!(a.pixels().any(|p| p.0[0] > 40), "{name}: the single-texture picture is empty");
        if let Err(e) = ALIKE.check(name, &difference) {
            failures.push(e);
        }
    }
    assert!(failures.is_empty(), "bricked differs from the single texture:\n{}", failures.join("\n"));
}

/// The tolerance judges what the mean hides: a seam one pixel wide at 40/255 across a 384^2
/// picture moves the mean by 0.1/255 and fails the maximum.
#[test]
fn a_one_pixel_seam_fails_the_tolerance() {
    let a = image::RgbaImage::from_pixel(384, 384, image::Rgba([100, 100, 100, 255]));
    let mut b = a.clone();
    for y in 0..384 {
        b.put_pixel(192, y, image::Rgba([140, 140, 140, 255]));
    }
    let d = Difference::between(&a, &b);
    assert!(d.mean < 0.11 && d.p99 == 0 && d.max == 40 && d.differing == 384, "{d}");
    assert!(ALIKE.check("seam", &d).is_err(), "{d}");
    assert!(ALIKE.check("same", &Difference::between(&a, &a)).is_ok());
}

/// A scene's own lookup (`lookup = "FILE.wgsl"`) replaces the standard one: a lookup that
/// answers 0 everywhere makes a uniform slice of the abdomen, which the standard lookup shows.
#[test]
fn a_scenes_own_lookup_replaces_the_standard_one() {
    let dir = tempfile::tempdir().expect("temp dir");
    let zero = r#"
struct BrickLayout { grid: vec4f, eye: vec4f, pool: vec4f, detail: vec4f, table: vec4f }
@group(0) @binding(0) var NAME: texture_3d<f32>;
@group(0) @binding(1) var NAME_sampler: sampler;
@group(0) @binding(2) var<storage, read> NAME_pages: array<u32>;
@group(0) @binding(3) var<uniform> NAME_layout: BrickLayout;
@group(0) @binding(4) var<storage, read_write> NAME_requests: array<u32>;
fn NAME_sample(p: vec3f) -> f32 { return 0.0; }
fn NAME_dims() -> vec3u { return vec3u(NAME_layout.grid.xyz); }
"#;
    std::fs::write(dir.path().join("zero.wgsl"), zero).expect("lookup written");
    let standard = scene(true);
    let own = standard.replace("bricks = true\n", "bricks = true\nlookup = \"zero.wgsl\"\n");
    assert_ne!(own, standard);
    let uniform = |image: &image::RgbaImage| image.pixels().all(|p| p == image.get_pixel(0, 0));
    let (with_standard, _) = render(dir.path(), "standard.toml", &standard);
    let (with_own, _) = render(dir.path(), "own.toml", &own);
    let slice =
        |images: &[(String, image::RgbaImage)]| images.iter().find(|(n, _)| n == "seam").expect("seam").1.clone();
    assert!(!uniform(&slice(&with_standard)), "the standard lookup shows the abdomen");
    assert!(uniform(&slice(&with_own)), "the scene's lookup answers 0 everywhere");
}

/// A bricked primary volume casts volume shadows and gives surfaces: both read a level that
/// fits one piece (the 128^3 abdomen phantom: level 0 itself), so the pictures are those of the same
/// volume in one texture (at a size whose pixels are smaller than a voxel, so that the rays
/// read level 0 too).
#[test]
fn light_volumes_and_surfaces_of_a_bricked_volume_come_from_a_level_that_fits() {
    let shadows = "shading = true\nshadows = \"volume\"\nlights = [\"key\"]\n";
    let surface = "[[mesh]]\nname = \"bone\"\nvolume = \"body\"\nlevel = 300.0\n";
    for (what, render, mesh) in [("shadows", shadows, ""), ("surface", "", surface)] {
        let text = |bricks: bool| {
            format!(
                r#"
[render]
compositing = "dvr"
jitter = 0.0
{render}
[[volume]]
name = "body"
role = "primary"
phantom = "abdomen"
bricks = {bricks}

{mesh}
[uniforms]
light_dir_key = [0.8, 0.3, 0.6]

[[view]]
name = "3d"
kind = "raycast"
size = [320, 320]
camera = {{ azimuth = 35.0, elevation = 20.0, distance = 2.2 }}
"#
            )
        };
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("scene.toml");
        let options = RenderOptions { phantom_size: [128, 128, 128], ..RenderOptions::default() };
        let mut pictures = Vec::new();
        for bricks in [false, true] {
            let text = text(bricks).replace("light_dir_key", if render.is_empty() { "# " } else { "light_dir_key" });
            std::fs::write(&path, text).expect("scene written");
            let mut renderer = SceneRenderer::open(common::software_gpu(), &path, options.clone(), &mut |_, _, _| {})
                .unwrap_or_else(|e| panic!("{what}, bricks = {bricks}: {e}"));
            assert_eq!(renderer.brick_residency().is_some(), bricks);
            pictures.push(renderer.render_all().unwrap_or_else(|e| panic!("{e}")).remove(0).1);
        }
        let difference = Difference::between(&pictures[0], &pictures[1]);
        println!("{what}, bricked against one texture: {difference}");
        if std::env::var_os("VRS_KEEP_IMAGES").is_some() {
            pictures[0].save(format!("/tmp/{what}-whole.png")).ok();
            pictures[1].save(format!("/tmp/{what}-bricked.png")).ok();
        }
        // The same level-0 voxels in one texture either way: differences of rounding only
        // (measured: a maximum of 1/255 on a handful of pixels).
        ALIKE.check(what, &difference).unwrap_or_else(|e| panic!("{e}"));
    }
}

/// A volume read from a file without a pyramid is read whole once at open, to build its coarse
/// levels; what that pass shows of the values is known before the first frame, so bricks the
/// transfer function makes transparent are skipped from the first ray on and never loaded. Here
/// 256 x 64 x 64 voxels (bricks of 64: 4 x 1 x 1 at level 0): air with noise (never one value,
/// so never a constant brick) up to x = 160 and bone beyond, so the 2 bricks of x < 128 (their
/// aprons included) are transparent under `ct_bone`. The pyramid has 4 + 2 + 1 bricks; the
/// picture's pixels are smaller than a voxel, so that the rays ask for level 0.
#[test]
fn bricks_the_transfer_function_hides_are_never_loaded() {
    let dir = tempfile::tempdir().expect("temp dir");
    let dims = [256u32, 64, 64];
    let values: Vec<f32> = (0..dims.iter().product::<u32>())
        .map(|i| {
            let noise = (i.wrapping_mul(2_654_435_761) >> 28) as f32;
            if i % dims[0] < 160 { -1000.0 + noise } else { 1000.0 + 10.0 * noise }
        })
        .collect();
    let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    common::write_nrrd(&dir.path().join("half.nrrd"), "right-anterior-superior", dims, identity, [0.0; 3], &values);
    let text = r#"
[render]
compositing = "dvr"
jitter = 0.0

[[volume]]
name = "half"
role = "primary"
path = "half.nrrd"
tf = "ct_bone"
bricks = true

[[view]]
name = "3d"
kind = "raycast"
size = [384, 384]
camera = { azimuth = -60.0, elevation = 20.0, distance = 1.6 }
"#;
    let (images, renderer) = render(dir.path(), "scene.toml", text);
    let residency = renderer.brick_residency().expect("bricked volumes");
    println!("{residency:?}");
    assert!(images[0].1.pixels().any(|p| p.0[3] > 200), "the bone shows");
    assert_eq!(residency.pending, 0, "{residency:?}");
    assert!(residency.loaded + u64::from(residency.constant) <= 7 - 2, "transparent bricks were loaded: {residency:?}");
    assert!(residency.loaded >= 2, "the bone's bricks were loaded: {residency:?}");
}
