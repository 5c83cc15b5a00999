//! Save-to-new-frame latency of the live loop on `examples/ablation` (run on lavapipe:
//! `VRS_ADAPTER=software cargo bench -p vrs-live --bench reload`): for a uniform-only edit of the
//! scene and for a structural edit of `compose_3d.vrs` (a new constant each round, so naga and the
//! driver compile a new pipeline every time), the time from the file write to the rebuilt state
//! (compose + upload, or compose + pipeline compile), then one full frame of the 3D view; and the
//! frame while orbiting (the preview the refinement schedule picks for a 100 ms budget) against
//! the still, full-resolution frame. Prints medians over the rounds.

use std::path::Path;
use std::time::{Duration, Instant};
use vrs_live::{LiveScene, Refiner, Work};
use vrs_runtime::view::{Region, create_output};
use vrs_runtime::{AdapterChoice, Gpu, RenderOptions, SceneRenderer};

const ROUNDS: usize = 7;

fn copy_example(to: &Path) {
    let from = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/ablation");
    for entry in std::fs::read_dir(&from).unwrap().flatten() {
        if entry.path().is_file() {
            std::fs::copy(entry.path(), to.join(entry.file_name())).unwrap();
        }
    }
}

/// Renders `region` of view 0 into `target` and waits for it.
fn frame(live: &mut LiveScene, target: &wgpu::Texture, region: Region) -> Duration {
    let gpu = live.renderer().gpu().clone();
    let started = Instant::now();
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    live.encode(0, &mut encoder, &target.create_view(&Default::default()), region).unwrap();
    gpu.queue.submit([encoder.finish()]);
    gpu.wait();
    started.elapsed()
}

fn median(mut v: Vec<Duration>) -> f64 {
    v.sort();
    v[v.len() / 2].as_secs_f64() * 1e3
}

fn main() {
    let dir = tempfile::tempdir().unwrap();
    copy_example(dir.path());
    let scene_path = dir.path().join("scene.toml");
    let gpu = Gpu::headless(AdapterChoice::PreferHardware).expect("an adapter");
    println!("adapter: {}", gpu.adapter);
    let renderer = SceneRenderer::open(gpu, &scene_path, RenderOptions::default(), &mut |_, _, _| {}).unwrap();
    let mut live = LiveScene::new(renderer);
    let size = live.size(0).unwrap();
    let output = live.output(0).unwrap().clone();
    frame(&mut live, &output, Region::whole(size));

    let scene_text = std::fs::read_to_string(&scene_path).unwrap();
    let module_path = dir.path().join("compose_3d.vrs");
    let module_text = std::fs::read_to_string(&module_path).unwrap();
    let (mut uniform_rebuild, mut uniform_frame, mut structural_rebuild, mut structural_frame) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for round in 0..ROUNDS {
        // Uniform-only: the scene's applicator radius, a new value each round.
        let edited = scene_text.replacen("0.07", &format!("0.0{}", 70 + round), 1);
        let started = Instant::now();
        std::fs::write(&scene_path, &edited).unwrap();
        let rebuild = live.rebuild();
        assert!(rebuild.succeeded() && rebuild.outcome.as_ref().unwrap().compiled == 0);
        uniform_rebuild.push(started.elapsed());
        let output = live.output(0).unwrap().clone();
        uniform_frame.push(frame(&mut live, &output, Region::whole(size)));

        // Structural: a new constant in the shell's opacity, so a new pipeline.
        let edited = module_text
            .replace("let a = shell_opacity * shell;", &format!("let a = shell_opacity * shell * 0.9{round};"));
        let started = Instant::now();
        std::fs::write(&module_path, &edited).unwrap();
        let rebuild = live.rebuild();
        assert!(rebuild.succeeded() && rebuild.outcome.as_ref().unwrap().compiled >= 1, "a structural edit compiles");
        structural_rebuild.push(started.elapsed());
        let output = live.output(0).unwrap().clone();
        structural_frame.push(frame(&mut live, &output, Region::whole(size)));
    }
    println!(
        "uniform-only edit: write to rebuilt (compose + upload) {:.2} ms, then a full frame {:.0} ms",
        median(uniform_rebuild),
        median(uniform_frame.clone())
    );
    println!(
        "structural edit: write to rebuilt (compose + pipeline compile) {:.1} ms, then a full frame {:.0} ms",
        median(structural_rebuild),
        median(structural_frame)
    );

    for example in ["ablation/scene.toml", "basic/scene.toml"] {
        orbit(example);
    }
}

/// Orbiting: previews as the refinement schedule picks them for a 100 ms budget (fed with each
/// frame's measured time, as the viewer does), against the still, full-resolution frame.
fn orbit(example: &str) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples").join(example);
    let gpu = Gpu::headless(AdapterChoice::PreferHardware).expect("an adapter");
    let renderer = SceneRenderer::open(gpu, &path, RenderOptions::default(), &mut |_, _, _| {}).unwrap();
    let mut live = LiveScene::new(renderer);
    let size = live.size(0).unwrap();
    let output = live.output(0).unwrap().clone();
    frame(&mut live, &output, Region::whole(size));
    let still: Vec<Duration> = (0..3).map(|_| frame(&mut live, &output, Region::whole(size))).collect();
    let mut refiner = Refiner::new(size, Duration::from_millis(100));
    refiner.finished(&Work::Tile { generation: 0, region: Region::whole(size) }, still[0]);
    let mut previews = Vec::new();
    for round in 1..=12u64 {
        let mut camera = live.camera(0).unwrap();
        camera.azimuth += 5.0;
        live.set_camera(0, camera);
        refiner.input(Instant::now());
        let Some(work) = refiner.next(round, Instant::now()) else { continue };
        let Work::Preview { size: preview, scale, .. } = work else {
            println!("{example}: the full frame fits the budget: no preview needed while orbiting");
            return;
        };
        let target = create_output(live.renderer().gpu(), preview).expect("a preview target");
        let t = frame(&mut live, &target, Region::whole(preview));
        refiner.finished(&work, t);
        previews.push((scale, preview, t));
    }
    let settled = &previews[previews.len() - 5..];
    let (scale, preview, _) = settled[settled.len() - 1];
    let o = median(settled.iter().map(|p| p.2).collect());
    let s = median(still);
    println!(
        "{example} orbiting: settles on preview 1/{:.0} ({}x{}), {o:.0} ms a frame (median of the last 5 of 12); \
         still: full {}x{} {s:.0} ms ({:.1}x)",
        1.0 / scale,
        preview[0],
        preview[1],
        size[0],
        size[1],
        s / o
    );
}
