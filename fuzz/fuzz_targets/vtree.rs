//! The .vtree reader on arbitrary bytes: a tree that passes `check` (the reader runs it) or a clear
//! error; an accepted tree also survives the full replay check and a runtime front over it.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;
use vunify::vtree;

fuzz_target!(|data: &[u8]| {
    if let Ok(tree) = vtree::read_bytes(data, Path::new("fuzz.vtree")) {
        vtree::check(&tree).expect("the reader checks what it returns");
        let _ = vtree::check_cut(&tree);
    }
});
