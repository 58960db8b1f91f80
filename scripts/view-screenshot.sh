#!/usr/bin/env bash
# Writes docs/images/view.png, the README's picture of `rtgi view`: the Cornell box with `ddgi` (left of
# the split) against the progressive path-traced reference (right), under Xvfb on whatever adapter
# `render` picks. Needs xvfb-run (scripts/ensure-xvfb.sh). About six minutes on lavapipe (64 frames of both).
set -euo pipefail
cd "$(dirname "$0")/.."
RTGI=${RTGI:-target/release/rtgi}
[ -n "${RTGI_SKIP_BUILD:-}" ] || cargo build --release -p rtgi-cli
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cat > "$work/script.txt" <<'SCRIPT'
compare path
frames 64
window-screenshot view.png
quit
SCRIPT
mkdir -p docs/images
(cd "$work" && xvfb-run -a -s "-screen 0 1100x620x24" "$OLDPWD/$RTGI" view --scene cornell --technique ddgi \
    --size 960x540 --render-size 256x256 --script script.txt)
cp "$work/view.png" docs/images/view.png
echo "wrote docs/images/view.png"
