/*
 * manifold/solve_mis.c: the balance heuristic with the randomized solver's real solve probability
 * (solve_mis.h): the two sides' estimates from Bernoulli trials.
 *
 * The light side is the Bernoulli trial count of Zeltner et al. 2020 (sec. 4.3) passed through the
 * geometric series of 1 / (p A + b) (the construction of unbiased reciprocal estimators, Booth
 * 2007), the tail of r^N past a small value by Russian roulette; the sampled side counts the same way.
 */
#include "manifold/solve_mis.h"

#include <math.h>
#include <stddef.h>

/* While r^n is above this, the light side multiplies by r exactly; below it, the rest of r^N is one
 * roulette per attempt (its value 0 or 1 moves Z by at most this fraction of 1 / b), so the count
 * ends after about ln(1 / 0.05) b / A + A / b attempts instead of 1 / p. */
#define SPC_SOLVE_MIS_EXACT_TAIL 0.05

double spc_solve_mis_light(double A, double b, spc_solve_mis_trial trial, void *user, spc_rng *rng, int cap,
                           int *trials, bool *capped)
{
    if (cap < 1)
        cap = 1;
    bool cut = false;
    int n = 0;
    double z;
    if (!(b > 0.0)) {
        /* BSDF sampling never takes the path: the plain count */
        while (++n < cap && !trial(user))
            ;
        cut = n >= cap;
        z = n / A;
    } else {
        /* log r, and r^n as its exponent n log r while exact; rest: the roulette's value (0 or 1) */
        double lr = -log1p(b / A), r = A / (A + b);
        int exact = 0;
        double rest = 1.0;
        for (;;) {
            ++n;
            if (exp((exact + 1) * lr) >= SPC_SOLVE_MIS_EXACT_TAIL)
                ++exact;
            else if (!(spc_rng_next(rng) < r)) {
                rest = 0.0;
                break;
            }
            if (trial(user))
                break;
            if (n >= cap) {
                cut = true;
                break;
            }
        }
        /* 1 - r^exact rest, without cancellation where r is near 1 */
        z = (rest > 0.0 ? -expm1(exact * lr) : 1.0) / b;
    }
    if (trials)
        *trials = n;
    if (capped)
        *capped = cut;
    return z;
}

double spc_solve_mis_sampled(double A, double b, spc_solve_mis_trial trial, void *user, spc_rng *rng, int cap,
                             int *trials)
{
    if (trials)
        *trials = 0;
    if (!(A > 0.0))
        return 1.0;
    if (!(b > 0.0))
        return 0.0;
    /* b Z: 1 - r^N, in [0, 1] */
    double w = b * spc_solve_mis_light(A, b, trial, user, rng, cap, trials, NULL);
    return w < 1.0 ? w : 1.0;
}
