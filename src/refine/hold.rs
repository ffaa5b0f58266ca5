//! Holding a frame rate: τ raised while frames take longer than the target, and let back down to the
//! user's τ once they are fast again (Hoppe, *View-dependent refinement of progressive meshes*,
//! SIGGRAPH 97, §4 regulates τ the same way to keep a constant number of faces; here the measure is
//! the frame time itself, which is what the user feels).
//!
//! The drawn triangles of a surface grow about as 1/τ², and a software rasteriser's frame time about
//! as the triangles, so the frame time goes about as 1/τ²: a step of √(frame time / target) in τ
//! would reach the target in one frame. Steps are capped at 10 % a frame so that one slow frame (a
//! model loading, a window resize) does not throw the detail away, and the band between 90 and
//! 100 % of the target moves nothing, so the scale does not hunt around it.

/// The scale on τ moves at most by this factor a frame.
const STEP: f32 = 1.1;
/// Frames faster than this share of the target let τ back down. Close enough to 1 that frames
/// whose time is mostly filling pixels (a close-up, where fewer triangles save little) still bring
/// τ back down until they near the target.
const LOW: f64 = 0.9;
/// τ is never raised beyond this many times the user's.
const MAX_SCALE: f32 = 64.0;

/// The state of the hold: how far τ is raised now.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hold {
    scale: f32,
}

impl Default for Hold {
    fn default() -> Self {
        Hold { scale: 1.0 }
    }
}

impl Hold {
    /// The factor on τ for the next frame, after a frame that took `frame_ms`, holding `target_fps`
    /// (0: no hold, the factor is 1).
    pub fn next(&mut self, frame_ms: f64, target_fps: f32) -> f32 {
        if !(target_fps > 0.0 && frame_ms > 0.0 && frame_ms.is_finite()) {
            self.scale = 1.0;
            return 1.0;
        }
        let ratio = frame_ms * target_fps as f64 / 1000.0;
        if !(LOW..=1.0).contains(&ratio) {
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

    #[test]
    fn raises_tau_on_slow_frames_and_lets_it_back_down() {
        let mut h = Hold::default();
        // Frames at twice the target's length: 10 % a frame, and no further than the cap.
        assert!((h.next(80.0, 25.0) - 1.1).abs() < 1e-6);
        assert!((h.next(80.0, 25.0) - 1.21).abs() < 1e-5);
        for _ in 0..100 {
            h.next(80.0, 25.0);
        }
        assert_eq!(h.scale(), MAX_SCALE);
        // Within the band (36 to 40 ms for 25 fps) nothing moves.
        assert_eq!(h.next(37.0, 25.0), MAX_SCALE);
        // Fast frames bring it down, to the user's τ and no lower.
        let mut last = MAX_SCALE;
        for _ in 0..100 {
            let s = h.next(10.0, 25.0);
            assert!(s <= last);
            last = s;
        }
        assert_eq!(h.scale(), 1.0);
        // A small overshoot takes a small step: √1.05.
        assert!((h.next(42.0, 25.0) - 1.05f32.sqrt()).abs() < 1e-5);
        // No target: τ as the user set it.
        assert_eq!(h.next(500.0, 0.0), 1.0);
        assert_eq!(h.next(f64::NAN, 25.0), 1.0);
    }
}
