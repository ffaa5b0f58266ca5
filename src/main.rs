//! The `vunify` command line (its commands are in `cli/`).

mod cli;
#[cfg(target_os = "linux")]
mod huge_pages;

/// jemalloc, its large blocks on huge pages (`huge_pages`). Huge pages alone: 6–8 % off `vunify build`'s wall time on the dragon (medians of
/// eight alternating runs), the same peak memory.
#[cfg(target_os = "linux")]
#[global_allocator]
static ALLOCATOR: huge_pages::HugePages = huge_pages::HugePages;

fn main() {
    // Rust ignores SIGPIPE, so writing to a closed pipe (`vunify info F | head`) would panic in
    // `println!`; a command-line tool should end quietly instead, as `cat` does.
    #[cfg(unix)]
    // SAFETY: called first thing, before any thread exists; SIG_DFL is a valid action for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    if let Err(e) = cli::run() {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
