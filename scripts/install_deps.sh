#!/usr/bin/env bash
# Installs what cierzo needs on Debian 12 (root, or sudo): compiler, CMake, Ninja and the
# libraries (tinyobjloader for OBJ meshes); Open MPI (distributed renders); assimp-testmodels (real OBJ, MTL and JPEG files the tests read); matplotlib for the
# plots; Python's headers, pybind11, NumPy and pytest for the Python module and its tests,
# and venv, pip, setuptools and wheel for `pip install .`; clang and its runtime libraries
# for the sanitizer job (clang's array-bounds checks) and the fuzzers (libFuzzer);
# clang-format for the format check (tests/check_format.sh).
# With --render, only what the two programs need (scripts/render_default.sh): the compiler,
# CMake, Ninja and the libraries. Skips what is installed.
set -euo pipefail
render=(g++ cmake ninja-build pkg-config libxsimd-dev libopenexr-dev libimath-dev libtbb-dev
        libcli11-dev nlohmann-json3-dev libfmt-dev libstb-dev libtinyobjloader-dev)
rest=(libgtest-dev libgmock-dev libbenchmark-dev python3-matplotlib openmpi-bin libopenmpi-dev
      python3-dev pybind11-dev python3-numpy python3-pytest python3-venv python3-pip
      python3-setuptools python3-wheel assimp-testmodels clang libclang-rt-14-dev clang-format)
case "${1:-}" in
    --render) packages=("${render[@]}") ;;
    "") packages=("${render[@]}" "${rest[@]}") ;;
    *) echo "usage: $0 [--render]" >&2; exit 2 ;;
esac
missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
sudo=""
[ "$(id -u)" -ne 0 ] && sudo="sudo"
echo "installing: ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
