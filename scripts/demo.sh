#!/usr/bin/env bash
# Renders a global-illumination technique next to the path-traced reference into one labelled PNG,
# out.png in the repository root (about a minute on lavapipe, less on a GPU; the reference is cached).
#
#     ./scripts/demo.sh [SCENE] [TECHNIQUE]      # defaults: cornell ddgi
#
# `rtgi list` names the scenes and techniques. The images themselves stay in target/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/ensure-vulkan.sh
scene="${1:-cornell}"
technique="${2:-ddgi}"
size=256x256
spp=128
cargo build --release -p rtgi-cli
rtgi="${CARGO_TARGET_DIR:-target}/release/rtgi"
mkdir -p target/demo
# 64 frames of one still: progressive techniques average them, temporal ones (ddgi's probes) converge.
"$rtgi" render --scene "$scene" --technique "$technique" --size "$size" --frames 64 \
    --out "target/demo/$technique.exr" --stats "target/demo/$technique.json"
"$rtgi" reference --scene "$scene" --size "$size" --spp "$spp" --out target/demo/reference.exr
flip=$("$rtgi" compare target/demo/reference.exr "target/demo/$technique.exr" | sed -n 's/.*flip \([0-9.]*\).*/\1/p' | xargs printf "%.3f")
# GPU time per frame, where the adapter has timestamps.
ms=$(python3 -c 'import json, sys
g = json.load(open(sys.argv[1])).get("frame_gpu") or {}
m = g.get("mean_ms")
print("" if m is None else "%.1f" % m)' "target/demo/$technique.json")
"$rtgi" montage target/demo/reference.exr "target/demo/$technique.exr" \
    --label "$scene: path tracer, $spp spp (reference)" \
    --label "$technique: FLIP $flip against the reference${ms:+, $ms ms per frame}" \
    --out out.png
echo "wrote out.png: $scene, $technique (FLIP $flip) beside the path-traced reference"
