#pragma once
// Run-time choice of instruction set for the hot kernels. The default build targets the
// x86-64 baseline (SSE2), so one binary runs on every x86-64 machine; a function marked
// WEFT_HOT_KERNEL is compiled twice by GCC, for the baseline and with AVX2, and the loader
// picks the clone the CPU supports (an ifunc). The clone names the instruction set, not an
// architecture level ("arch=x86-64-v3"): GCC inlines the kernels' small helpers only into a
// caller of the same architecture and tuning. The build turns
// floating-point contraction off (-ffp-contract=off, CMakeLists.txt), and the kernels'
// vector arithmetic is element-wise in a fixed order, so both clones round alike: a step
// gives the same bits whichever clone runs.
//
// No clones where the whole build already targets AVX2 (-march=native on such a CPU, the
// WEFT_NATIVE option), with compilers other than GCC, or when WEFT_NO_DISPATCH is defined.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(__AVX2__) && \
    !defined(WEFT_NO_DISPATCH)
#define WEFT_HOT_KERNEL __attribute__((target_clones("avx2", "default")))
#else
#define WEFT_HOT_KERNEL
#endif
