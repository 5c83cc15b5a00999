//! Progressive refinement as a schedule, without a GPU: what a view should render next so that
//! an interactive frame stays within its budget and the picture reaches full quality when input
//! stops (VTK's interactive and still update rates, as one rule).
//!
//! Every change of a view (its generation) first gets a **preview**: the whole image at the
//! largest resolution whose estimated cost fits the frame budget. While the user keeps
//! interacting nothing else is rendered; once input has been quiet for the settle time the
//! full-resolution image is rendered in **tiles** of rows, each sized to the tile budget, so
//! that no single submission holds the GPU queue (and the window's own frames) for long. The
//! estimate is a running average of measured time per pixel.

use std::time::{Duration, Instant};
use vrs_runtime::view::Region;

/// What to render next for a view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Work {
    /// The whole image at `size` (a fraction `scale` of the full size) into the preview target.
    Preview {
        /// The view's state it renders (as given to [`Refiner::next`]).
        generation: u64,
        /// The preview's pixels (width, height).
        size: [u32; 2],
        /// `size` over the full size, per axis (at least 1/8).
        scale: f32,
    },
    /// `region` of the full-resolution image.
    Tile {
        /// The view's state it renders (as given to [`Refiner::next`]).
        generation: u64,
        /// The rows of the full image it renders.
        region: Region,
    },
}

impl Work {
    fn generation(&self) -> u64 {
        match *self {
            Work::Preview { generation, .. } | Work::Tile { generation, .. } => generation,
        }
    }

    fn pixels(&self) -> u64 {
        match self {
            Work::Preview { size, .. } => Region::whole(*size).pixels(),
            Work::Tile { region, .. } => region.pixels(),
        }
    }
}

/// How good the picture on screen is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Quality {
    /// Nothing rendered yet.
    None,
    /// A preview at `scale` of the full resolution; `refined` of the full image is done.
    Preview {
        /// The preview's size over the full size, per axis.
        scale: f32,
        /// The fraction (0 to 1) of the full image's rows rendered so far.
        refined: f32,
    },
    /// The full-resolution image of the current state.
    Full,
    /// The full-resolution image of an earlier state (the new one is on its way).
    Stale,
}

/// The schedule of one view. Feed it the view's generation, input times and finished work.
#[derive(Clone, Debug)]
pub struct Refiner {
    full: [u32; 2],
    /// The interactive frame budget of this view.
    pub budget: Duration,
    /// The longest a full-resolution tile should take.
    pub tile_budget: Duration,
    /// How long input must be quiet before refining.
    pub settle: Duration,
    /// Measured seconds per pixel (running average, so it follows what the last pieces
    /// covered); `None` before the first measurement.
    cost: Option<f64>,
    /// The time of the current generation's tiles so far, from its first row.
    picture_time: Duration,
    /// The summed time of the tiles of the last complete full-resolution picture: the view's
    /// measured cost of a full frame (rows differ in cost, so no one tile's rate gives it).
    full_time: Option<Duration>,
    generation: Option<u64>,
    preview: Option<(u64, f32)>,
    /// The generation whose full image is complete and intact (no newer tile written over it).
    full_done: Option<u64>,
    next_row: u32,
    last_input: Option<Instant>,
    in_flight: bool,
    /// The full-resolution frames a picture is the mean of when complete (a progressive view:
    /// the path tracer; 1 for the others), and those the current generation's holds.
    frames: u32,
    frames_done: u32,
}

/// The smallest preview scale: 1/8 of the resolution on each axis.
const MIN_SCALE_DIVISOR: u32 = 8;
/// The first preview, before anything was measured, is cheap: a quarter of each axis.
const FIRST_SCALE_DIVISOR: u32 = 4;
/// Tiles are whole multiples of the workgroup height.
const ROW_GRANULE: u32 = 8;

impl Refiner {
    /// A schedule for a view of `full` pixels with an interactive frame budget.
    pub fn new(full: [u32; 2], budget: Duration) -> Refiner {
        Refiner {
            full,
            budget,
            tile_budget: Duration::from_millis(40),
            settle: Duration::from_millis(150),
            cost: None,
            picture_time: Duration::ZERO,
            full_time: None,
            generation: None,
            preview: None,
            full_done: None,
            next_row: 0,
            last_input: None,
            in_flight: false,
            frames: 1,
            frames_done: 0,
        }
    }

    /// Sets the frames the view's complete picture is the mean of: above 1, the full image is
    /// rendered again, tile by tile, until it holds that many (each frame adds one sample per
    /// pixel to a progressive view's history).
    pub fn set_frames(&mut self, frames: u32) {
        self.frames = frames.max(1);
    }

    /// The full-resolution frames the current generation's picture holds.
    pub fn frames_done(&self) -> u32 {
        if self.full_done == self.generation { self.frames_done } else { 0 }
    }

    /// Whether the full picture of the current generation is shown but is to hold more frames.
    pub fn wants_more(&self) -> bool {
        self.full_done.is_some() && self.full_done == self.generation && self.frames_done < self.frames
    }

    /// The view's full size changed (the window was resized): everything starts again.
    pub fn resize(&mut self, full: [u32; 2]) {
        if full != self.full {
            self.full = full;
            self.preview = None;
            self.full_done = None;
            self.generation = None;
        }
    }

    /// The full-resolution texture was replaced by a new one, which holds no picture yet.
    pub fn output_replaced(&mut self) {
        self.full_done = None;
        self.next_row = 0;
        self.frames_done = 0;
    }

    /// The user is interacting with the view now (dragging, scrolling).
    pub fn input(&mut self, now: Instant) {
        self.last_input = Some(now);
    }

    /// Whether the user interacted within the settle time.
    pub fn interacting(&self, now: Instant) -> bool {
        self.last_input.is_some_and(|t| now.saturating_duration_since(t) < self.settle)
    }

    /// The next piece of work for `generation`, or `None` while work is in flight, while the
    /// user interacts with a preview shown, or when the picture is complete.
    pub fn next(&mut self, generation: u64, now: Instant) -> Option<Work> {
        if self.in_flight {
            return None;
        }
        if self.generation != Some(generation) {
            self.generation = Some(generation);
            self.next_row = 0;
            self.frames_done = 0;
        }
        let has_preview = self.preview.is_some_and(|(g, _)| g == generation);
        let work = if self.full_done == Some(generation) && self.frames_done >= self.frames {
            return None;
        } else if self.full_done == Some(generation) {
            // A progressive view's next frame, once the user lets go.
            if self.interacting(now) {
                return None;
            }
            self.tile(generation)
        } else if !has_preview && self.next_row == 0 {
            self.first_work(generation)
        } else if self.interacting(now) {
            return None;
        } else {
            self.tile(generation)
        };
        if matches!(work, Work::Tile { .. }) && self.full_done.is_some_and(|g| g != generation) {
            // The full image's texture now mixes two states: no longer a picture to show.
            self.full_done = None;
        }
        self.in_flight = true;
        Some(work)
    }

    /// What [`Refiner::next`] would hand out now, without handing it out.
    pub fn peek(&self, generation: u64, now: Instant) -> Option<Work> {
        self.clone().next(generation, now)
    }

    /// The view's full size (the full-resolution image's pixels).
    pub fn full_size(&self) -> [u32; 2] {
        self.full
    }

    /// The estimated time of `work`: the measured cost per pixel times its pixels; `None` before
    /// anything was measured.
    pub fn estimate(&self, work: &Work) -> Option<Duration> {
        self.cost.map(|cost| Duration::from_secs_f64(cost * work.pixels() as f64))
    }

    /// The estimated time to complete the full picture of `generation`: the measured cost per
    /// pixel times the rows it has left; `None` before anything was measured.
    pub fn remaining_estimate(&self, generation: u64) -> Option<Duration> {
        let whole = Region::whole(self.full).pixels().max(1) as f64;
        let cost = self.full_time.map(|t| t.as_secs_f64() / whole).or(self.cost)?;
        let current = self.generation == Some(generation);
        let rows_done = if self.full_done == Some(generation) && !self.wants_more() {
            self.full[1]
        } else if current {
            self.next_row
        } else {
            0
        };
        // A progressive view's frames after this one.
        let frames_after = if current { self.frames.saturating_sub(self.frames_done + 1) } else { self.frames - 1 };
        let rows =
            u64::from(self.full[1].saturating_sub(rows_done)) + u64::from(frames_after) * u64::from(self.full[1]);
        let pixels = rows * u64::from(self.full[0]);
        Some(Duration::from_secs_f64(cost * pixels as f64))
    }

    /// A preview, or the whole full image at once when it fits the budget.
    fn first_work(&mut self, generation: u64) -> Work {
        let divisor = self.preview_divisor();
        if divisor == 1 {
            return Work::Tile { generation, region: Region::whole(self.full) };
        }
        let size = [self.full[0].div_ceil(divisor), self.full[1].div_ceil(divisor)];
        Work::Preview { generation, size, scale: 1.0 / divisor as f32 }
    }

    /// The resolution divisor whose estimated cost fits the budget (1 = full resolution).
    fn preview_divisor(&self) -> u32 {
        let Some(cost) = self.cost else { return FIRST_SCALE_DIVISOR };
        let full_cost = cost * Region::whole(self.full).pixels() as f64;
        let ratio = (full_cost / self.budget.as_secs_f64().max(1e-6)).sqrt();
        (ratio.ceil() as u32).clamp(1, MIN_SCALE_DIVISOR)
    }

    fn tile(&mut self, generation: u64) -> Work {
        let [w, h] = self.full;
        let rows = match self.cost {
            Some(cost) => (self.tile_budget.as_secs_f64() / (cost * f64::from(w.max(1)))) as u32,
            None => ROW_GRANULE,
        };
        let rows = (rows / ROW_GRANULE * ROW_GRANULE).max(ROW_GRANULE);
        let y0 = self.next_row.min(h);
        let y1 = (y0 + rows).min(h);
        Work::Tile { generation, region: Region { x0: 0, y0, x1: w, y1 } }
    }

    /// `work` finished on the GPU after `elapsed`.
    pub fn finished(&mut self, work: &Work, elapsed: Duration) {
        self.in_flight = false;
        let pixels = work.pixels().max(1) as f64;
        let sample = elapsed.as_secs_f64() / pixels;
        self.cost = Some(match self.cost {
            Some(cost) => 0.5 * cost + 0.5 * sample,
            None => sample,
        });
        let generation = work.generation();
        if self.generation != Some(generation) {
            return;
        }
        match *work {
            Work::Preview { scale, .. } => self.preview = Some((generation, scale)),
            Work::Tile { region, .. } => {
                self.next_row = region.y1;
                self.picture_time = if region.y0 == 0 { elapsed } else { self.picture_time + elapsed };
                if region.y1 >= self.full[1] {
                    self.full_done = Some(generation);
                    self.full_time = Some(self.picture_time);
                    self.frames_done += 1;
                    if self.frames_done < self.frames {
                        // The next frame starts again from the first row.
                        self.next_row = 0;
                    }
                }
            }
        }
    }

    /// Work that never finished (its submission failed): it may be asked for again.
    pub fn abandoned(&mut self) {
        self.in_flight = false;
    }

    /// Whether to show the full-resolution texture rather than the preview: the newest complete
    /// picture is shown, the full one when both are of the same state.
    pub fn full_shown(&self) -> bool {
        match (self.full_done, self.preview) {
            (Some(full), Some((preview, _))) => full >= preview,
            (Some(_), None) => true,
            (None, _) => false,
        }
    }

    /// How good the picture on screen is (see [`Refiner::full_shown`] for which texture).
    pub fn quality(&self) -> Quality {
        if self.full_shown() {
            return if self.full_done == self.generation { Quality::Full } else { Quality::Stale };
        }
        match self.preview {
            Some((generation, scale)) => {
                let current = Some(generation) == self.generation;
                let refined = if current { self.next_row as f32 / self.full[1].max(1) as f32 } else { 0.0 };
                Quality::Preview { scale, refined }
            }
            None => Quality::None,
        }
    }

    /// The cost of a full-resolution frame: the tiles of the last complete one summed, or before
    /// there is one, the measured cost per pixel times the pixels.
    pub fn full_frame_estimate(&self) -> Option<Duration> {
        let extrapolated = || self.cost.map(|c| Duration::from_secs_f64(c * Region::whole(self.full).pixels() as f64));
        self.full_time.or_else(extrapolated)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Duration = Duration::from_millis(1);

    /// Runs the schedule as a GPU of `ns_per_px` would, with no input, until it is idle.
    fn settle(r: &mut Refiner, generation: u64, now: Instant, ns_per_px: u64) -> Vec<Work> {
        let mut done = Vec::new();
        while let Some(work) = r.next(generation, now) {
            r.finished(&work, Duration::from_nanos(ns_per_px * work.pixels()));
            done.push(work);
            assert!(done.len() < 1000, "the schedule never ends");
        }
        done
    }

    #[test]
    fn a_slow_adapter_previews_first_then_refines_in_tiles_that_cover_the_image() {
        let now = Instant::now();
        let mut r = Refiner::new([512, 512], 100 * MS);
        // 2 µs per pixel: a full frame is 524 ms, five times the budget.
        let work = settle(&mut r, 1, now, 2000);
        assert!(matches!(work[0], Work::Preview { scale, .. } if scale == 0.25), "{:?}", work[0]);
        let tiles: Vec<Region> = work[1..]
            .iter()
            .map(|w| match w {
                Work::Tile { region, .. } => *region,
                other => panic!("expected tiles after the preview, got {other:?}"),
            })
            .collect();
        assert_eq!(tiles.first().map(|t| t.y0), Some(0));
        assert!(tiles.windows(2).all(|p| p[0].y1 == p[1].y0), "tiles must follow each other");
        assert_eq!(tiles.last().map(|t| t.y1), Some(512));
        for t in &tiles[..tiles.len() - 1] {
            let cost = t.pixels() as f64 * 2e-6;
            assert!(cost <= 0.045, "a tile of {cost} s exceeds the tile budget");
        }
        assert_eq!(r.quality(), Quality::Full);
        assert!(r.full_shown());
    }

    #[test]
    fn the_preview_resolution_follows_the_measured_cost_to_fit_the_budget() {
        let now = Instant::now();
        let mut r = Refiner::new([512, 512], 100 * MS);
        settle(&mut r, 1, now, 2000);
        // Measured: 524 ms per full frame, so a preview at 1/3 (58 ms) is the largest that fits.
        let Some(Work::Preview { size, scale, .. }) = r.next(2, now) else { panic!("expected a preview") };
        assert_eq!((size, scale), ([171, 171], 1.0 / 3.0));
        let estimate = 2e-6 * (171.0 * 171.0);
        assert!(estimate < 0.1, "{estimate}");
    }

    #[test]
    fn a_fast_adapter_renders_the_full_image_at_once() {
        let now = Instant::now();
        let mut r = Refiner::new([512, 512], 100 * MS);
        settle(&mut r, 1, now, 10); // 2.6 ms per frame
        let work = settle(&mut r, 2, now, 10);
        assert_eq!(work, vec![Work::Tile { generation: 2, region: Region::whole([512, 512]) }]);
    }

    #[test]
    fn while_the_user_interacts_only_previews_are_rendered() {
        let start = Instant::now();
        let mut r = Refiner::new([256, 256], 100 * MS);
        settle(&mut r, 1, start, 2000);
        for (i, generation) in (2..10).enumerate() {
            let now = start + 30 * MS * i as u32;
            r.input(now);
            let work = settle(&mut r, generation, now, 2000);
            assert!(matches!(work[..], [Work::Preview { .. }]), "generation {generation}: {work:?}");
            assert!(matches!(r.quality(), Quality::Preview { .. }));
        }
        let later = start + Duration::from_secs(2);
        let work = settle(&mut r, 9, later, 2000);
        assert!(!work.is_empty() && work.iter().all(|w| matches!(w, Work::Tile { .. })));
        assert_eq!(r.quality(), Quality::Full);
    }

    #[test]
    fn a_full_frame_costs_what_its_tiles_took_together() {
        let now = Instant::now();
        let mut r = Refiner::new([64, 64], 100 * MS);
        let preview = r.next(1, now).expect("a preview");
        r.finished(&preview, 5 * MS);
        // Rows in the middle cost ten times the edges'; the running rate follows the last tile.
        let mut total = Duration::ZERO;
        while let Some(work) = r.next(1, now) {
            let Work::Tile { region, .. } = work else { panic!("tiles after the preview") };
            let per_row = if (16..48).contains(&region.y0) { 10 * MS } else { MS };
            let took = per_row * (region.y1 - region.y0);
            total += took;
            r.finished(&work, took);
        }
        assert_eq!(r.quality(), Quality::Full);
        assert_eq!(r.full_frame_estimate(), Some(total));
        assert_eq!(r.remaining_estimate(2), Some(total), "a new state has every row left");
        assert_eq!(r.remaining_estimate(1), Some(Duration::ZERO), "the picture is complete");
        assert_eq!(r.peek(2, now), r.clone().next(2, now), "peeking hands out nothing");
    }

    #[test]
    fn a_progressive_view_renders_whole_frames_until_its_picture_holds_enough() {
        let start = Instant::now();
        let mut r = Refiner::new([64, 64], 100 * MS);
        r.set_frames(3);
        // 50 µs per pixel: 205 ms a frame, so a preview and then tiles of each frame.
        let work = settle(&mut r, 1, start, 50_000);
        let frames = work.iter().filter(|w| matches!(w, Work::Tile { region, .. } if region.y1 == 64)).count();
        assert_eq!(frames, 3, "three whole frames: {work:?}");
        assert_eq!(work.iter().filter(|w| matches!(w, Work::Preview { .. })).count(), 1, "one preview first");
        assert_eq!((r.quality(), r.frames_done(), r.wants_more()), (Quality::Full, 3, false));
        assert_eq!(r.remaining_estimate(1), Some(Duration::ZERO));
        // A change starts again; while the user interacts only previews come, and the picture
        // shown between frames stays the full one.
        let now = start + Duration::from_secs(1);
        let first = settle(&mut r, 2, now, 50_000);
        assert_eq!(r.frames_done(), 3);
        assert!(first.iter().all(|w| w.generation() == 2));
        r.input(now);
        let _ = settle(&mut r, 3, now, 50_000);
        assert_eq!((r.frames_done(), r.wants_more()), (0, false), "a preview of generation 3 only");
    }

    #[test]
    fn between_frames_a_progressive_view_shows_its_full_picture_and_counts_what_is_left() {
        let now = Instant::now();
        let mut r = Refiner::new([64, 64], 100 * MS);
        r.set_frames(4);
        while r.frames_done() < 1 {
            let work = r.next(1, now).expect("work until the first frame");
            r.finished(&work, Duration::from_nanos(50_000 * work.pixels()));
        }
        assert!(r.wants_more() && r.full_shown() && r.quality() == Quality::Full);
        let frame = r.full_frame_estimate().expect("measured");
        let left = r.remaining_estimate(1).expect("measured");
        assert!(left.abs_diff(frame * 3) < Duration::from_micros(1), "three frames left: {left:?} against {frame:?}");
        let tile = r.next(1, now).expect("the next frame's first tile");
        assert!(matches!(tile, Work::Tile { region, .. } if region.y0 == 0));
        assert!(r.full_shown(), "a frame of the same state written over the last is still a picture of it");
    }

    #[test]
    fn one_piece_of_work_is_in_flight_at_a_time() {
        let now = Instant::now();
        let mut r = Refiner::new([64, 64], 100 * MS);
        let first = r.next(1, now).expect("work");
        assert_eq!(r.next(1, now), None, "nothing more before the first finishes");
        r.finished(&first, MS);
        assert!(r.next(1, now).is_some());
    }

    #[test]
    fn work_finished_for_an_older_generation_does_not_count_as_the_new_picture() {
        let now = Instant::now();
        let mut r = Refiner::new([64, 64], 100 * MS);
        settle(&mut r, 1, now, 50_000); // full image of generation 1 complete (205 ms a frame)
        assert_eq!(r.quality(), Quality::Full);
        let preview = r.next(2, now).expect("a preview of generation 2");
        r.finished(&preview, Duration::from_nanos(50_000 * preview.pixels()));
        let tile = r.next(2, now).expect("a tile of generation 2");
        assert!(matches!(tile, Work::Tile { .. }));
        assert!(!r.full_shown(), "the full texture mixes two generations now");
        assert!(matches!(r.quality(), Quality::Preview { .. }));
        let _ = r.next(3, now); // generation 3 arrives while the tile is in flight
        r.finished(&tile, Duration::from_nanos(50_000 * tile.pixels()));
        assert!(!r.full_shown());
        let work = settle(&mut r, 3, now, 50_000);
        assert!(matches!(work.first(), Some(Work::Preview { generation: 3, .. })), "{work:?}");
        assert_eq!(r.quality(), Quality::Full);
    }
}
