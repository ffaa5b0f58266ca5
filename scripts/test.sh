#!/usr/bin/env bash
# The whole test suite, from a fresh Debian machine with only Rust installed.
#
#   scripts/test.sh
#
# Installs what the suite needs when it is missing (Mesa lavapipe, the software Vulkan driver the GPU
# tests render with; Xvfb and the X libraries winit loads, for the viewer's test; node and the
# Khronos glTF Validator, into tools/npm; Ray from PyPI, into tools/venv; cargo-fuzz), then
# checks formatting and lints, runs every test, and fuzzes each input reader briefly. Set
# VUNIFY_MODELS to a folder of the real test models (the README lists them) to include the tests on
# them; CI does. FUZZ_SECONDS (default 30) sets the fuzzing time per reader; 0 skips it.
set -euo pipefail
cd "$(dirname "$0")/.."

source scripts/deps.sh
# /dev/null must be the device: a program that once renamed a file over it (as root) leaves a
# regular file that collects every discarded output, and rustc then reads that garbage as source
# when cargo probes it. Put the device back (root), or say what is wrong.
if [ ! -c /dev/null ]; then
  if [ "$(id -u)" = 0 ]; then
    echo "scripts/test.sh: /dev/null is not a device (something replaced it); restoring it" >&2
    rm -f /dev/null && mknod -m 666 /dev/null c 1 3
  else
    echo "scripts/test.sh: /dev/null is not a device; ask an administrator to restore it" >&2
    exit 1
  fi
fi
ensure_packages "${BUILD_PACKAGES[@]}" "${VULKAN_PACKAGES[@]}" "${X11_PACKAGES[@]}" xvfb
# The Khronos glTF Validator (npm), which the tests run on every glTF file vunify writes.
command -v npm >/dev/null || ensure_packages nodejs npm
if [ ! -d tools/npm/node_modules/gltf-validator ]; then
  npm install --prefix tools/npm --no-audit --no-fund --loglevel=error gltf-validator@2.0.0-dev.3.10
fi
# meshoptimizer's glTF tool: the tests read the quantized files it writes (and the bench compares).
if [ ! -d tools/npm/node_modules/gltfpack ]; then
  npm install --prefix tools/npm --no-audit --no-fund --loglevel=error gltfpack@1.3.0
fi

# Ray (PyPI), which the distributed build's driver (scripts/ray_build.py) runs on; its test starts
# a local Ray instance. In a virtual environment, so the system's Python stays as it is.
command -v python3 >/dev/null || ensure_packages python3
python3 -c "import venv, ensurepip" 2>/dev/null || ensure_packages python3-venv
if ! tools/venv/bin/python -c "import ray" 2>/dev/null; then
  python3 -m venv tools/venv
  tools/venv/bin/pip install --quiet --disable-pip-version-check "ray==2.*"
fi
export VUNIFY_PYTHON="$PWD/tools/venv/bin/python"

if [ -n "${VUNIFY_MODELS:-}" ]; then
  echo "scripts/test.sh: real models from VUNIFY_MODELS=$VUNIFY_MODELS"
else
  echo "scripts/test.sh: VUNIFY_MODELS is not set; the tests on real models will say so and pass"
fi

# wgpu prints a warning on every instance without a runtime directory (harmless; TOOLCHAIN.md).
if [ -z "${XDG_RUNTIME_DIR:-}" ] || [ ! -d "${XDG_RUNTIME_DIR}" ]; then
  export XDG_RUNTIME_DIR="$(mktemp -d)"
  chmod 700 "$XDG_RUNTIME_DIR"
fi

# The house style and the lints (Cargo.toml's [lints]), held by CI.
cargo fmt --check
cargo clippy --locked --all-targets --all-features -- -D warnings
# The algorithms (builder, runtime) build with no GPU crate at all, and the CLI without the renderer.
cargo check --lib --no-default-features --locked
cargo check --lib --bins --no-default-features --features cli --locked
cargo check --benches --examples --all-features --locked   # must keep compiling; they run with `cargo bench` / `cargo run --example`
log=$(mktemp)
trap 'rm -f "$log"' EXIT
cargo test --doc --locked 2>&1 | tee "$log"
cargo test --lib --bins --tests --locked --no-fail-fast 2>&1 | tee -a "$log"
# The runtime's benchmark on the dragon, a short run: its numbers are printed, not asserted
# (BENCHMARKS.md has the full runs); without a GPU crate, so it builds quickly.
if [ -n "${VUNIFY_MODELS:-}" ]; then
  cargo bench --locked --no-default-features --features trace --bench refine -- --models dragon --frames 60
fi
# Each input reader fuzzed for a short while (scripts/fuzz.sh; longer runs are for development).
if [ "${FUZZ_SECONDS:-30}" != 0 ]; then
  scripts/fuzz.sh "${FUZZ_SECONDS:-30}"
fi
# One closing line over every test binary above.
awk '/^test result:/ { for (i = 1; i <= NF; i++) { if ($i ~ /^passed/) p += $(i-1); if ($i ~ /^failed/) f += $(i-1) } }
     END { printf "%d passed, %d failed\n", p, f }' "$log"
