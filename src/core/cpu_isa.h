/*
 * core/cpu_isa.h: which vector instruction set the batch kernels use.
 *
 * The kernels with AVX2 and AVX-512 variants (the sampler's pairs, the warps, the camera's rays, the
 * area and sphere lights' batches) give the same results in every variant; this picks the best one
 * the CPU has, once per process. SPECULA_VECTOR_ISA=base|avx2|avx512 caps it (tests run every
 * variant that way).
 */
#ifndef SPC_CORE_CPU_ISA_H
#define SPC_CORE_CPU_ISA_H

enum { SPC_ISA_BASE = 0, SPC_ISA_AVX2 = 1, SPC_ISA_AVX512 = 2 };

/* SPC_ISA_AVX512 (F, DQ, BW and VL), SPC_ISA_AVX2 or SPC_ISA_BASE: the CPU's best under the cap. */
int spc_vector_isa(void);

#endif
