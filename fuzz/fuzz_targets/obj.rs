//! The obj reader on arbitrary bytes: a mesh or a clear error, never a panic, hang or huge
//! allocation. A mesh it returns passes the structural check, and cleaning it keeps it valid.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;
use vunify::mesh::{self, CleanOptions, Format};

fuzz_target!(|data: &[u8]| {
    if let Ok(m) = mesh::parse(data, Format::Obj, Path::new("fuzz.obj")) {
        m.check().expect("a parsed mesh is valid");
        let (m, _) = mesh::clean(m, &CleanOptions::default());
        m.check().expect("a cleaned mesh is valid");
    }
});
