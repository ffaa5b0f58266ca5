#!/usr/bin/env bash
# The main job, from a fresh Debian machine with only Rust installed:
#
#   scripts/run.sh [vunify arguments…]
#
# Installs the Vulkan driver (Mesa lavapipe) and the X11 libraries the window needs when they are
# missing, then runs vunify: with no arguments it builds the bundled water bottle's tree (textured glTF) and opens the viewer
# on it, or, with no display, says so and renders the default camera path headless to out/default-path/.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/deps.sh
ensure_packages "${BUILD_PACKAGES[@]}" "${VULKAN_PACKAGES[@]}" "${X11_PACKAGES[@]}"
# wgpu prints a warning on every instance without a runtime directory (harmless; TOOLCHAIN.md).
if [ -z "${XDG_RUNTIME_DIR:-}" ] || [ ! -d "${XDG_RUNTIME_DIR}" ]; then
  export XDG_RUNTIME_DIR="$(mktemp -d)"
  chmod 700 "$XDG_RUNTIME_DIR"
fi
exec cargo run --release --locked -- "$@"
