//! Viewer-script JSON on arbitrary bytes: a script or a clear error.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;
use vunify::script::Script;

fuzz_target!(|data: &[u8]| {
    let _ = Script::parse(data, Path::new("fuzz.json"));
});
