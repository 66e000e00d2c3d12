// Internal: which architecture's SIMD kernels this build compiles. Every file that holds or
// selects architecture-specific kernels includes this header, and only this one defines the
// macros. Kernels are compiled with target attributes or pragmas; the baseline ISA stays the
// compiler's default.
#pragma once

// x86-64: SSE2 is the baseline; the AVX2 and AVX-512 kernels carry __attribute__((target(...))).
#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define NIGHTLOC_X86_KERNELS 1
#else
#define NIGHTLOC_X86_KERNELS 0
#endif

// AArch64: NEON is the baseline; the dot-product kernel's file compiles it for
// armv8.2-a+dotprod with a target pragma (sad_neon_dotprod.cpp).
#if defined(__aarch64__) && (defined(__GNUC__) || defined(__clang__))
#define NIGHTLOC_ARM_KERNELS 1
#else
#define NIGHTLOC_ARM_KERNELS 0
#endif
