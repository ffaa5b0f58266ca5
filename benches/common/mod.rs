//! Shared by the benchmarks: `--name value` options and the model folder.
#![allow(dead_code)]

use std::path::PathBuf;

/// The value after `--name` on the command line, or `default`.
pub fn arg(name: &str, default: &str) -> String {
    let argv: Vec<String> = std::env::args().collect();
    argv.iter()
        .position(|a| a == name)
        .and_then(|i| argv.get(i + 1).cloned())
        .unwrap_or_else(|| default.to_string())
}

/// A model named on the command line (`dragon`, `bunny`, `cow`, or a file name) in `$VUNIFY_MODELS`
/// (required).
pub fn model_file(name: &str) -> PathBuf {
    let file = match name {
        "dragon" => "stanford-dragon.obj.xz".to_string(),
        "bunny" => "stanford-bunny.obj".to_string(),
        m if m.contains('.') => m.to_string(),
        m => format!("{m}.obj"),
    };
    models_dir().join(file)
}

pub fn models_dir() -> PathBuf {
    PathBuf::from(
        std::env::var_os("VUNIFY_MODELS")
            .expect("set VUNIFY_MODELS to the folder of the test models (see the README)"),
    )
}
