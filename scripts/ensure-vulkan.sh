#!/usr/bin/env bash
# rtgi renders through wgpu's Vulkan backend; on machines without a GPU, Mesa's lavapipe (a CPU Vulkan
# driver) stands in. This checks for a Vulkan loader plus at least one driver manifest (ICD) and installs
# both on Debian/Ubuntu when it can.
set -euo pipefail

INSTALL_PACKAGES=(mesa-vulkan-drivers libvulkan1)

have_vulkan() {
    local ldconfig
    ldconfig=$(command -v ldconfig || echo /sbin/ldconfig)
    # No `grep -q`: it would stop reading early, ldconfig would die of SIGPIPE and pipefail would turn a
    # found loader into a failure.
    "$ldconfig" -p 2>/dev/null | grep 'libvulkan\.so\.1' >/dev/null || return 1
    compgen -G '/usr/share/vulkan/icd.d/*.json' >/dev/null || compgen -G '/etc/vulkan/icd.d/*.json' >/dev/null
}

if have_vulkan; then
    exit 0
fi

if [ "$(id -u)" -ne 0 ]; then
    echo "error: no Vulkan loader or driver found; rtgi needs one (Mesa's lavapipe works without a GPU). Install with:" >&2
    echo "  sudo apt-get install -y ${INSTALL_PACKAGES[*]}" >&2
    exit 1
fi

echo "Installing a Vulkan loader and Mesa drivers (${INSTALL_PACKAGES[*]})..." >&2
apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${INSTALL_PACKAGES[@]}"

if ! have_vulkan; then
    echo "error: installed ${INSTALL_PACKAGES[*]} but still found no Vulkan loader and driver" >&2
    exit 1
fi
