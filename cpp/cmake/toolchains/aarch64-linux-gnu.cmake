# Cross-building the nightloc core for 64-bit ARM Linux (Raspberry Pi 3/4/5, Rockchip, Jetson)
# with Debian's cross compiler, and running its tests and examples under user-mode QEMU:
#
#   apt-get install g++-aarch64-linux-gnu qemu-user
#   cmake -S cpp -B build/aarch64 --toolchain cpp/cmake/toolchains/aarch64-linux-gnu.cmake \
#         -DCMAKE_PREFIX_PATH=<Eigen's prefix>
#   cmake --build build/aarch64 -j 2 && ctest --test-dir build/aarch64
#
# The binaries are plain AArch64 (armv8-a): NEON is the baseline; the dot-product kernels are
# compiled with a target attribute and chosen at run time (getauxval(AT_HWCAP)), never by flags.
# Another cross compiler: -DNIGHTLOC_CROSS_PREFIX=<triplet>- (e.g. aarch64-none-linux-gnu-) and
# -DNIGHTLOC_SYSROOT=<its sysroot>.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)

set(NIGHTLOC_CROSS_PREFIX "aarch64-linux-gnu-" CACHE STRING "Prefix of the cross compiler's programs")
set(NIGHTLOC_SYSROOT "/usr/aarch64-linux-gnu" CACHE PATH "Target's root: its libc and libstdc++ (QEMU's -L)")
set(CMAKE_C_COMPILER "${NIGHTLOC_CROSS_PREFIX}gcc")
set(CMAKE_CXX_COMPILER "${NIGHTLOC_CROSS_PREFIX}g++")

# Libraries and headers of the target come from its root; programs from the build machine.
# Packages may be found anywhere: Eigen is header-only and the same for every architecture.
set(CMAKE_FIND_ROOT_PATH "${NIGHTLOC_SYSROOT}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)

# ctest runs every test and example through QEMU (the "max" CPU model: NEON and dot product).
find_program(NIGHTLOC_QEMU NAMES qemu-aarch64 qemu-aarch64-static)
if(NIGHTLOC_QEMU)
  set(CMAKE_CROSSCOMPILING_EMULATOR "${NIGHTLOC_QEMU};-L;${NIGHTLOC_SYSROOT}")
else()
  message(WARNING "qemu-aarch64 not found (Debian: apt-get install qemu-user): ctest cannot run the tests here")
endif()
