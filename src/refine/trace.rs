//! Timing of single operations, for the benchmarks: with the `trace` feature, each split and unify
//! is timed by the time-stamp counter between fences; without it, [`OpClock`] is empty and every
//! call compiles to nothing (the shipped binary has no `rdtsc` or `lfence`).

#[cfg(feature = "trace")]
pub use on::OpClock;

#[cfg(not(feature = "trace"))]
pub use off::OpClock;

#[cfg(not(feature = "trace"))]
mod off {
    /// Operation timing, switched off (build with the `trace` feature to switch it on).
    #[derive(Clone, Copy, Debug, Default)]
    pub struct OpClock {
        _off: (),
    }

    impl OpClock {
        #[inline(always)]
        pub fn start_frame(&mut self) {}
        #[inline(always)]
        pub fn start(&self) -> u64 {
            0
        }
        #[inline(always)]
        pub fn stop(&mut self, _: u64) {}
        /// Always 0.
        #[inline(always)]
        pub fn frame_seconds(&mut self, _: f64) -> f64 {
            0.0
        }
    }
}

#[cfg(feature = "trace")]
mod on {
    #[cfg(not(target_arch = "x86_64"))]
    use std::time::Instant;

    /// Time spent in operations over a frame, in time-stamp counter ticks.
    #[derive(Clone, Copy, Debug, Default)]
    pub struct OpClock {
        frame_start: u64,
        operations: u64,
        /// What an empty span measures this frame.
        overhead: u64,
    }

    impl OpClock {
        /// A new frame: counts from zero, and measures the empty span again.
        pub fn start_frame(&mut self) {
            self.frame_start = ticks();
            self.operations = 0;
            self.overhead = span_overhead();
        }

        /// The start of an operation's span.
        #[inline(always)]
        pub fn start(&self) -> u64 {
            span_start()
        }

        /// The end of the span from `t0`, counted as operation time.
        #[inline(always)]
        pub fn stop(&mut self, t0: u64) {
            let span = span_end().wrapping_sub(t0);
            self.operations += span.saturating_sub(self.overhead);
        }

        /// The frame's operation time in seconds, converting ticks at the rate the frame's ticks
        /// went against its clock (`frame_seconds`, measured by the caller).
        pub fn frame_seconds(&mut self, frame_seconds: f64) -> f64 {
            let frame_ticks = ticks().saturating_sub(self.frame_start).max(1);
            let ops = std::mem::take(&mut self.operations);
            ops as f64 * frame_seconds / frame_ticks as f64
        }
    }

    /// The time-stamp counter where there is one (about 10 ns a read here, where `Instant::now`
    /// takes about 23 ns, a tenth of an operation); nanoseconds elsewhere.
    #[inline(always)]
    fn ticks() -> u64 {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: reading the time-stamp counter has no preconditions.
        unsafe {
            core::arch::x86_64::_rdtsc()
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            static EPOCH: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
            EPOCH.get_or_init(Instant::now).elapsed().as_nanos() as u64
        }
    }

    /// The start of a timed span: [`ticks`] once everything before has finished, and before
    /// anything after starts (Intel's "How to Benchmark Code Execution Times on Intel IA-32 and
    /// IA-64", 2010, with `lfence`, which orders the counter read on both makers' processors, for
    /// `cpuid`). Unfenced, the counter drifts into the work around it; fenced, an operation is
    /// charged all of its own work and none of its overlap with the visits around it.
    #[inline(always)]
    fn span_start() -> u64 {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: fences and the time-stamp counter have no preconditions.
        unsafe {
            use core::arch::x86_64::{_mm_lfence, _rdtsc};
            _mm_lfence();
            let t = _rdtsc();
            _mm_lfence();
            t
        }
        #[cfg(not(target_arch = "x86_64"))]
        ticks()
    }

    /// The end of a timed span: [`ticks`] once everything in it has finished.
    #[inline(always)]
    fn span_end() -> u64 {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as for `span_start`.
        unsafe {
            use core::arch::x86_64::{_mm_lfence, _rdtsc};
            _mm_lfence();
            _rdtsc()
        }
        #[cfg(not(target_arch = "x86_64"))]
        ticks()
    }

    /// What an empty span measures, the least of a few: taken off each operation's span, so that an
    /// operation is charged its own work and not the fences' and the counter's.
    fn span_overhead() -> u64 {
        (0..16)
            .map(|_| {
                let t0 = span_start();
                span_end().wrapping_sub(t0)
            })
            .min()
            .unwrap_or(0)
    }
}
