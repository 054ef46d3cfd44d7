#!/bin/sh
# Set-up for the README's two commands on a bare Debian or Ubuntu machine: the system packages
# es2particles needs (Python's venv, Mesa's EGL driver: llvmpipe renders on the CPU; libGLESv2 for
# --backend gles), then a
# virtual environment .venv with es2particles installed from this folder.
#
#   sh setup.sh          the program
#   sh setup.sh test     also the test extra and what the tests drive: the Khronos GLSL
#                        reference compiler, Arm's ASTC encoder, Chromium, and an X screen
#                        (Xvfb, xdotool, Mesa's GLX) for the live window
#
# Packages already installed are left alone and recommended ones are not installed (the few a
# test needs are named: the X screen's fonts, a font for Chromium); apt-get runs through sudo
# unless run as root.
# Elsewhere than Debian or Ubuntu it says which packages it would have installed, and goes on.
set -eu
cd "$(dirname "$0")"

packages="python3-venv python3-pip libegl1 libgl1-mesa-dri libegl-mesa0 libgles2"
extra=""
if [ "${1:-}" = "test" ]; then
  packages="$packages glslang-tools astcenc chromium fonts-liberation xvfb xfonts-base xauth"
  packages="$packages xdotool libglx-mesa0"
  extra="[test]"
fi

missing=""
if command -v dpkg >/dev/null 2>&1; then
  for pkg in $packages; do
    dpkg -s "$pkg" >/dev/null 2>&1 || missing="$missing $pkg"
  done
fi
if [ -n "$missing" ]; then
  if command -v apt-get >/dev/null 2>&1; then
    sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    echo "setup.sh: installing$missing"
    $sudo apt-get update -qq
    # Only the packages named and what they depend on: no recommends (Chromium's recommends alone
    # were ~130 packages, among them a systemd upgrade), and no upgrade of anything installed.
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
      --no-upgrade $missing
  else
    echo "setup.sh: no apt-get here; install the equivalents of:$missing" >&2
  fi
elif ! command -v dpkg >/dev/null 2>&1; then
  echo "setup.sh: not Debian or Ubuntu; it needs the equivalents of: $packages" >&2
fi

[ -x .venv/bin/python ] || python3 -m venv .venv
.venv/bin/python -m pip install -q ".$extra"
echo "setup.sh: ready (.venv)"
