//! Carrying out the views' [`Refiner`] schedules on the GPU without ever waiting for it: one
//! piece of work in flight at a time, of the view that needs it most ([`crate::schedule`]), its
//! completion noticed by a thread that waits on the device in the window's stead, and the
//! newest complete picture of every view always ready to draw.

use crate::refine::{Quality, Refiner, Work};
use crate::schedule::{self, Candidate};
use crate::session::LiveScene;
use std::sync::mpsc::{Sender, channel};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use vrs_runtime::RuntimeError;
use vrs_runtime::view::{Region, create_output};

/// When a submission finished (set by the [`GpuWaiter`]'s thread).
type Done = Arc<Mutex<Option<Instant>>>;

/// A thread that waits for submissions to finish, so that the thread drawing the window never
/// has to. `wake` is called after each (to redraw).
pub struct GpuWaiter {
    sender: Sender<(wgpu::SubmissionIndex, Done)>,
}

impl GpuWaiter {
    /// Starts the thread that waits on `device`'s submissions, calling `wake` after each.
    pub fn new(device: wgpu::Device, wake: impl Fn() + Send + 'static) -> GpuWaiter {
        let (sender, submissions) = channel::<(wgpu::SubmissionIndex, Done)>();
        let spawned = std::thread::Builder::new().name("vrs-gpu-wait".into()).spawn(move || {
            for (index, done) in submissions {
                let _ = device.poll(wgpu::PollType::Wait { submission_index: Some(index), timeout: None });
                if let Ok(mut slot) = done.lock() {
                    *slot = Some(Instant::now());
                }
                wake();
            }
        });
        if spawned.is_err() {
            // Without the thread nothing would ever be reported finished; say so where it shows.
            eprintln!("warning: cannot start the GPU waiting thread; frames will not refine");
        }
        GpuWaiter { sender }
    }

    fn watch(&self, index: wgpu::SubmissionIndex) -> Done {
        let done = Done::default();
        let _ = self.sender.send((index, done.clone()));
        done
    }
}

/// The picture of a view to draw now.
pub struct Shown<'a> {
    /// `Rgba8Unorm`, premultiplied alpha; draw it over the view's whole rectangle.
    pub texture: &'a wgpu::Texture,
    /// How refined the picture is (a preview, full resolution, or stale).
    pub quality: Quality,
    /// How long the last piece of work took on the GPU, and what it was.
    pub last: Option<(Work, Duration)>,
}

/// The frames a progressive view's picture (the path tracer's) is refined to while it is left
/// alone: samples per pixel.
pub const PROGRESSIVE_FRAMES: u32 = 256;

/// The frames of one view: its schedule, its preview target and the work in flight.
pub struct ViewFrames {
    refiner: Refiner,
    preview: Option<(wgpu::Texture, [u32; 2])>,
    pending: Option<(Work, Instant, Done)>,
    last: Option<(Work, Duration)>,
    /// The output texture the full-resolution tiles went into; a new one (a reload, a resize)
    /// holds no picture yet.
    output: Option<wgpu::Texture>,
}

impl ViewFrames {
    /// Frames for a view, with an interactive frame budget.
    pub fn new(budget: Duration) -> ViewFrames {
        ViewFrames { refiner: Refiner::new([1, 1], budget), preview: None, pending: None, last: None, output: None }
    }

    /// The view's refinement schedule (its quality, what it renders next).
    pub fn refiner(&self) -> &Refiner {
        &self.refiner
    }

    /// The user interacts with the view now.
    pub fn input(&mut self, now: Instant) {
        self.refiner.input(now);
    }

    /// The last piece of work that finished, and how long it took on the GPU.
    pub fn shown_last(&self) -> Option<(Work, Duration)> {
        self.last
    }

    /// Whether work is in flight or waiting to be submitted.
    pub fn busy(&self) -> bool {
        self.pending.is_some() || self.refiner.quality() != Quality::Full || self.refiner.wants_more()
    }

    /// Drives the frames of every view (`views[i]` is view `i` of `live`): notes finished work
    /// and, when no view has work on the GPU, submits the most urgent next piece of any view
    /// (see `crate::schedule`: first pictures of a new state, then the tiles of the view that
    /// settles soonest), so that
    /// each piece's measured time is its own. Never waits. Returns the view whose piece could
    /// not be encoded or submitted, with the error; its schedule may ask for it again.
    pub fn step_views(
        views: &mut [&mut ViewFrames],
        live: &mut LiveScene,
        waiter: &GpuWaiter,
        now: Instant,
    ) -> Option<(usize, RuntimeError)> {
        for (index, frames) in views.iter_mut().enumerate() {
            frames.collect();
            frames.follow_output(live, index);
        }
        if views.iter().any(|f| f.pending.is_some()) {
            return None;
        }
        let candidates: Vec<Option<Candidate>> =
            views.iter().enumerate().map(|(index, f)| f.candidate(live.generation(index), now)).collect();
        let index = schedule::pick(&candidates)?;
        views[index].submit(live, index, waiter, now).err().map(|e| (index, e))
    }

    /// This view's next piece of work, with what orders it among the views'.
    fn candidate(&self, generation: u64, now: Instant) -> Option<Candidate> {
        let work = self.refiner.peek(generation, now)?;
        let first_picture = match work {
            Work::Preview { .. } => true,
            Work::Tile { region, .. } => region == Region::whole(self.refiner.full_size()),
        };
        Some(Candidate {
            work,
            interacting: self.refiner.interacting(now),
            first_picture,
            piece: self.refiner.estimate(&work),
            remaining: self.refiner.remaining_estimate(generation),
        })
    }

    /// Encodes and submits the next piece of the schedule.
    fn submit(
        &mut self,
        live: &mut LiveScene,
        index: usize,
        waiter: &GpuWaiter,
        now: Instant,
    ) -> Result<(), RuntimeError> {
        let Some(work) = self.refiner.next(live.generation(index), now) else { return Ok(()) };
        let gpu = live.renderer().gpu().clone();
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        let encoded = match work {
            Work::Preview { size, .. } => match self.preview_target(&gpu, size) {
                Ok(target) => {
                    let target = target.create_view(&Default::default());
                    live.encode(index, &mut encoder, &target, Region::whole(size))
                }
                Err(e) => Err(e),
            },
            Work::Tile { region, .. } => match live.output(index) {
                Some(output) => {
                    let target = output.create_view(&Default::default());
                    live.encode(index, &mut encoder, &target, region)
                }
                None => Err(RuntimeError::Invalid(format!("no view {index}"))),
            },
        };
        if let Err(e) = encoded {
            self.refiner.abandoned();
            return Err(e);
        }
        let submitted = Instant::now();
        let submission = gpu.capture("rendering", || gpu.queue.submit([encoder.finish()]));
        // A refused submission, or an error another thread left, abandons this piece of work:
        // the picture shown stays the last good one.
        let fault = submission.as_ref().err().cloned().or_else(|| gpu.take_fault());
        if let Some(fault) = fault {
            self.refiner.abandoned();
            return Err(fault.into());
        }
        let Ok(submission) = submission else { return Ok(()) };
        self.pending = Some((work, submitted, waiter.watch(submission)));
        Ok(())
    }

    /// The newest complete picture, or `None` before the first one.
    pub fn shown<'a>(&'a self, live: &'a LiveScene, index: usize) -> Option<Shown<'a>> {
        let quality = self.refiner.quality();
        let texture = match quality {
            Quality::None => return None,
            Quality::Full | Quality::Stale => live.output(index)?,
            Quality::Preview { .. } => &self.preview.as_ref()?.0,
        };
        Some(Shown { texture, quality, last: self.last })
    }

    fn collect(&mut self) {
        let finished = self.pending.as_ref().and_then(|(_, _, done)| *done.lock().ok()?);
        // Only finished work is taken: work still on the GPU stays pending (taking it would
        // leave the schedule waiting for it forever).
        let Some(at) = finished else { return };
        if let Some((work, submitted, _)) = self.pending.take() {
            let elapsed = at.saturating_duration_since(submitted);
            self.refiner.finished(&work, elapsed);
            self.last = Some((work, elapsed));
        }
    }

    /// A new output texture (reload, resize) or size starts the full picture again.
    fn follow_output(&mut self, live: &LiveScene, index: usize) {
        if let Some(size) = live.size(index) {
            self.refiner.resize(size);
        }
        let progressive = live.renderer().views().get(index).is_some_and(|v| v.renderer.is_progressive());
        self.refiner.set_frames(if progressive { PROGRESSIVE_FRAMES } else { 1 });
        let output = live.output(index);
        if output != self.output.as_ref() {
            self.refiner.output_replaced();
            self.output = output.cloned();
        }
    }

    fn preview_target(&mut self, gpu: &vrs_runtime::Gpu, size: [u32; 2]) -> Result<&wgpu::Texture, RuntimeError> {
        let preview = match self.preview.take() {
            Some((texture, made)) if made == size => (texture, made),
            _ => (create_output(gpu, size)?, size),
        };
        Ok(&self.preview.insert(preview).0)
    }
}
