#!/usr/bin/env bash
# One prepared run on a machine with an NVIDIA GPU (issue 47): sets up headless EGL, prints
# `es2particles info`, runs the GL tier's core tests and the figures (benchmarks/gpu_figures.py),
# writing RESULTS.md and results.json as it goes, then the whole suite but the browser's, within 7 minutes in all (the device
# tool lends 15 minutes a session, a machine's start included, so a failed run can be rerun).
#
#   bash benchmarks/gpu.sh                  on the GPU machine (bare, no network)
#   bash benchmarks/gpu.sh --dry-run        here, on llvmpipe, at small sizes (CI runs this)
#   bash benchmarks/gpu.sh --out DIR        where RESULTS.md and results.json go
#                                           (default benchmarks/)
#   bash benchmarks/gpu.sh --fetch-wheels   here, with network: moderngl and glcontext wheels
#                                           for the GPU machine's Python into .whl/ (ignored)
#
# The GPU machine has Python with numpy, pillow, pytest and scipy but not moderngl: carry .whl/
# (the device tool's carry list). Nothing else is installed there; the package runs from this
# checkout (PYTHONPATH), so no pip install of it is needed.
set -u
cd "$(dirname "$0")/.."
ROOT=$(pwd)
OUT="$ROOT/benchmarks"
DRY=""
FETCH=""
while [ $# -gt 0 ]; do
  case "$1" in
    --dry-run) DRY="--dry-run" ;;
    --fetch-wheels) FETCH=1 ;;
    --out) shift; OUT="${1:?--out needs a folder}" ;;
    *) echo "gpu.sh: unknown option $1 (--dry-run, --out DIR, --fetch-wheels)" >&2; exit 2 ;;
  esac
  shift
done

if [ -n "$FETCH" ]; then
  mkdir -p .whl
  for pkg in moderngl glcontext; do
    python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 \
      --implementation cp --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 \
      -d .whl "$pkg" || exit 1
  done
  ls .whl
  exit 0
fi

PY=python3
[ -x .venv/bin/python ] && [ -n "$DRY" ] && PY=.venv/bin/python
if ! $PY -c "import moderngl" 2>/dev/null; then
  if [ -d .whl ]; then
    $PY -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
      --target /tmp/site .whl/*.whl || exit 1
    export PYTHONPATH=/tmp/site${PYTHONPATH:+:$PYTHONPATH}
  else
    echo "gpu.sh: moderngl is missing and there is no .whl/ to install it from" \
         "(bash benchmarks/gpu.sh --fetch-wheels, then carry .whl)" >&2
    exit 1
  fi
fi
export PYTHONPATH="$ROOT${PYTHONPATH:+:$PYTHONPATH}"

# Headless EGL on NVIDIA's driver. A bare machine may lack GLVND's loaders (libEGL.so.1): carry
# .gl/ with their Debian packages (the device tool's README says how) and they are unpacked here.
# GLVND then needs the driver's vendor file, which a bare machine may have without saying so.
if [ -z "$DRY" ] && ls .gl/*.deb >/dev/null 2>&1; then
  for f in .gl/*.deb; do dpkg -x "$f" / || exit 1; done
  ldconfig
fi
if [ -z "$DRY" ] && [ -z "${__EGL_VENDOR_LIBRARY_FILENAMES:-}" ]; then
  for vendor in /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json \
                /usr/share/glvnd/egl_vendor.d/10_nvidia.json; do
    [ -f "$vendor" ] && export __EGL_VENDOR_LIBRARY_FILENAMES="$vendor" && break
  done
  if [ -z "${__EGL_VENDOR_LIBRARY_FILENAMES:-}" ]; then
    printf '{"file_format_version": "1.0.0", "ICD": {"library_path": "libEGL_nvidia.so.0"}}\n' \
      > /tmp/10_nvidia.json
    export __EGL_VENDOR_LIBRARY_FILENAMES=/tmp/10_nvidia.json
  fi
fi

mkdir -p "$OUT"
LOG="$OUT/gpu-run.log"
: > "$LOG"
start=$(date +%s)
say() { echo "$*" | tee -a "$LOG"; }
say "gpu.sh ${DRY:-(GPU run)} at $(date -u '+%Y-%m-%d %H:%M UTC'), commit $(git rev-parse --short HEAD 2>/dev/null)"
command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,driver_version,memory.total \
  --format=csv,noheader 2>&1 | tee -a "$LOG"

say "== es2particles info (gl)"
timeout 60 $PY -m es2particles info 2>&1 | tee -a "$LOG"
say "== es2particles info (gles)"
timeout 60 $PY -m es2particles info --backend gles 2>&1 | tee -a "$LOG"

say "== the GL tier's core tests"
TESTS="tests/test_packing.py tests/test_simulation.py tests/test_grids.py tests/test_wind.py"
TESTS="$TESTS tests/test_dejong.py tests/test_executor.py tests/test_gles.py tests/test_air3d.py"
# -p checkout_clean beside the emptied addopts: without it the tests wrote .hypothesis/ into the
# checkout (Hypothesis's home, which the plugin moves to a folder of the session's).
timeout $([ -n "$DRY" ] && echo 240 || echo 120) $PY -m pytest -q -p no:cacheprovider \
  -p checkout_clean -o addopts="" -m "gl and not slow" $TESTS 2>&1 | tail -25 | tee -a "$LOG"

say "== figures"
left=$(( $([ -n "$DRY" ] && echo 560 || echo 380) - ($(date +%s) - start) ))
timeout "$left" $PY benchmarks/gpu_figures.py --out "$OUT" $DRY 2>&1 | tee -a "$LOG"
code=${PIPESTATUS[0]}

# Where another driver behaves differently it shows in the tests, not the figures: the whole suite
# but the browser's, in parallel where pytest-xdist is installed, into gpu-suite.log. A test that
# needs what a bare machine lacks (Xvfb, glfw, Chromium, a pip install) fails or skips there for
# that reason; its line says so. The docs' blocks call `es2particles`: a shim stands in for it.
if [ -z "$DRY" ]; then
  say "== the whole suite but the browser's"
  mkdir -p /tmp/bin
  printf '#!/bin/sh\nexec %s -m es2particles "$@"\n' "$(command -v $PY)" > /tmp/bin/es2particles
  chmod +x /tmp/bin/es2particles
  export PATH="/tmp/bin:$PATH"
  extra=""
  $PY -c "import xdist" 2>/dev/null && extra="-n $(( $(nproc) > 12 ? 12 : $(nproc) ))"
  $PY -c "import pytest_timeout" 2>/dev/null && extra="$extra --timeout 150"
  left=$(( 420 - ($(date +%s) - start) ))
  timeout "$left" $PY -m pytest -q -p no:cacheprovider -p checkout_clean -o addopts="-ra" \
    -m "not browser" \
    $extra tests > "$OUT/gpu-suite.log" 2>&1
  grep -E "^(FAILED|ERROR) |^[0-9]+ (passed|failed)|^=+ .*(passed|failed)" "$OUT/gpu-suite.log" \
    | tail -60 | tee -a "$LOG"
fi
say "gpu.sh: done in $(( $(date +%s) - start )) s (figures exit $code); $OUT/RESULTS.md"
exit "$code"
