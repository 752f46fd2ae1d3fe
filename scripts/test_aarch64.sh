#!/usr/bin/env bash
# The aarch64 job: on an x86-64 Debian host, installs what is missing for a cross build
# (the aarch64 GCC, qemu-user, the :arm64 libraries), cross-builds cierzo with its NEON
# kernels into build-aarch64/ and runs the ctest suite under qemu-user, but for the statistical
# comparisons over every scene (scripts/statistical_tests.sh says why). Ends with the
# pass count and the ISAs exercised. Called by scripts/test.sh; an aarch64 host needs none of
# this (scripts/test.sh builds and tests NEON natively there).
set -euo pipefail
cd "$(dirname "$0")/.."
case "$(uname -m)" in
    aarch64 | arm64)
        echo "test_aarch64.sh: not needed on an aarch64 host: scripts/test.sh tests NEON natively"
        exit 0
        ;;
    x86_64) ;;
    *)
        echo "test_aarch64.sh: cross-builds on x86-64 hosts only, not $(uname -m)" >&2
        exit 1
        ;;
esac
build=build-aarch64
sysroot=$build/sysroot
emulator=(qemu-aarch64 -L /)  # as in cmake/aarch64-linux-gnu.cmake, which says why
start=$(date +%s)

# ---- Packages: host tools, and the target's libraries beside the host's (Multi-Arch) ------
sudo=""
[ "$(id -u)" -ne 0 ] && sudo="sudo"
export DEBIAN_FRONTEND=noninteractive
updated=0
apt_update() {
    if [ "$updated" = 0 ]; then $sudo apt-get update -qq; updated=1; fi
}
if ! dpkg --print-foreign-architectures | grep -qx arm64; then
    echo "adding the arm64 architecture to dpkg" >&2
    $sudo dpkg --add-architecture arm64
fi
# OpenEXR's runtime is Multi-Arch: same; its -dev package is not (installing it for arm64
# would remove the host's), so its headers and CMake files are unpacked below instead
packages=(crossbuild-essential-arm64 qemu-user pkg-config cmake ninja-build libxsimd-dev
          libcli11-dev nlohmann-json3-dev)
for p in libc6 libstdc++6 libtbb-dev libimath-dev libgtest-dev libgmock-dev libbenchmark-dev \
         libfmt-dev libstb-dev libtinyobjloader-dev zlib1g-dev libopenexr-3-1-30; do
    packages+=("$p:arm64")
done
missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
    echo "installing: ${missing[*]}" >&2
    apt_update
    $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# ---- OpenEXR for arm64 in a private sysroot: the -dev package and the runtime it names ----
exr_config=$sysroot/usr/lib/aarch64-linux-gnu/cmake/OpenEXR
if [ ! -f "$exr_config/OpenEXRConfig.cmake" ]; then
    version=$(dpkg-query -W -f='${Version}' libopenexr-3-1-30:arm64)
    debs=$(mktemp -d)
    trap 'rm -rf "$debs"' EXIT
    download() {
        # (as root, apt would hand the download to its _apt user, who cannot write here)
        (cd "$debs" && apt-get download -qq -o APT::Sandbox::User="$(id -un)" \
            "libopenexr-dev:arm64=$version" "libopenexr-3-1-30:arm64=$version")
    }
    download 2>/dev/null || { apt_update; download; }
    mkdir -p "$sysroot"
    for deb in "$debs"/*.deb; do dpkg-deb -x "$deb" "$sysroot"; done
    rm -rf "$debs"
    trap - EXIT
fi

# ---- Cross build: Release and the tests (the benchmarks are not run under qemu, and an
# aarch64 host builds them natively) -------------------------------------------------------
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCIERZO_BUILD_BENCH=OFF -DCIERZO_MPI=OFF \
    -DCIERZO_PYTHON=OFF \
    -DCMAKE_TOOLCHAIN_FILE="$PWD/cmake/aarch64-linux-gnu.cmake" \
    -DOpenEXR_DIR="$PWD/$exr_config" >/dev/null
cmake --build "$build" --parallel "$(nproc)"
built=$(date +%s)

# ---- The suite under qemu-user -----------------------------------------------------------
# qemu runs these renders about 100 times slower: the tests that read CIERZO_TEST_EMULATED
# render fewer paths and smaller images (as under the sanitizers)
export CIERZO_TEST_EMULATED=1
echo "CIERZO_TEST_EMULATED=1: under qemu, the whole-render tests use their lighter settings"
log=$build/ctest.log
status=0
# The statistical comparisons over every scene are left to the native run (the script says
# why; here Agreement.WavefrontMatchesScalarOnEverySceneAndIsa checks NEON on every scene)
source scripts/statistical_tests.sh
(cd "$build" && ctest --output-on-failure --parallel "$(nproc)" --timeout 3600 -E "$statistical") |
    tee "$log" ||
    status=$?
tested=$(date +%s)
scripts/skipped_tests.sh "$build" "aarch64 tests"

# ---- Summary ------------------------------------------------------------------------------
total=$(sed -n 's/.*tests failed out of \([0-9]*\).*/\1/p' "$log" | tail -1)
failed=$(sed -n 's/.* \([0-9]*\) tests failed out of.*/\1/p' "$log" | tail -1)
skipped=$(grep -c '(Skipped)$' "$log" || true)
echo "aarch64 under qemu: ${total:-?} tests, $((${total:-0} - ${failed:-0} - skipped)) passed," \
     "$skipped skipped, ${failed:-?} failed (build $((built - start)) s, tests $((tested - built)) s)"
scripts/isa_summary.sh "$build" "aarch64, qemu" "${emulator[@]}"
exit "$status"
