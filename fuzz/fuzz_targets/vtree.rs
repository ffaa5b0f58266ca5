//! The .vtree reader on arbitrary bytes: a tree that passes `check` (the reader runs it) or a clear
//! error; an accepted tree also survives the full replay check and a runtime front over it. The
//! page-by-page reader (`PagedFile`, what `vunify path` and `info` use) on the same bytes: an
//! answer or a clear error.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;
use vunify::vtree;

fuzz_target!(|data: &[u8]| {
    if let Ok(tree) = vtree::read_bytes(data, Path::new("fuzz.vtree")) {
        vtree::check(&tree).expect("the reader checks what it returns");
        let _ = vtree::check_cut(&tree);
    }
    let path = std::env::temp_dir().join(format!("vunify-fuzz-{}.vtree", std::process::id()));
    if std::fs::write(&path, data).is_ok()
        && let Ok(file) = vtree::PagedFile::open(&path)
    {
        let _ = file.survey();
    }
});
