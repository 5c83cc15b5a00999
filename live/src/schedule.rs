//! Which view renders next when a scene has several: one piece of work is on the GPU at a time,
//! and the most urgent piece of any view goes next.
//!
//! All views share one queue, and a submission waits for the ones before it: with a piece in
//! flight per view, a cheap slice's tile waited behind a 3D view's, its measured time included
//! that wait (so its cost, and from it its tile sizes and preview resolution, were wrong), and
//! it settled only as fast as the heavy view. With one piece in flight at a time every measured
//! time is the piece's own, and no view waits longer than one piece of another (a preview, or a
//! tile of at most its `tile_budget`). The order:
//!
//! 1. **First pictures** of a view's new state (a preview at a reduced resolution, or the whole
//!    image when it fits the budget) before any refinement: the views the user is interacting
//!    with first, then the cheapest piece (its measured cost per pixel times its pixels), so a
//!    slice that renders whole in 20 ms is not kept behind a 3D view's 40 ms preview.
//! 2. **Tiles** of the view whose full picture will be complete soonest (its measured cost per
//!    pixel times the pixels it has left; a view not yet measured first): cheap views settle in
//!    about their own time while a heavy one refines after them.
//!
//! Ties go to the view listed first.

use crate::refine::Work;
use std::time::Duration;

/// A view's next piece of work, with what orders it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// The piece of work.
    pub work: Work,
    /// The user interacted with the view within its settle time.
    pub interacting: bool,
    /// The piece shows a picture of the view's new state at once (a preview, or the whole image).
    pub first_picture: bool,
    /// The estimated time of the piece itself; `None` before the view's cost is measured.
    pub piece: Option<Duration>,
    /// The estimated time to complete the view's full picture; `None` before it is measured.
    pub remaining: Option<Duration>,
}

/// The position in `candidates` of the piece to render next (`None` entries: views with
/// nothing to do), or `None` when no view has work.
pub fn pick(candidates: &[Option<Candidate>]) -> Option<usize> {
    candidates
        .iter()
        .enumerate()
        .filter_map(|(i, c)| c.as_ref().map(|c| (i, urgency(c))))
        .min_by(|(i, a), (j, b)| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal).then(i.cmp(j)))
        .map(|(i, _)| i)
}

/// A sort key: smaller goes first.
fn urgency(c: &Candidate) -> (u8, f64) {
    let seconds = |d: Option<Duration>| d.map_or(0.0, |d| d.as_secs_f64());
    if c.first_picture { (u8::from(!c.interacting), seconds(c.piece)) } else { (2, seconds(c.remaining)) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vrs_runtime::view::Region;

    fn preview(interacting: bool, piece_ms: Option<u64>) -> Option<Candidate> {
        let work = Work::Preview { generation: 1, size: [64, 64], scale: 0.25 };
        let piece = piece_ms.map(Duration::from_millis);
        Some(Candidate { work, interacting, first_picture: true, piece, remaining: None })
    }

    fn tile(remaining_ms: Option<u64>) -> Option<Candidate> {
        let work = Work::Tile { generation: 1, region: Region { x0: 0, y0: 0, x1: 256, y1: 8 } };
        let remaining = remaining_ms.map(Duration::from_millis);
        Some(Candidate { work, interacting: false, first_picture: false, piece: None, remaining })
    }

    /// The whole image at once: a first picture, like a preview.
    fn whole(piece_ms: u64) -> Option<Candidate> {
        let work = Work::Tile { generation: 1, region: Region::whole([256, 256]) };
        let piece = Some(Duration::from_millis(piece_ms));
        Some(Candidate { work, interacting: false, first_picture: true, piece, remaining: piece })
    }

    #[test]
    fn the_cheapest_view_refines_first() {
        // A 3D view with 70 s left and a slice with 1 s left: the slice's tiles go first.
        assert_eq!(pick(&[tile(Some(70_000)), tile(Some(1_000))]), Some(1));
        // Not yet measured: measured first (its first tile is what measures it).
        assert_eq!(pick(&[tile(Some(1_000)), tile(None)]), Some(1));
        // Equal: the first listed.
        assert_eq!(pick(&[tile(Some(5)), tile(Some(5))]), Some(0));
    }

    #[test]
    fn first_pictures_go_before_tiles_the_view_in_hand_first_then_the_cheapest() {
        assert_eq!(pick(&[tile(Some(1)), preview(false, Some(40))]), Some(1));
        assert_eq!(pick(&[tile(Some(1)), whole(20)]), Some(1));
        assert_eq!(pick(&[preview(false, Some(10)), preview(true, Some(40))]), Some(1));
        assert_eq!(pick(&[preview(false, Some(40)), preview(false, Some(10))]), Some(1));
        // A slice rendered whole in 20 ms goes before a 3D view's 40 ms preview.
        assert_eq!(pick(&[preview(false, Some(40)), whole(20)]), Some(1));
        assert_eq!(pick(&[preview(true, Some(40)), whole(20)]), Some(0));
    }

    #[test]
    fn nothing_to_do_picks_nothing() {
        assert_eq!(pick(&[]), None);
        assert_eq!(pick(&[None, None]), None);
        assert_eq!(pick(&[None, tile(None)]), Some(1));
    }
}
