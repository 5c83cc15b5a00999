//! Streaming bricked volumes while the user looks, as a pure rule: after each redraw the loop
//! reads back what the frames asked for, and it must keep calling until every frame drawn has
//! been read back, nothing is loading and nothing new arrived. Stopping earlier would leave a
//! picture coarser than it should be until the next input; going on longer would copy the
//! request buffers on every redraw for nothing.

use vrs_runtime::bricks::Residency;
use vrs_runtime::scene::BrickProgress;

/// Rounds in a row (since the last change of the user's or the files') in which placing bricks
/// evicted others, after which arrivals no longer redraw the views. When the bricks the views
/// need do not fit the pool, each redraw (a preview, then tiles that each use other bricks)
/// evicts what the last one used and asks for it again: without a bound the viewer would draw
/// forever. As many as `render_all` runs rounds.
const MAX_EVICTING_ROUNDS: u32 = 64;

/// What the live loop knows of the streaming of its bricked volumes.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Streaming {
    /// The outcome of the last call, for display.
    last: Option<BrickProgress>,
    /// Frames were drawn after the last read-back started.
    unread: bool,
    /// Rounds that evicted bricks since the last change ([`MAX_EVICTING_ROUNDS`]).
    evicting: u32,
}

impl Streaming {
    /// A frame was recorded: its rays may ask for bricks.
    pub fn drawn(&mut self) {
        self.unread = true;
    }

    /// The last outcome, `None` before the first call or without bricked volumes.
    pub fn last(&self) -> Option<BrickProgress> {
        self.last
    }

    /// Forgets everything (the scene no longer has bricked volumes).
    pub fn clear(&mut self) {
        *self = Streaming::default();
    }

    /// The user or the files changed a view: it asks for bricks anew, and arrivals redraw the
    /// views again.
    pub fn restart(&mut self) {
        self.evicting = 0;
    }

    /// Whether another call is needed: frames not read back yet, a read-back under way, bricks
    /// loading, or bricks that just arrived (the views draw again and may ask for more).
    pub fn busy(&self) -> bool {
        self.unread || self.last.is_some_and(|p| p.reading || p.residency.pending > 0 || p.arrived > 0)
    }

    /// Notes the outcome of a call, given the residency just before it. Returns whether the
    /// pictures are out of date: bricks were placed or found to hold one value (a refused or
    /// unreadable brick changes nothing, and redrawing for it would only ask for it again),
    /// unless placing them has evicted others for too many rounds.
    pub fn note(&mut self, before: Residency, progress: BrickProgress) -> bool {
        // A call that found no read-back under way started one after every frame drawn so far:
        // those are covered (while it is under way, `reading` keeps the loop busy). A call that
        // only finished an older one leaves the frames drawn since for the next call.
        if !self.last.is_some_and(|p| p.reading) {
            self.unread = false;
        }
        self.last = Some(progress);
        let after = progress.residency;
        let placed = after.loaded > before.loaded || after.constant > before.constant;
        if placed && after.evicted > before.evicted {
            self.evicting += 1;
        }
        placed && self.evicting <= MAX_EVICTING_ROUNDS
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bricks_that_keep_evicting_each_other_stop_redrawing_until_the_next_change() {
        let mut s = Streaming::default();
        let round = |s: &mut Streaming, n: u64| {
            let before = Residency { loaded: n, evicted: n, ..Residency::default() };
            let after = Residency { loaded: n + 1, evicted: n + 1, ..Residency::default() };
            s.note(before, BrickProgress { residency: after, arrived: 1, ..BrickProgress::default() })
        };
        let redrawn = (0..200).filter(|&n| round(&mut s, n)).count();
        assert_eq!(redrawn, MAX_EVICTING_ROUNDS as usize);
        s.restart();
        assert!(round(&mut s, 200), "a change redraws with new bricks again");
    }

    fn progress(reading: bool, pending: u32, loaded: u64, arrived: usize) -> BrickProgress {
        let residency = Residency { pending, loaded, ..Residency::default() };
        BrickProgress { residency, arrived, asked: 0, reading }
    }

    #[test]
    fn a_drawn_frame_keeps_streaming_until_a_read_back_started_after_it_finishes() {
        let mut s = Streaming::default();
        assert!(!s.busy(), "nothing drawn, nothing to read");
        s.drawn();
        // The first call starts a read-back that is still under way.
        s.note(Residency::default(), progress(true, 0, 0, 0));
        assert!(s.busy());
        // The next finishes it: the frame was covered.
        s.note(Residency::default(), progress(false, 0, 0, 0));
        assert!(!s.busy());
    }

    #[test]
    fn a_frame_drawn_while_an_older_read_back_was_under_way_needs_a_new_one() {
        let mut s = Streaming::default();
        s.drawn();
        s.note(Residency::default(), progress(true, 0, 0, 0));
        s.drawn();
        // This call only finished the older read-back (copied before the second frame).
        s.note(Residency::default(), progress(false, 0, 0, 0));
        assert!(s.busy(), "the second frame's requests were never read");
        s.note(Residency::default(), progress(false, 0, 0, 0));
        assert!(!s.busy());
    }

    #[test]
    fn loading_bricks_keep_streaming_and_placed_ones_change_the_pictures() {
        let mut s = Streaming::default();
        s.drawn();
        assert!(!s.note(Residency::default(), progress(false, 3, 0, 0)));
        assert!(s.busy(), "bricks loading");
        let before = Residency { loaded: 0, ..Residency::default() };
        assert!(s.note(before, progress(false, 0, 3, 3)), "three bricks placed");
        assert!(s.busy(), "the views draw again with them");
        let before = Residency { loaded: 3, ..Residency::default() };
        assert!(!s.note(before, progress(false, 0, 3, 1)), "a refused brick changes nothing");
        assert!(s.busy());
        assert!(!s.note(before, progress(false, 0, 3, 0)));
        assert!(!s.busy());
    }
}
