#!/usr/bin/env bash
# Installs what a fresh Debian machine with only Rust lacks to build, test and
# run gibake: a Vulkan loader and, when no GPU driver is present, Mesa's
# lavapipe software GPU (mesa-vulkan-drivers). With --node, also Node.js and
# npm for the Khronos glTF validator used by the tests.
set -euo pipefail

want_node=0
[ "${1:-}" = "--node" ] && want_node=1

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "ensure-deps: not root and no sudo; install mesa-vulkan-drivers (and nodejs npm) yourself" >&2
    exit 1
  fi
fi

pkgs=()
# A Vulkan driver: any ICD manifest counts (a real GPU's, or lavapipe's).
if ! ls /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json >/dev/null 2>&1; then
  pkgs+=(mesa-vulkan-drivers)
fi
if ! ldconfig -p 2>/dev/null | grep -q 'libvulkan\.so\.1'; then
  pkgs+=(libvulkan1)
fi
if [ "$want_node" = 1 ] && ! { command -v node >/dev/null 2>&1 && command -v npm >/dev/null 2>&1; }; then
  pkgs+=(nodejs npm)
fi
if [ ${#pkgs[@]} -gt 0 ]; then
  echo "ensure-deps: installing ${pkgs[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq "${pkgs[@]}" >/dev/null
fi
