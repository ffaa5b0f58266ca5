//! This process's memory as the kernel counts it: what `/usr/bin/time -v` reports as its maximum
//! resident set size, and what is resident now. Linux only (`/proc/self/status`); `None` elsewhere.

/// Bytes resident now (`VmRSS`).
pub fn resident_bytes() -> Option<u64> {
    status_kb("VmRSS:").map(|kb| kb * 1024)
}

/// The machine's physical memory (`MemTotal`).
pub fn physical_bytes() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemTotal:"))?;
    line.split_whitespace()
        .nth(1)?
        .parse::<u64>()
        .ok()
        .map(|kb| kb * 1024)
}

/// The most bytes resident so far (`VmHWM`, the high-water mark).
pub fn peak_resident_bytes() -> Option<u64> {
    status_kb("VmHWM:").map(|kb| kb * 1024)
}

/// With the `trace` feature (for the benchmarks), prints the memory resident now and at peak
/// after `phase`, to stderr: where a build's peak comes from. Nothing otherwise.
#[inline]
pub fn trace_phase(phase: &str) {
    #[cfg(feature = "trace")]
    eprintln!(
        "memory after {phase}: resident {} MiB, peak {} MiB",
        resident_bytes().unwrap_or(0) >> 20,
        peak_resident_bytes().unwrap_or(0) >> 20
    );
    #[cfg(not(feature = "trace"))]
    let _ = phase;
}

fn status_kb(key: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(key))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

#[cfg(test)]
mod tests {
    #[test]
    fn resident_memory_is_read_where_the_kernel_says_it() {
        if !std::path::Path::new("/proc/self/status").exists() {
            assert_eq!(super::resident_bytes(), None);
            return;
        }
        // Touching 64 MiB raises both: what is resident now and the peak, which never falls below it.
        let before = super::peak_resident_bytes().unwrap();
        let block = vec![1u8; 64 << 20];
        std::hint::black_box(&block);
        let now = super::resident_bytes().unwrap();
        let peak = super::peak_resident_bytes().unwrap();
        assert!(now >= 64 << 20, "{now}");
        assert!(peak >= now && peak >= before, "{peak} {now} {before}");
    }
}
