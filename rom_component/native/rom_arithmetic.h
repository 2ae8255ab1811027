/*
 * The floating-point contract of every exported ROM's sums: no contraction of a * b + c into a fused multiply-add
 * and no -ffast-math, so that the C code repeats the Python ROM's reproducible arithmetic bit for bit whatever the
 * compiler flags. Included first by every source that computes.
 */
#ifndef ROM_ARITHMETIC_H
#define ROM_ARITHMETIC_H

#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#elif defined(_MSC_VER)
#pragma fp_contract(off)
#else
#pragma STDC FP_CONTRACT OFF
#endif
#if defined(__FAST_MATH__)
#error "an exported ROM must not be built with -ffast-math: its results are defined bit for bit"
#endif

/* the hot loops are compiled twice on x86-64 with GCC, for AVX2 and for the baseline, and the loader picks one
 * for the CPU it runs on; both do the same operations in the same order (no contraction), so the same results */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define HOT __attribute__((target_clones("avx2", "default")))
#else
#define HOT
#endif

#endif
