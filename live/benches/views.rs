//! Several views on one GPU (run on lavapipe: `cargo bench -p vrs-live --bench views`):
//! `examples/ablation` (a 3D view and an axial slice, 384x384 each) driven as the viewer drives
//! it — [`ViewFrames::step_views`] in a loop that looks every millisecond, 50 ms of the 100 ms
//! interactive budget per view — against each view rendered alone, headless. Prints, as medians
//! over the rounds:
//! - after a change of both views (the camera and the slice moved), the time until the slice
//!   shows its full-resolution picture, over its headless full frame (target: at most 2);
//! - while the 3D view refines, the time from an orbit step to the 3D view's first preview of
//!   the new camera on screen (target: at most 100 ms);
//! - each view's full frame as the schedule measured it (its last complete picture's tiles
//!   summed), over its headless frame: about 1 when every measured time is the view's own work
//!   (the 3D view's headless frame in tiles is printed too).

use std::path::Path;
use std::time::{Duration, Instant};
use vrs_live::{GpuWaiter, LiveScene, Quality, ViewFrames, Work};
use vrs_runtime::view::Region;
use vrs_runtime::{AdapterChoice, Gpu, RenderOptions, SceneRenderer};

const ROUNDS: usize = 5;
/// The viewer's default budget (`vrsc view --budget-ms`), shared by the two views.
const BUDGET: Duration = Duration::from_millis(50);
/// Longer than this and a run is taken as stuck.
const GIVE_UP: Duration = Duration::from_secs(120);

fn copy_example(to: &Path) {
    let from = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/ablation");
    for entry in std::fs::read_dir(&from).unwrap().flatten() {
        if entry.path().is_file() {
            std::fs::copy(entry.path(), to.join(entry.file_name())).unwrap();
        }
    }
}

/// View `index`'s full frame rendered alone, waited for.
fn headless_frame(live: &mut LiveScene, index: usize) -> Duration {
    let gpu = live.renderer().gpu().clone();
    let size = live.size(index).unwrap();
    let target = live.output(index).unwrap().create_view(&Default::default());
    let started = Instant::now();
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    live.encode(index, &mut encoder, &target, Region::whole(size)).unwrap();
    gpu.queue.submit([encoder.finish()]);
    gpu.wait();
    started.elapsed()
}

/// View `index`'s full frame rendered alone in tiles of `rows` rows, each waited for: the sum.
fn headless_tiles(live: &mut LiveScene, index: usize, rows: u32) -> Duration {
    let gpu = live.renderer().gpu().clone();
    let [w, h] = live.size(index).unwrap();
    let target = live.output(index).unwrap().create_view(&Default::default());
    let mut total = Duration::ZERO;
    for y0 in (0..h).step_by(rows as usize) {
        let started = Instant::now();
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        live.encode(index, &mut encoder, &target, Region { x0: 0, y0, x1: w, y1: (y0 + rows).min(h) }).unwrap();
        gpu.queue.submit([encoder.finish()]);
        gpu.wait();
        total += started.elapsed();
    }
    total
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// Runs the loop until `done` holds (or [`GIVE_UP`]); returns the time it took.
fn run_until(
    frames: &mut [ViewFrames],
    live: &mut LiveScene,
    waiter: &GpuWaiter,
    mut done: impl FnMut(&[ViewFrames], &LiveScene) -> bool,
) -> Duration {
    let start = Instant::now();
    while !done(frames, live) {
        assert!(start.elapsed() < GIVE_UP, "the views did not get there in {GIVE_UP:?}");
        let mut all: Vec<&mut ViewFrames> = frames.iter_mut().collect();
        if let Some((index, e)) = ViewFrames::step_views(&mut all, live, waiter, Instant::now()) {
            panic!("view {index}: {e}");
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    start.elapsed()
}

/// Moves the 3D view's camera by `degrees` of azimuth.
fn orbit(live: &mut LiveScene, degrees: f32) {
    let mut camera = live.camera(0).expect("view 0 is the 3D view");
    camera.azimuth += degrees;
    live.set_camera(0, camera);
}

fn main() {
    let dir = tempfile::tempdir().unwrap();
    copy_example(dir.path());
    let gpu = Gpu::headless(AdapterChoice::PreferHardware).expect("an adapter");
    println!("adapter: {}", gpu.adapter);
    let renderer =
        SceneRenderer::open(gpu, &dir.path().join("scene.toml"), RenderOptions::default(), &mut |_, _, _| {}).unwrap();
    let mut live = LiveScene::new(renderer);
    assert_eq!(live.view_names(), ["3d", "axial"], "the ablation example's views");
    let headless: Vec<Duration> = (0..2)
        .map(|index| {
            headless_frame(&mut live, index);
            median((0..3).map(|_| headless_frame(&mut live, index)).collect())
        })
        .collect();
    println!("headless full frames: 3d {:.0} ms, axial {:.0} ms", ms(headless[0]), ms(headless[1]));
    let tiled = median((0..3).map(|_| headless_tiles(&mut live, 0, 24)).collect());
    println!("headless 3d in tiles of 24 rows (as the schedule cuts it): {:.0} ms", ms(tiled));

    let waiter = GpuWaiter::new(live.renderer().gpu().device.clone(), || {});
    let mut frames: Vec<ViewFrames> = (0..2).map(|_| ViewFrames::new(BUDGET)).collect();
    // The first pictures, which also measure each view's cost.
    run_until(&mut frames, &mut live, &waiter, |f, _| f.iter().all(|f| f.refiner().quality() == Quality::Full));
    let (mut settle, mut preview) = (Vec::new(), Vec::new());
    for round in 0..ROUNDS {
        // Both views change: the slice must settle in about its own time.
        orbit(&mut live, 7.0);
        let mut plane = live.slice(1).expect("view 1 is the slice");
        let step = if round % 2 == 0 { 0.02 } else { -0.02 };
        plane.origin += plane.u.cross(plane.v).normalize_or_zero() * step;
        live.set_slice(1, plane);
        let changed = live.generation(1);
        settle.push(run_until(&mut frames, &mut live, &waiter, move |f, _| {
            f[1].refiner().remaining_estimate(changed) == Some(Duration::ZERO)
        }));
        // The 3D view refines; an orbit step must show a preview at once.
        run_until(
            &mut frames,
            &mut live,
            &waiter,
            |f, _| matches!(f[0].refiner().quality(), Quality::Preview { refined, .. } if refined > 0.2),
        );
        orbit(&mut live, 3.0);
        frames[0].input(Instant::now());
        let wanted = live.generation(0);
        preview.push(run_until(&mut frames, &mut live, &waiter, move |f, _| {
            matches!(f[0].shown_last(), Some((Work::Preview { generation, .. }, _)) if generation == wanted)
        }));
        if std::env::var_os("VRS_BENCH_VERBOSE").is_some() {
            eprintln!("round {round}: preview {:?}", frames[0].shown_last());
        }
        run_until(&mut frames, &mut live, &waiter, |f, _| f.iter().all(|f| f.refiner().quality() == Quality::Full));
    }
    let (settle, preview) = (median(settle), median(preview));
    println!(
        "slice settled after a change of both views: {:.0} ms, {:.2}x its headless frame (target <= 2)",
        ms(settle),
        settle.as_secs_f64() / headless[1].as_secs_f64()
    );
    println!("3D preview after an orbit step while refining: {:.0} ms (target <= 100)", ms(preview));
    for (index, name) in ["3d", "axial"].iter().enumerate() {
        let estimate = frames[index].refiner().full_frame_estimate().expect("measured");
        println!(
            "{name}: full frame as measured by the schedule {:.0} ms, headless {:.0} ms ({:.2}x)",
            ms(estimate),
            ms(headless[index]),
            estimate.as_secs_f64() / headless[index].as_secs_f64()
        );
    }
}
