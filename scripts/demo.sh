#!/usr/bin/env bash
# Renders the Cornell box to out.png (in the repository root). Extra arguments go to `rtgi render` and
# override the defaults below, e.g. `./scripts/demo.sh --size 256x256 --out cornell.exr`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/ensure-vulkan.sh
exec cargo run --release -p rtgi-cli -- render --scene cornell --technique direct --size 512x512 --frames 16 --out out.png "$@"
