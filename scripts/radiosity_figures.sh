#!/usr/bin/env bash
# Redraws the radiosity pictures in docs/ (docs/RADIOSITY.md) from lit meshes:
#
#   scripts/radiosity_figures.sh LIT_DIR
#
# LIT_DIR holds room.ply, office.ply and cornell.ply from `vunify radiosity assets/scenes/S.obj`.
# Superfaces at the paper's settings are written beside them. The curves (Figs. 8-11) come from
# `cargo bench --bench superfaces -- --lit ...`, the viewer's picture from a screenshot.
set -euo pipefail
lit=${1:?usage: scripts/radiosity_figures.sh LIT_DIR}
cd "$(dirname "$0")/.."
vunify=target/release/vunify
[[ -x $vunify ]] || cargo build --release --locked
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# draw MESH CAMERA SIZE OUT [--wireframe]
draw() {
    local mesh=$1 camera=$2 size=$3 out=$4
    shift 4
    "$vunify" render "$mesh" --full --color-by baked --path "$camera" --size "$size" \
        --out "$tmp/frames" "$@" > /dev/null
    cp "$tmp/frames/frame_00000.png" "$out"
    echo "drew       $out"
}

simplify() {
    local scene=$1 epsilon=$2 delta=$3
    "$vunify" superfaces "$lit/$scene.ply" --epsilon "$epsilon" --delta "$delta" \
        -o "$lit/$scene-$epsilon-$delta.ply"
}

simplify room 0.1 2
simplify room 0.8 50
simplify office 0.06 1
simplify office 0.8 4

draw "$lit/cornell.ply" docs/radiosity/cornell-camera.json 400x400 docs/radiosity-cornell.png
draw "$lit/room.ply" docs/radiosity/room-camera.json 640x480 docs/radiosity-room.png
draw "$lit/room-0.1-2.ply" docs/radiosity/room-camera.json 640x480 docs/radiosity-room-superfaces.png --wireframe
for scene in room office; do
    draw "$lit/$scene.ply" "docs/radiosity/$scene-camera.json" 480x360 "docs/radiosity/$scene-full.png"
done
for s in room-0.1-2 room-0.8-50 office-0.06-1 office-0.8-4; do
    draw "$lit/$s.ply" "docs/radiosity/${s%%-*}-camera.json" 480x360 "docs/radiosity/$s-wire.png" --wireframe
done
for s in room-0.8-50 office-0.8-4; do
    draw "$lit/$s.ply" "docs/radiosity/${s%%-*}-camera.json" 480x360 "docs/radiosity/$s.png"
done
