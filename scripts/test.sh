#!/usr/bin/env bash
# Runs the whole test suite. Extra arguments go to `cargo test` (e.g. a test name filter).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/ensure-vulkan.sh
bash scripts/ensure-xvfb.sh
# Mesa's device-select layer probes Wayland/X11 and prints noise on headless machines (see main.rs).
export NODEVICE_SELECT="${NODEVICE_SELECT:-1}"
exec cargo test --release --workspace "$@"
