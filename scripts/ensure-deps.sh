#!/usr/bin/env bash
# Installs what a fresh Debian machine with only Rust lacks to build, test and
# run gibake: a Vulkan loader and, when no GPU driver is present, Mesa's
# lavapipe software GPU (mesa-vulkan-drivers). With --node, also Node.js and
# npm for the Khronos glTF validator used by the tests. With --slurm, also
# slurm-wlm and munge for the one-node Slurm cluster of tests/pipeline_slurm.rs
# (scripts/slurm/ci-cluster.sh).
set -euo pipefail

want_node=0
want_slurm=0
for arg in "$@"; do
  case "$arg" in
    --node) want_node=1 ;;
    --slurm) want_slurm=1 ;;
    *) echo "ensure-deps: unknown option $arg (known: --node --slurm)" >&2; exit 2 ;;
  esac
done

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "ensure-deps: not root and no sudo; install mesa-vulkan-drivers (and nodejs npm, slurm-wlm munge) yourself" >&2
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
if [ "$want_slurm" = 1 ] && ! { command -v slurmctld >/dev/null 2>&1 && command -v slurmd >/dev/null 2>&1 && command -v sbatch >/dev/null 2>&1 && command -v munged >/dev/null 2>&1; }; then
  pkgs+=(slurm-wlm munge)
fi
if [ ${#pkgs[@]} -gt 0 ]; then
  echo "ensure-deps: installing ${pkgs[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq "${pkgs[@]}" >/dev/null
fi
