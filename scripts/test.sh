#!/usr/bin/env bash
# Runs the whole test suite. Extra arguments go to `cargo test` (e.g. a test name filter).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/ensure-vulkan.sh
exec cargo test --release --workspace "$@"
