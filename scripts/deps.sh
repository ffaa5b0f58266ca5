# Sourced by scripts/run.sh and scripts/test.sh: installs the Debian packages named as arguments when
# any is missing (with sudo when not root), quietly.
ensure_packages() {
  local need=() pkg sudo=""
  for pkg in "$@"; do
    dpkg -s "$pkg" >/dev/null 2>&1 || need+=("$pkg")
  done
  [ ${#need[@]} -eq 0 ] && return 0
  echo "vunify: installing ${need[*]}"
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${need[@]}" >/dev/null
}

# The software Vulkan driver (Mesa lavapipe) and the loader: vunify renders with any Vulkan device and
# these give one on a machine without a GPU.
VULKAN_PACKAGES=(mesa-vulkan-drivers libvulkan1)
# What winit loads at run time for an X11 window (no -dev packages are needed), and Xvfb for tests.
X11_PACKAGES=(libx11-xcb1 libxcursor1 libxrandr2 libxi6 libxkbcommon-x11-0)
# What compiles jemalloc, the command's allocator (tikv-jemalloc-sys runs its configure and make).
BUILD_PACKAGES=(gcc make)
