//! Frame timing shared by the benchmarks: submit to completion, no read-back.

use std::time::Instant;
use vrs_runtime::SceneRenderer;

/// Times `frames` frames of view `view` (after one untimed frame), in ms.
pub fn frame_times_of(scene: &mut SceneRenderer, view: usize, frames: usize) -> Vec<f64> {
    let mut times = Vec::with_capacity(frames);
    for i in 0..=frames {
        let mut encoder = scene.gpu().device.create_command_encoder(&Default::default());
        scene.encode_view(view, &mut encoder).expect("encode");
        let start = Instant::now();
        scene.gpu().queue.submit([encoder.finish()]);
        scene.gpu().wait();
        if i > 0 {
            times.push(start.elapsed().as_secs_f64() * 1e3);
        }
    }
    times
}

/// Times `frames` frames of view 0.
#[allow(dead_code)]
pub fn frame_times(scene: &mut SceneRenderer, frames: usize) -> Vec<f64> {
    frame_times_of(scene, 0, frames)
}

/// The middle of `times` (the upper one of an even count).
pub fn median(mut times: Vec<f64>) -> f64 {
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}
