//! Camera-path JSON on arbitrary bytes: a path whose every sample is a finite camera, or a clear
//! error.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;
use vunify::camera_path::CameraPath;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(path) = CameraPath::parse(text, Path::new("fuzz.json")) {
        for i in 0..=8 {
            let t = path.duration() * i as f32 / 8.0;
            let (position, orientation, fov) = path.sample(t);
            assert!(position.is_finite() && orientation.is_finite() && fov.is_finite());
        }
    }
});
