//! vunify: view-dependent level of detail for triangle meshes.
//!
//! The crate reads as a pipeline, each module depending only on those before it:
//! [`mesh`] (input, welding) → [`simplify`] (quadrics, pairs, the merge operation) → [`vtree`] (the
//! binary vertex tree of Tao et al.: its builder, file format and static extraction) → [`measure`]
//! (Hausdorff distance). None of these touch a GPU.

#[cfg(feature = "viewer")]
pub mod app;
pub mod camera_path;
pub mod color;
pub mod display;
pub mod export;
#[doc(hidden)]
pub mod fixtures;
pub mod generate;
pub mod measure;
pub mod memory;
pub mod mesh;
pub mod radiosity;
pub mod refine;
#[cfg(feature = "render")]
pub mod render;
pub mod script;
pub mod simplify;
pub mod vtree;

/// A hint that `x` will be read soon: a prefetch into all cache levels where the target has one,
/// nothing elsewhere. Loops over scattered data (the builder's merges) issue it a few iterations
/// ahead so that the loads overlap instead of queueing one after another.
#[inline(always)]
pub(crate) fn prefetch<T>(x: &T) {
    prefetch_address(x as *const T as usize);
}

/// [`prefetch`] of an address (which need not be valid: a prefetch never faults).
#[inline(always)]
pub(crate) fn prefetch_address(address: usize) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: prefetching is a hint with no architectural effect; any address is allowed.
    unsafe {
        core::arch::x86_64::_mm_prefetch::<{ core::arch::x86_64::_MM_HINT_T0 }>(
            address as *const i8,
        );
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = address;
}
