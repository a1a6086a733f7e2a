/*
 * core/cpu_isa.h: which vector instruction set the batch kernels use.
 *
 * The kernels with AVX2 and AVX-512 variants (the sampler's pairs, the warps, the camera's rays, the
 * area and sphere lights' batches) give the same results in every variant; this picks the best one
 * the CPU has, once per process. SPECULA_VECTOR_ISA=base|avx2|avx512|avx512gfni caps it (tests
 * run every variant that way); avx512 caps it below GFNI, which the sampler's pairs use where the
 * CPU has it and the cap allows.
 */
#ifndef SPC_CORE_CPU_ISA_H
#define SPC_CORE_CPU_ISA_H

#include <stdbool.h>

enum { SPC_ISA_BASE = 0, SPC_ISA_AVX2 = 1, SPC_ISA_AVX512 = 2 };

/* SPC_ISA_AVX512 (F, DQ, BW and VL), SPC_ISA_AVX2 or SPC_ISA_BASE: the CPU's best under the cap. */
int spc_vector_isa(void);
/* Whether the kernels may use GFNI beside AVX-512: spc_vector_isa is SPC_ISA_AVX512, the CPU has
 * GFNI, and SPECULA_VECTOR_ISA is unset or avx512gfni. */
bool spc_vector_gfni(void);

#endif
