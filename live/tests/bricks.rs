//! Streaming bricks while the user looks, as `vrsc view` runs it but without a window, on the
//! software adapter: each redraw steps every view's frames (encode and submit, never waiting)
//! and then streams; bricks the rays asked for arrive over later redraws, every view draws
//! again when they do, and the loop settles once nothing is loading.

use std::path::Path;
use std::time::{Duration, Instant};
use vrs_live::{GpuWaiter, LiveScene, ViewFrames};
use vrs_runtime::bricks::Residency;
use vrs_runtime::{AdapterChoice, Gpu, RenderOptions, SceneRenderer};

/// The abdomen phantom at 128^3 in bricks (64^3: eight at the finest level, one coarser) and a
/// 3D view large enough that its rays ask for the finest level.
const SCENE: &str = r#"
[render]
compositing = "dvr"
jitter = 0.0

[[volume]]
name = "body"
role = "primary"
phantom = "abdomen"
bricks = true

[[view]]
name = "3d"
kind = "raycast"
size = [192, 192]
camera = { azimuth = 35.0, elevation = 20.0, distance = 1.8 }

[[view]]
name = "axial"
kind = "slice"
axis = "axial"
position = 0.5
size = [128, 128]
"#;

/// Redraws at most this many times before the test gives up.
const MAX_REDRAWS: usize = 2000;

fn open(dir: &Path, text: &str, phantom: u32) -> LiveScene {
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    let gpu = Gpu::headless(AdapterChoice::Software).expect("the software adapter (lavapipe) is required");
    let options = RenderOptions { phantom_size: [phantom; 3], ..RenderOptions::default() };
    let renderer = SceneRenderer::open(gpu, &path, options, &mut |_, _, _| {}).unwrap_or_else(|e| panic!("{e}"));
    LiveScene::new(renderer)
}

/// Bricks placed in the pool or found to hold one value, since the volume was made.
fn placed(r: Residency) -> u64 {
    r.loaded + u64::from(r.constant)
}

#[test]
fn bricks_stream_in_between_frames_and_the_views_draw_again_with_them() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = open(dir.path(), SCENE, 128);
    let start = live.renderer().brick_residency().expect("bricked volumes");
    let waiter = GpuWaiter::new(live.renderer().gpu().device.clone(), || {});
    let views = live.view_names().len();
    let mut frames: Vec<ViewFrames> = (0..views).map(|_| ViewFrames::new(Duration::from_millis(100))).collect();
    let (mut arrivals, mut redrawn_after_arrival, mut settled) = (0, 0, false);
    let mut redraws = 0;
    for _ in 0..MAX_REDRAWS {
        redraws += 1;
        let now = Instant::now();
        let mut all: Vec<&mut ViewFrames> = frames.iter_mut().collect();
        if let Some((index, e)) = ViewFrames::step_views(&mut all, &mut live, &waiter, now) {
            panic!("view {index}: {e}");
        }
        let generations: Vec<u64> = (0..views).map(|i| live.generation(i)).collect();
        let progress = live.stream_bricks().unwrap_or_else(|e| panic!("{e}")).expect("a bricked scene");
        if placed(progress.residency) > placed(start) + arrivals {
            arrivals = placed(progress.residency) - placed(start);
            redrawn_after_arrival += 1;
            assert!(
                (0..views).all(|i| live.generation(i) > generations[i]),
                "bricks were placed: every view must draw again"
            );
        }
        if !live.bricks_busy() && !frames.iter().any(ViewFrames::busy) {
            settled = true;
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(settled, "streaming did not settle within {MAX_REDRAWS} redraws: {:?}", live.brick_progress());
    let end = live.brick_progress().expect("progress of the last call");
    eprintln!("settled after {redraws} redraws, {arrivals} bricks placed ({redrawn_after_arrival} times): {end:?}");
    assert!(arrivals > 0 && redrawn_after_arrival > 0, "the finest bricks must stream in: {end:?}");
    assert_eq!(end.residency.pending, 0, "{end:?}");
    assert!(end.residency.resident + end.residency.constant > start.resident + start.constant, "{start:?} -> {end:?}");
    // Settled: another redraw draws nothing and asks for nothing.
    let generations: Vec<u64> = (0..views).map(|i| live.generation(i)).collect();
    assert_eq!(live.stream_bricks().unwrap(), Some(end));
    assert_eq!((0..views).map(|i| live.generation(i)).collect::<Vec<_>>(), generations);
}

#[test]
fn a_scene_without_bricked_volumes_streams_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let text = SCENE.replace("bricks = true", "bricks = false");
    let mut live = open(dir.path(), &text, 32);
    assert_eq!(live.stream_bricks().unwrap(), None);
    assert!(!live.bricks_busy() && live.brick_progress().is_none());
}
