//! The glTF reader on arbitrary bytes (JSON or GLB): a mesh or a clear error, never a panic, hang
//! or huge allocation. Called without `mesh::parse`'s last-resort `catch_unwind`, so that a panic
//! is a finding. A mesh it returns passes the structural check, and cleaning it keeps it valid.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;
use vunify::mesh::{self, CleanOptions};

fuzz_target!(init: {
    // libFuzzer's hook aborts at any panic, before `catch_unwind` can see it; the reader catches
    // the `gltf` crate's own panics as errors, so the default hook is put back. A panic that
    // leaves the reader still aborts the run (the harness's `catch_unwind` does that).
    let _ = std::panic::take_hook();
}, |data: &[u8]| {
    if let Ok(read) = mesh::gltf::parse(data, Path::new("fuzz/no-such-dir/fuzz.glb")) {
        read.mesh.check().expect("a parsed mesh is valid");
        let (m, _) = mesh::clean(read.mesh, &CleanOptions::default());
        m.check().expect("a cleaned mesh is valid");
    }
});
