#!/usr/bin/env bash
# Idempotent set-up of a fresh machine: a virtual environment in .venv with the pinned CPU torch wheel,
# the package and its test tools, and (where apt and root are available) Debian's libllvm19 so that
# Mitsuba's fast LLVM variant can run (mcd falls back to the scalar variant without it) and Debian's
# chromium, the headless browser of the report viewer's test (tests/reports/test_viewer.py; it skips without
# one outside CI and fails without one in CI). Playwright drives that chromium: no browser is downloaded.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3.11}
command -v "$PY" >/dev/null || PY=python3
if [ ! -f /usr/lib/x86_64-linux-gnu/libLLVM-19.so ] && command -v apt-get >/dev/null && [ "$(id -u)" = 0 ]; then
    (apt-get update -qq && apt-get install -y -qq libllvm19) || echo "setup: libllvm19 not installed; Mitsuba will use the scalar variant"
fi
if ! command -v chromium >/dev/null && command -v apt-get >/dev/null && [ "$(id -u)" = 0 ]; then
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium) || echo "setup: chromium not installed; the viewer's browser test needs it"
fi
[ -x .venv/bin/python ] || "$PY" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
# The pinned CPU wheel first: an unpinned torch would pull several GB of CUDA packages.
.venv/bin/python -c "import torch" 2>/dev/null || .venv/bin/python -m pip install -q torch==2.13.0
.venv/bin/python -m pip install -q -e '.[dev,oidn]'
