#!/usr/bin/env bash
# Installs what a fresh Debian machine with only Rust lacks to build, test and
# run gibake: a Vulkan loader and, when no GPU driver is present, Mesa's
# lavapipe software GPU (mesa-vulkan-drivers). With --node, also Node.js and
# npm for the Khronos glTF validator used by the tests. With --slurm, also
# slurm-wlm and munge for the one-node Slurm cluster of tests/pipeline_slurm.rs
# (scripts/slurm/ci-cluster.sh). With --python, also python3 and python3-venv
# and a virtual environment at target/pyenv (or $CARGO_TARGET_DIR/pyenv) with
# numpy, OpenEXR and blake3 for the spec reader (tools/spec_reader,
# tests/spec_reader.rs); Debian's own pip is externally managed, hence the
# venv. With --deny, also cargo-deny (cargo install --locked --debug) for
# the dependency check of .ci/run: its release profile is fat LTO with one
# codegen unit, 3 min 36 s to build on the 2-core CI machine against 1 min
# 27 s unoptimised, and the unoptimised checks take 8 s instead of 2. With --faults, also strace (fault injection
# in tests/faults.rs; unshare comes with util-linux). With --xvfb, also Xvfb
# (a virtual X server for tests/view.rs, which opens `gibake view`'s window)
# and the X11 libraries winit loads at run time (libX11, libX11-xcb,
# libXcursor, libXrandr, libXi, libxkbcommon-x11); lavapipe's X11 WSI comes
# with mesa-vulkan-drivers. Every step is skipped when already done.
set -euo pipefail
cd "$(dirname "$0")/.."

want_node=0
want_slurm=0
want_python=0
want_deny=0
want_faults=0
want_xvfb=0
for arg in "$@"; do
  case "$arg" in
    --node) want_node=1 ;;
    --slurm) want_slurm=1 ;;
    --python) want_python=1 ;;
    --deny) want_deny=1 ;;
    --faults) want_faults=1 ;;
    --xvfb) want_xvfb=1 ;;
    *) echo "ensure-deps: unknown option $arg (known: --node --slurm --python --deny --faults --xvfb)" >&2; exit 2 ;;
  esac
done

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "ensure-deps: not root and no sudo; install mesa-vulkan-drivers (and nodejs npm, slurm-wlm munge, python3 python3-venv) yourself" >&2
    exit 1
  fi
fi

pkgs=()
# A Vulkan driver: any ICD manifest counts (a real GPU's, or lavapipe's).
# (`ls a/*.json b/*.json` fails when either directory has none, so test each.)
if ! compgen -G '/usr/share/vulkan/icd.d/*.json' >/dev/null && ! compgen -G '/etc/vulkan/icd.d/*.json' >/dev/null; then
  pkgs+=(mesa-vulkan-drivers)
fi
if ! ldconfig -p 2>/dev/null | grep -q 'libvulkan\.so\.1'; then
  pkgs+=(libvulkan1)
fi
# A C++ compiler: nv-flip (mean FLIP in gibake-eval) builds NVIDIA's C++
# implementation with the cc crate.
if ! command -v c++ >/dev/null 2>&1; then
  pkgs+=(g++)
fi
if [ "$want_node" = 1 ] && ! { command -v node >/dev/null 2>&1 && command -v npm >/dev/null 2>&1; }; then
  pkgs+=(nodejs npm)
fi
if [ "$want_faults" = 1 ] && ! command -v strace >/dev/null 2>&1; then
  pkgs+=(strace)
fi
if [ "$want_faults" = 1 ] && ! command -v unshare >/dev/null 2>&1; then
  pkgs+=(util-linux)
fi
if [ "$want_xvfb" = 1 ]; then
  command -v Xvfb >/dev/null 2>&1 || pkgs+=(xvfb)
  # What winit dlopens on X11 (library file → Debian package).
  for lib in libX11.so.6:libx11-6 libX11-xcb.so.1:libx11-xcb1 libXcursor.so.1:libxcursor1 \
             libXrandr.so.2:libxrandr2 libXi.so.6:libxi6 libxkbcommon-x11.so.0:libxkbcommon-x11-0; do
    ldconfig -p 2>/dev/null | grep -q "${lib%%:*}" || pkgs+=("${lib#*:}")
  done
fi
if [ "$want_slurm" = 1 ] && ! { command -v slurmctld >/dev/null 2>&1 && command -v slurmd >/dev/null 2>&1 && command -v sbatch >/dev/null 2>&1 && command -v munged >/dev/null 2>&1; }; then
  pkgs+=(slurm-wlm munge)
fi
# The spec reader's venv; PIP_PACKAGES is what tools/spec_reader needs.
PYENV="${CARGO_TARGET_DIR:-target}/pyenv"
PIP_PACKAGES=("numpy>=1.24" "OpenEXR>=3.3,<4" "blake3>=0.4")
pyenv_ready() {
  [ -x "$PYENV/bin/python" ] && "$PYENV/bin/python" -c 'import numpy, OpenEXR, blake3' >/dev/null 2>&1
}
if [ "$want_python" = 1 ] && ! pyenv_ready; then
  if ! command -v python3 >/dev/null 2>&1; then
    pkgs+=(python3 python3-venv)
  elif ! python3 -c 'import ensurepip, venv' >/dev/null 2>&1; then
    pkgs+=(python3-venv)
  fi
fi
if [ ${#pkgs[@]} -gt 0 ]; then
  echo "ensure-deps: installing ${pkgs[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq "${pkgs[@]}" >/dev/null
fi

if [ "$want_python" = 1 ] && ! pyenv_ready; then
  echo "ensure-deps: creating $PYENV with ${PIP_PACKAGES[*]}" >&2
  rm -rf "$PYENV"
  python3 -m venv "$PYENV"
  "$PYENV/bin/python" -m pip install --quiet --disable-pip-version-check "${PIP_PACKAGES[@]}"
  pyenv_ready || { echo "ensure-deps: $PYENV cannot import numpy, OpenEXR, blake3" >&2; exit 1; }
fi
if [ "$want_deny" = 1 ] && ! cargo deny --version >/dev/null 2>&1; then
  echo "ensure-deps: installing cargo-deny (cargo install --locked --debug; a minute or two)" >&2
  cargo install cargo-deny --locked --debug
fi
