//! A volume larger than a texture and than the GPU budget: a generated 2048x2048x1024 OME-Zarr
//! store (sparse balls, written in the test's temporary folder) renders through `vrsc render`
//! with a 512 MiB GPU budget and a 1 GiB host budget, in bounded memory, and looks like its
//! level 2 (512x512x256) rendered as one texture.

use std::path::Path;
use std::process::Command;

/// Balls in level-0 voxels: centre, radius, value.
const BALLS: [([f32; 3], f32, f32); 5] = [
    ([700.0, 900.0, 500.0], 180.0, 900.0),
    ([1300.0, 1100.0, 400.0], 140.0, 600.0),
    ([1000.0, 600.0, 700.0], 110.0, 1000.0),
    ([1500.0, 1500.0, 600.0], 160.0, 400.0),
    ([500.0, 1500.0, 300.0], 120.0, 750.0),
];

/// The value at a voxel of `level`: the balls, sampled at the voxel's centre in level-0 voxels,
/// with a soft rim of 16 voxels.
fn value(level: usize, voxel: [u32; 3]) -> f32 {
    let s = (1u32 << level) as f32;
    let p = voxel.map(|i| (i as f32 + 0.5) * s - 0.5);
    BALLS
        .iter()
        .map(|(c, r, v)| {
            let d = ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt();
            v * ((r - d) / 16.0).clamp(0.0, 1.0)
        })
        .fold(0.0, f32::max)
}

/// Whether the chunk `[lo, hi)` of `level` may hold a ball.
fn occupied(level: usize, lo: [u32; 3], hi: [u32; 3]) -> bool {
    let s = (1u32 << level) as f32;
    BALLS.iter().any(|(c, r, _)| (0..3).all(|a| (lo[a] as f32) * s <= c[a] + r && (hi[a] as f32) * s >= c[a] - r))
}

fn scene(path: &str, step: f32, bricks: bool) -> String {
    format!(
        r#"
[render]
compositing = "dvr"
jitter = 0.0
step_size = {step}
memory = "512 MiB"
host_memory = "1 GiB"

[[volume]]
name = "balls"
role = "primary"
path = "{path}"
window = [0.0, 1000.0]
bricks = {bricks}

[uniforms]
ref_step = {step}

[[view]]
name = "3d"
kind = "raycast"
size = [512, 512]
camera = {{ azimuth = 30.0, elevation = 20.0, distance = 8.0, fov = 10.0 }}
"#
    )
}

/// `vrsc render` of `scene` into `out`; its standard error.
fn render(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("scene written");
    let out = dir.join(name.replace(".toml", ""));
    let output = Command::new(env!("CARGO_BIN_EXE_vrsc"))
        .args(["render", path.to_str().expect("utf-8"), "-o", out.to_str().expect("utf-8"), "--software"])
        .output()
        .expect("vrsc runs");
    let stderr = String::from_utf8_lossy(&output.stderr).to_string();
    assert!(output.status.success(), "{name}: {stderr}");
    stderr
}

/// The largest resident set of the children waited for so far, in bytes.
fn children_peak_rss() -> u64 {
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `usage` is a valid, writable rusage.
    let status = unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut usage) };
    assert_eq!(status, 0, "getrusage");
    usage.ru_maxrss as u64 * 1024
}

#[test]
fn a_volume_beyond_the_budget_streams_in_bounded_memory() {
    let dir = tempfile::tempdir().expect("temp dir");
    let big = dir.path().join("big");
    let small = dir.path().join("small");
    std::fs::create_dir_all(&big).expect("dir");
    std::fs::create_dir_all(&small).expect("dir");
    let store =
        vrs_runtime::bricks::zarr::write_test_zarr(&big, [2048, 2048, 1024], [128, 128, 64], 6, value, occupied)
            .expect("big store written");
    // The reference: level 2 alone, as a store of its own (voxels of 1 mm: the camera is
    // relative to the volume's box, and the steps are the same fraction of it).
    let coarse = |_: usize, v: [u32; 3]| value(2, v);
    let coarse_occupied = |_: usize, lo: [u32; 3], hi: [u32; 3]| occupied(2, lo, hi);
    let reference =
        vrs_runtime::bricks::zarr::write_test_zarr(&small, [512, 512, 256], [128, 128, 64], 1, coarse, coarse_occupied)
            .expect("reference store written");

    let streamed = render(dir.path(), "streamed.toml", &scene(store.to_str().expect("utf-8"), 4.0, true));
    let peak = children_peak_rss();
    println!("{streamed}\npeak RSS of `vrsc render`: {:.0} MiB", peak as f64 / (1 << 20) as f64);
    assert!(peak < 3 << 29, "peak RSS {} MiB is not below 1.5 GiB", peak >> 20);
    let loaded = streamed.lines().find(|l| l.contains("bricks loaded for this picture")).expect("a residency note");
    assert!(!loaded.contains("shown coarser"), "{loaded}");

    render(dir.path(), "reference.toml", &scene(reference.to_str().expect("utf-8"), 1.0, false));
    let a = image::open(dir.path().join("streamed/3d.png")).expect("streamed image").to_rgba8();
    let b = image::open(dir.path().join("reference/3d.png")).expect("reference image").to_rgba8();
    let total: u64 = a.as_raw().iter().zip(b.as_raw()).map(|(&x, &y)| u64::from(x.abs_diff(y))).sum();
    let mean = total as f64 / a.as_raw().len() as f64;
    let background = *b.get_pixel(0, 0);
    let lit = b.pixels().filter(|p| p.0.iter().zip(background.0).any(|(&x, y)| x.abs_diff(y) > 8)).count();
    println!("mean difference from level 2 as one texture: {mean:.4}/255; {lit} pixels show a ball");
    if std::env::var_os("VRS_KEEP_IMAGES").is_some() {
        a.save("/tmp/bricks-streamed.png").ok();
        b.save("/tmp/bricks-reference.png").ok();
    }
    assert!(lit > 512 * 512 / 100, "the balls cover too little of the picture to compare: {lit} pixels");
    assert!(mean <= 0.5, "the streamed picture differs from level 2 as one texture by {mean:.3}/255 on average");
}
