#!/usr/bin/env bash
# Sets glmls up on a fresh Debian/Ubuntu machine with Python >= 3.11:
#   - the system OpenGL stack for headless rendering (EGL + Mesa; llvmpipe runs GL 4.5 on
#     the CPU when there is no GPU) and Xvfb for the real-time window under a virtual screen;
#   - a virtual environment in .venv with glmls installed (editable), its test tools, the
#     `distributed` extra (Dask, for --scheduler) and the extras of glmls.augment's adapters
#     (`albumentations`; `torch`: torch and torchvision, whose tests run on the CPU).
# Safe to run again: it installs only what is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

PYTHON=${PYTHON:-python3}
# glslang-tools: the Khronos reference compiler, which the tests run over the shaders (it is
# stricter than Mesa's, as GPU vendors' compilers are)
packages=(libegl1 libegl-mesa0 libgl1-mesa-dri xvfb xauth glslang-tools)
if ! "$PYTHON" -c "import ensurepip, venv" >/dev/null 2>&1; then
    packages+=(python3-venv)
fi
missing=()
for pkg in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" \
        || missing+=("$pkg")
done
if ((${#missing[@]})); then
    echo "setup: installing system packages: ${missing[*]}" >&2
    sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
        "${missing[@]}" >/dev/null
fi

if [ ! -x .venv/bin/python ]; then
    "$PYTHON" -m venv .venv
fi
.venv/bin/python -m pip install -q --disable-pip-version-check --upgrade pip
# the distributed extra too, so that the tests run the Dask paths (--scheduler) as well, and
# the adapters' libraries, so that their tests run
.venv/bin/python -m pip install -q --disable-pip-version-check \
    -e ".[test,distributed,albumentations,torch]"
echo "setup: ready (.venv/bin/python, .venv/bin/glmls)" >&2
