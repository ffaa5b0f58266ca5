//! Holding a frame rate: τ raised while frames take longer than the target, and let back down to the
//! user's τ once they are fast again (Hoppe, *View-dependent refinement of progressive meshes*,
//! SIGGRAPH 97, §4 regulates τ the same way to keep a constant number of faces; here the measure is
//! the frame time itself, which is what the user feels).
//!
//! The drawn triangles of a surface grow about as 1/τ², and a software rasteriser's frame time about
//! as the triangles, so the frame time goes about as 1/τ²: a step of √(frame time / target) in τ
//! would reach the target in one frame. The frame time weighed is the median of the last
//! [`WINDOW`] frames, so that one slow frame (a model loading, the machine busy for a moment) moves
//! nothing; steps are capped at 10 % a frame; and the band between 90 and 100 % of the target moves
//! nothing, so the scale does not hunt around it.

/// Frames whose median the hold weighs.
const WINDOW: usize = 9;
/// The scale on τ moves at most by this factor a frame.
const STEP: f32 = 1.1;
/// Frames faster than this share of the target let τ back down. Close enough to 1 that frames
/// whose time is mostly filling pixels (a close-up, where fewer triangles save little) still bring
/// τ back down until they near the target.
const LOW: f64 = 0.9;
/// τ is never raised beyond this many times the user's: past it, frames that are still slow are
/// slow for another reason than the triangles (the window's size, the machine).
const MAX_SCALE: f32 = 8.0;
/// Nor while a frame draws fewer triangles than this: lavapipe, the slowest renderer vunify runs
/// on, draws the dragon's 20,000–30,000 at 1280 × 720 in 25–35 ms, inside a 25 fps frame, so a slower
/// frame with fewer triangles is slow for another reason (the machine busy with other work), which
/// coarser models would not cure. Measured: with a compile running beside the viewer, the dragon's
/// frames stayed at ~70 ms while a hold without this floor took it from 30,000 triangles down to
/// 7,500 (τ 8 px), visibly faceted.
const MIN_TRIANGLES: u32 = 30_000;

/// The state of the hold: the last frames' times and how far τ is raised now.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hold {
    scale: f32,
    recent: [f64; WINDOW],
    /// Frames recorded in `recent`, up to `WINDOW`; the next goes to `frames % WINDOW`.
    frames: usize,
}

impl Default for Hold {
    fn default() -> Self {
        Hold {
            scale: 1.0,
            recent: [0.0; WINDOW],
            frames: 0,
        }
    }
}

impl Hold {
    /// The factor on τ for the next frame, after a frame that took `frame_ms` to draw `triangles`,
    /// holding `target_fps` (0: no hold, the factor is 1).
    pub fn next(&mut self, frame_ms: f64, triangles: u32, target_fps: f32) -> f32 {
        if !(target_fps > 0.0 && frame_ms > 0.0 && frame_ms.is_finite()) {
            *self = Hold::default();
            return 1.0;
        }
        self.recent[self.frames % WINDOW] = frame_ms;
        self.frames += 1;
        if self.frames < WINDOW {
            return self.scale;
        }
        let mut recent = self.recent;
        recent.sort_by(f64::total_cmp);
        let typical = recent[WINDOW / 2];
        let ratio = typical * target_fps as f64 / 1000.0;
        let raise = ratio > 1.0 && triangles > MIN_TRIANGLES;
        if raise || ratio < LOW {
            let step = (ratio.sqrt() as f32).clamp(1.0 / STEP, STEP);
            self.scale = (self.scale * step).clamp(1.0, MAX_SCALE);
        }
        self.scale
    }

    /// The factor on τ now.
    pub fn scale(&self) -> f32 {
        self.scale
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame's triangles when they are not what the test is about: enough to be worth cutting.
    const BUSY: u32 = 200_000;

    #[test]
    fn raises_tau_on_slow_frames_and_lets_it_back_down() {
        let mut h = Hold::default();
        // Frames at twice the target's length: nothing until a window of them is seen, then 10 %
        // a frame, and no further than the cap.
        for _ in 1..WINDOW {
            assert_eq!(h.next(80.0, BUSY, 25.0), 1.0);
        }
        assert!((h.next(80.0, BUSY, 25.0) - 1.1).abs() < 1e-6);
        assert!((h.next(80.0, BUSY, 25.0) - 1.21).abs() < 1e-5);
        for _ in 0..100 {
            h.next(80.0, BUSY, 25.0);
        }
        assert_eq!(h.scale(), MAX_SCALE);
        // Fast frames bring it down, once they are the median, to the user's τ and no lower.
        for _ in 0..WINDOW / 2 {
            assert_eq!(h.next(10.0, BUSY, 25.0), MAX_SCALE);
        }
        let mut last = MAX_SCALE;
        for _ in 0..100 {
            let s = h.next(10.0, BUSY, 25.0);
            assert!(s <= last);
            last = s;
        }
        assert_eq!(h.scale(), 1.0);
        // Within the band (36 to 40 ms for 25 fps) nothing moves.
        for _ in 0..WINDOW {
            assert_eq!(h.next(37.0, BUSY, 25.0), 1.0);
        }
        // No target: τ as the user set it.
        assert_eq!(h.next(500.0, BUSY, 0.0), 1.0);
        assert_eq!(h.next(f64::NAN, BUSY, 25.0), 1.0);
    }

    #[test]
    fn few_triangles_are_never_cut_further() {
        let mut h = Hold::default();
        // Slow frames of few triangles: the machine is busy, not the renderer.
        for _ in 0..50 {
            assert_eq!(h.next(90.0, MIN_TRIANGLES, 25.0), 1.0);
        }
        // Raised while there were many, it stays where it is once they are few, and comes down
        // when frames are fast.
        for _ in 0..50 {
            h.next(90.0, BUSY, 25.0);
        }
        let high = h.scale();
        assert!(high > 1.0);
        assert_eq!(h.next(90.0, 1000, 25.0), high);
        for _ in 0..100 {
            h.next(10.0, 1000, 25.0);
        }
        assert_eq!(h.scale(), 1.0);
    }

    #[test]
    fn single_slow_frames_move_nothing() {
        let mut h = Hold::default();
        for i in 0..200 {
            // Every third frame takes three times the target; the others are within the band.
            let ms = if i % 3 == 0 { 120.0 } else { 38.0 };
            assert_eq!(h.next(ms, BUSY, 25.0), 1.0, "frame {i}");
        }
        // A small, steady overshoot takes a small step: √1.05.
        let mut h = Hold::default();
        for _ in 1..WINDOW {
            h.next(42.0, BUSY, 25.0);
        }
        assert!((h.next(42.0, BUSY, 25.0) - 1.05f32.sqrt()).abs() < 1e-5);
    }
}
