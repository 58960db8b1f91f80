#!/usr/bin/env bash
# `rtgi view` opens a window; its tests run it under Xvfb (a virtual X server) with the libraries winit
# loads at run time. This installs them on Debian/Ubuntu when it can; otherwise it says what to install
# (the window tests are then skipped, except in CI, where they fail).
set -euo pipefail

INSTALL_PACKAGES=(xvfb xauth libxkbcommon-x11-0 libxcursor1 libxrandr2 libxi6 libx11-xcb1)

if command -v xvfb-run >/dev/null && command -v xauth >/dev/null \
    && ldconfig -p 2>/dev/null | grep 'libxkbcommon-x11\.so\.0' >/dev/null; then
    exit 0
fi

if [ "$(id -u)" -ne 0 ]; then
    echo "warning: no Xvfb; the \`rtgi view\` window tests will be skipped. Install with:" >&2
    echo "  sudo apt-get install -y ${INSTALL_PACKAGES[*]}" >&2
    exit 0
fi

echo "Installing a virtual X server for the viewer's tests (${INSTALL_PACKAGES[*]})..." >&2
apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${INSTALL_PACKAGES[@]}"
