/*
 * manifold/solve_mis.h: multiple importance sampling between specular NEE and BSDF sampling with the
 * randomized solver's real probability of finding a chain, which is not known but can be sampled.
 *
 * A covered path reaches the light through a chain that a randomized attempt finds with probability
 * p (unknown; each attempt an independent Bernoulli trial). Specular NEE generates it with density
 * p A (A: the light point's density times the probabilities of the query and of the chain's events,
 * known), BSDF sampling with density b (known). The balance heuristic gives both strategies the
 * same contribution F / (p A + b) (F the path's measurement contribution). With N the number of
 * attempts until the chain is found again (geometric, E[N] = 1 / p) and r = A / (A + b),
 *
 *     Z = (1 - r^N) / b        has E[Z] = 1 / (p A + b)
 *
 * (the geometric series 1 / (p A + b) = (1 / (A + b)) sum_k (r (1 - p))^k, whose k-th term is
 * P(N > k) r^k). Specular NEE adds F Z from the count after its attempt found the chain, BSDF
 * sampling F / b times the weight b Z = 1 - r^N from a count of its own: unbiased, each side bounded
 * by F / b (Z <= 1 / b), so the count's heavy tail N / A where p is small stays only where b is
 * small against A, where BSDF sampling cannot take the path. The second moment of the pair is within
 * a small factor of the deterministic balance heuristic's (Z <= min(1 / b, N / (A + b))). A 0/1
 * weight of the same mean on the BSDF side (1 with probability b / (p A + b)) would add the
 * variance of a coin flip on BSDF sampling's largest values F / b; b Z does not.
 *
 * Cost: specular NEE's count is the trial count it ran before (one attempt per trial); once r^n is
 * small (solve_mis.c) the rest of r^N is one Russian roulette of probability r per attempt, so a
 * count stops after a few times A / b attempts where p is small and b is not. Both sides count at
 * most `cap` attempts, as the trial count always was (N replaced by min(N, cap) on both sides: a
 * cut count loses a little where p < ~1/cap).
 *
 * specular_nee.c applies it to the chains through tessellated balls (solver.h, solve_mis), whose
 * seeds (fit_seeds.h) make p large; elsewhere MIS keeps the stand-in psi.
 */
#ifndef SPC_MANIFOLD_SOLVE_MIS_H
#define SPC_MANIFOLD_SOLVE_MIS_H

#include <stdbool.h>

#include "core/rng.h"

/* One Bernoulli trial: one independent attempt; true if it found the chain. */
typedef bool (*spc_solve_mis_trial)(void *user);

/* Specular NEE's side: Z above, an unbiased estimate of 1 / (p A + b) (with b = 0: N / A, the plain
 * trial count over A), after the first attempt found the chain. A > 0, b >= 0. *trials (may be
 * NULL) gets the attempts run, *capped (may be NULL) whether the count reached cap. */
double spc_solve_mis_light(double A, double b, spc_solve_mis_trial trial, void *user, spc_rng *rng, int cap,
                           int *trials, bool *capped);

/* BSDF sampling's side: the weight b Z = 1 - r^N (in [0, 1]) from a count of its own, with
 * expectation b / (p A + b) (1 where A is 0, 0 where b is 0). */
double spc_solve_mis_sampled(double A, double b, spc_solve_mis_trial trial, void *user, spc_rng *rng, int cap,
                             int *trials);

#endif
