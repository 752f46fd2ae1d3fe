# Cross-compiling cierzo for aarch64 Linux on a Debian x86-64 host (scripts/test_aarch64.sh):
# Debian's aarch64-linux-gnu GCC, the :arm64 libraries of the multiarch tree, and qemu-user to
# run the tests. OpenEXR's development files come from a private sysroot the script unpacks
# (libopenexr-dev cannot be installed for two architectures at once); pass -DOpenEXR_DIR.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)

# find_package and find_library look in /usr/lib/aarch64-linux-gnu, never the host's tree
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
set(ENV{PKG_CONFIG_LIBDIR} /usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig)
# xsimd is headers only; the host's package config serves every architecture
set(xsimd_DIR /usr/lib/x86_64-linux-gnu/cmake/xsimd CACHE PATH "xsimd's CMake config")

# No binfmt_misc registration is assumed: ctest and gtest_discover_tests run every test
# program through qemu. Its loader and libc are the multiarch ones (libc6:arm64, which the
# :arm64 libraries depend on). Not -L /usr/aarch64-linux-gnu: that tree's loader comes from
# the cross toolchain's libc6-arm64-cross, a different build of glibc than the libc.so.6 it
# then finds in /lib/aarch64-linux-gnu, and the pair hangs in the first pthread_create.
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64 -L /)
