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
 * count stops after a few times A / b attempts where p is small and b is not. Both sides count the
 * first `cap` attempts plainly; a count that reaches cap without its chain goes on by Russian
 * roulette (SPC_TRIAL_GO_ON below), unbiased for every p.
 *
 * specular_nee.c applies it to the chains through tessellated balls (solver.h, solve_mis), whose
 * seeds (fit_seeds.h) make p large, and to the chains within the budget on SDFs without creases;
 * elsewhere MIS keeps the stand-in psi.
 */
#ifndef SPC_MANIFOLD_SOLVE_MIS_H
#define SPC_MANIFOLD_SOLVE_MIS_H

#include <stdbool.h>

#include "core/rng.h"

/* Russian roulette past a count's cap, for every trial count of specular NEE (this file's and
 * solver.h's spc_snee_count_trials): a count whose first `cap` attempts failed goes on in blocks of
 * twice the last block's attempts (at most SPC_TRIAL_MAX_BLOCK), each block entered with probability
 * SPC_TRIAL_GO_ON and what its attempts add then weighted by the inverse of every entry so far. The
 * count has no memory (the attempts are independent), so the expected rest of the count where a
 * block is entered is the uncut count's: unbiased for every p > 0, where a cut count's mean is
 * (1 - (1 - p)^cap) / p (226 for p = 1e-3, cap 256, against 1000). Its attempts are a prefix of the
 * uncut count's, so it costs at most that count's 1/p; the doubling keeps its variance finite for every p
 * (the chance of reaching a block falls faster than the weight 1 / GO_ON^k grows), where a roulette
 * with blocks of a fixed `cap` has infinite variance for (1 - p)^cap > GO_ON (p below 4e-4 at cap 256
 * and 0.9). Variance of 1/p's estimate at cap 256 against the uncut count's (1 - p) / p^2, and expected
 * attempts times p (bench/RESULTS.md, part cap9): p = 1e-3: 1.34x, 0.87; 1e-4: 2.1x, 0.66; 1e-5: 3.4x,
 * 0.47. A smaller GO_ON stops sooner at more variance (0.7: 9x at 1e-4 for 0.28 of the attempts). */
#define SPC_TRIAL_GO_ON 0.9
/* The longest block (the doubling's end, so a count's attempts fit an int for any p above ~1e-8). */
#define SPC_TRIAL_MAX_BLOCK (1 << 24)

/* One Bernoulli trial: one independent attempt; true if it found the chain. */
typedef bool (*spc_solve_mis_trial)(void *user);

/* The roulette past a count's cap: after `done` failed attempts, an unbiased estimate of the
 * attempts the uncut count still needs (E[N - done | N > done] = 1 / p), blocks as above (the first
 * of 2 done attempts). Draws rng only for the roulette. *attempts gets the attempts run. */
double spc_trial_count_on(spc_solve_mis_trial trial, void *user, spc_rng *rng, int done, int *attempts);

/* Specular NEE's side: Z above, an unbiased estimate of 1 / (p A + b) (with b = 0: N / A, the plain
 * trial count over A), after the first attempt found the chain. A > 0, b >= 0. *trials (may be
 * NULL) gets the attempts run, *capped (may be NULL) whether the count reached cap (and went on by
 * roulette; Z may then exceed 1 / b). */
double spc_solve_mis_light(double A, double b, spc_solve_mis_trial trial, void *user, spc_rng *rng, int cap,
                           int *trials, bool *capped);

/* BSDF sampling's side: the weight b Z = 1 - r^N from a count of its own, with expectation
 * b / (p A + b) (1 where A is 0, 0 where b is 0); in [0, 1] unless the count went past cap. */
double spc_solve_mis_sampled(double A, double b, spc_solve_mis_trial trial, void *user, spc_rng *rng, int cap,
                             int *trials);

#endif
