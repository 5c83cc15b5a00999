//! Memory budgets hold: a 1024 x 1024 x 512 uint16 Zarr array (1 GiB of samples, one stored
//! level, so every coarser level is built from it through the cache the host budget pays for)
//! renders through `vrsc render` at `memory = host_memory = 64 MiB` and `512 MiB`, shaded at
//! 256^2 and zoomed in (`fov = 8`), each within the budgets plus the fixed cost of a render (a
//! phantom scene's peak, measured first) plus the loader threads' decode buffers; and the tight
//! budget settles its picture within twice the time the loose one takes. A measurement
//! (ignored by default: it writes a 1 GiB store and renders four times); run with
//! `cargo test --release -p vrsc-cli --test suite budgets:: -- --ignored --nocapture`.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

/// Transient memory over budgets and the fixed cost: two loader threads' brick reads (a 68^3
/// box with the apron of f32 values per read, up to 16 dataset voxels per level voxel), the
/// chunks zarrs decodes for them, up to 16 bricks staged for the pool (9 MiB), and the ranges
/// learnt for empty-space skipping (a 128 x 128 x 64 grid, 9 MiB, with its copies for the
/// occupancy pass, about 12 MiB at the peak), and while a brick pool grows, its first one (64 MiB
/// and the coarsest level) beside the whole one for one copy.
/// Measured (2026-12-06, 2 cores, lavapipe; fixed cost 130 MiB): 64 MiB budgets peak at 350 MiB
/// (fov 30) and 405 MiB (fov 8), 92 and 147 MiB over fixed cost + host budget + pool;
/// 512 MiB budgets at 819 and 1006 MiB, under the bound.
const SLACK: u64 = 192 << 20;

fn scene(path: &str, budget: &str, fov: f32) -> String {
    format!(
        r#"
[render]
compositing = "dvr"
shading = true
jitter = 0.0
memory = "{budget}"
host_memory = "{budget}"

[[volume]]
name = "big"
role = "primary"
path = "{path}"
window = [0.0, 1000.0]

[[view]]
name = "3d"
kind = "raycast"
size = [256, 256]
camera = {{ azimuth = 30.0, elevation = 20.0, distance = 2.5, fov = {fov} }}
"#
    )
}

/// Runs `vrsc render` of `text`; its peak resident set in bytes, its time and its notes.
#[expect(clippy::zombie_processes, reason = "waited for with wait4, which gives its resource usage too")]
fn render(dir: &Path, name: &str, text: &str) -> (u64, Duration, String) {
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text).expect("scene written");
    let out = dir.join(name);
    let started = Instant::now();
    let child = Command::new(env!("CARGO_BIN_EXE_vrsc"))
        .args(["render", path.to_str().expect("utf-8"), "-o", out.to_str().expect("utf-8"), "--software"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("vrsc runs");
    let pid = child.id() as libc::pid_t;
    let mut stderr = child.stderr.expect("its standard error");
    let mut said = String::new();
    std::io::Read::read_to_string(&mut stderr, &mut said).expect("readable");
    let mut status = 0;
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `status` and `usage` are valid, writable; `pid` is our child, not yet waited for.
    let waited = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(waited, pid, "wait4");
    assert!(libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0, "{name}: {said}");
    (usage.ru_maxrss as u64 * 1024, started.elapsed(), said)
}

/// Writes the 1 GiB store into `dir`: a ball of values up to 1000 with a ripple, zero around.
fn write_store(dir: &Path) -> std::path::PathBuf {
    let value = |_: usize, [x, y, z]: [u32; 3]| {
        let (fx, fy, fz) = (x as f32 / 1024.0 - 0.5, y as f32 / 1024.0 - 0.5, z as f32 / 512.0 - 0.5);
        let r = (fx * fx + fy * fy + fz * fz).sqrt();
        1000.0 * (1.0 - (r / 0.45).min(1.0)) * (0.75 + 0.25 * (x as f32 * 0.05).sin() * (y as f32 * 0.07).cos())
    };
    let t = Instant::now();
    let store =
        vrs_runtime::bricks::zarr::write_test_zarr(dir, [1024, 1024, 512], [128, 128, 64], 1, value, |_, _, _| true)
            .expect("store written");
    println!("wrote the 1 GiB store in {:?}", t.elapsed());
    store
}

#[test]
#[ignore = "a measurement: writes a 1 GiB store and renders it four times (minutes)"]
fn budgets_bound_the_peak_memory_of_a_render() {
    let dir = tempfile::tempdir().expect("temp dir");
    let store = write_store(dir.path());
    let fixed = "[[volume]]\nname = \"p\"\nrole = \"primary\"\nphantom = \"head\"\n\n[[view]]\nname = \"3d\"\nkind = \"raycast\"\nsize = [256, 256]\n";
    let (base, _, _) = render(dir.path(), "fixed", fixed);
    println!("fixed cost (a phantom scene): {} MiB", base >> 20);
    let mut times = Vec::new();
    for (budget, bytes) in [("64 MiB", 64u64 << 20), ("512 MiB", 512 << 20)] {
        for fov in [30.0, 8.0] {
            let name = format!("b{}-fov{fov}", bytes >> 20);
            let (peak, took, said) = render(dir.path(), &name, &scene(store.to_str().expect("utf-8"), budget, fov));
            let note = said.lines().find(|l| l.contains("bricks loaded")).unwrap_or("").trim().to_string();
            // On a software device the pool lives in host memory: host budget + pool.
            let bound = base + 2 * bytes + SLACK;
            println!(
                "{budget}, fov {fov}: peak {} MiB (bound {} MiB), {:.1} s; {note}",
                peak >> 20,
                bound >> 20,
                took.as_secs_f64()
            );
            assert!(peak <= bound, "{budget} fov {fov}: peak {} MiB over {} MiB", peak >> 20, bound >> 20);
            times.push(took.as_secs_f64());
        }
    }
    // Measured (same session): 4.2 s against 4.5 s (fov 30), 12.8 s against 17.5 s (fov 8).
    for (fov, tight, loose) in [(30, times[0], times[2]), (8, times[1], times[3])] {
        assert!(tight <= 2.0 * loose, "fov {fov}: {tight:.1} s at 64 MiB, over twice {loose:.1} s at 512 MiB");
    }
}

/// How long a viewer waits for the store's first picture and for the settled one, in the
/// runtime as a viewer drives it (default budgets, shaded 256^2): the adapter, the scene's
/// opening (the full pass over level 0 that builds the coarsest level, the shader), the
/// preview the viewer's schedule renders first, one full frame with what is resident then,
/// and the frames until every brick the rays ask for is there.
/// Measured (2026-12-07, 2 cores, lavapipe, three runs): adapter 0.04 s, open 1.19-1.22 s,
/// the 64x64 preview at 1.36-1.39 s, the full picture at 1.99-2.03 s, settled at 3.41-3.47 s.
/// Before the pool started small (it grows to the budget when a brick needs it: the device
/// clears a texture before its first write, 0.5 s for 1 GiB) and before a store's value range
/// was left until asked for (64 coarse bricks read at open, on one thread): open 1.8-2.0 s,
/// preview at 2.4-3.0 s, full picture at 3.1-3.7 s, settled at 4.5-5.1 s.
/// A measurement, ignored by default: `cargo test --release -p vrsc-cli --test suite budgets:: --
/// --ignored --nocapture first_picture`.
#[test]
#[ignore = "a measurement: writes a 1 GiB store and renders it"]
fn first_picture_of_a_store_without_a_pyramid() {
    let dir = tempfile::tempdir().expect("temp dir");
    let store = write_store(dir.path());
    let text = scene(store.to_str().expect("utf-8"), "1 GiB", 30.0);
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).expect("scene written");
    let started = Instant::now();
    let gpu = vrs_runtime::Gpu::headless(vrs_runtime::AdapterChoice::Software).expect("the software adapter");
    let adapter = started.elapsed();
    let options = vrs_runtime::RenderOptions::default();
    let mut scene = vrs_runtime::SceneRenderer::open(gpu, &path, options, &mut |_, _, _| {}).expect("opens");
    let opened = started.elapsed();
    // What the viewer renders first, before it has measured anything: a preview.
    let mut refiner = vrs_live::Refiner::new([256, 256], Duration::from_millis(100));
    let Some(vrs_live::Work::Preview { size, .. }) = refiner.next(0, Instant::now()) else { panic!("a preview first") };
    let target = vrs_runtime::view::create_output(scene.gpu(), size).expect("a preview target");
    let region = vrs_runtime::view::Region::whole(size);
    let mut encoder = scene.gpu().device.create_command_encoder(&Default::default());
    let view = target.create_view(&Default::default());
    scene.encode_view_into(0, &mut encoder, &view, region).expect("encoded");
    scene.gpu().queue.submit([encoder.finish()]);
    scene.gpu().wait();
    let preview = started.elapsed();
    let mut encoder = scene.gpu().device.create_command_encoder(&Default::default());
    scene.encode_view(0, &mut encoder).expect("encoded");
    scene.gpu().queue.submit([encoder.finish()]);
    scene.gpu().wait();
    let first = started.elapsed();
    scene.render_all().expect("settled");
    let settled = started.elapsed();
    let s = |d: Duration| d.as_secs_f64();
    println!(
        "adapter {:.2} s, scene open {:.2} s, the viewer's first preview ({}x{}) at {:.2} s, first full picture at \
         {:.2} s, settled at {:.2} s",
        s(adapter),
        s(opened),
        size[0],
        size[1],
        s(preview),
        s(first),
        s(settled)
    );
}
