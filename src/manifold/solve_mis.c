/*
 * manifold/solve_mis.c: the balance heuristic with the randomized solver's real solve probability
 * (solve_mis.h): the two sides' estimates from Bernoulli trials.
 *
 * The light side is the Bernoulli trial count of Zeltner et al. 2020 (sec. 4.3) passed through the
 * geometric series of 1 / (p A + b) (the construction of unbiased reciprocal estimators, Booth
 * 2007), the tail of r^N past a small value by Russian roulette; the sampled side counts the same way.
 */
#include "manifold/solve_mis.h"

#include <limits.h>
#include <math.h>
#include <stddef.h>

/* While r^n is above this, the light side multiplies by r exactly; below it, the rest of r^N is one
 * roulette per attempt (its value 0 or 1 moves Z by at most this fraction of 1 / b), so the count
 * ends after about ln(1 / 0.05) b / A + A / b attempts instead of 1 / p. */
#define SPC_SOLVE_MIS_EXACT_TAIL 0.05

double spc_trial_count_on(spc_solve_mis_trial trial, void *user, spc_rng *rng, int done, int *attempts)
{
    double more = 0.0, w = 1.0;
    int block = done > 0 ? done : 1, run = 0;
    while (spc_rng_next(rng) < SPC_TRIAL_GO_ON) {
        w /= SPC_TRIAL_GO_ON;
        if (block <= SPC_TRIAL_MAX_BLOCK / 2)
            block *= 2;
        for (int i = 1; i <= block; ++i) {
            run = run < INT_MAX ? run + 1 : run;
            if (trial(user)) {
                *attempts = run;
                return more + w * i;
            }
        }
        more += w * block;
    }
    *attempts = run;
    return more;
}

/* The b > 0 count's state: attempts run, those multiplied by r exactly, and the roulette's value. */
typedef struct tail_count {
    double lr, r;
    int n, exact;
    double rest;
} tail_count;

/* One attempt of the b > 0 count; true where the count ends (found, or the roulette's 0). */
static bool tail_step(tail_count *c, spc_solve_mis_trial trial, void *user, spc_rng *rng)
{
    ++c->n;
    if (exp((c->exact + 1) * c->lr) >= SPC_SOLVE_MIS_EXACT_TAIL)
        ++c->exact;
    else if (!(spc_rng_next(rng) < c->r)) {
        c->rest = 0.0;
        return true;
    }
    return trial(user);
}

/* Z of the b > 0 count's state: 1 - r^exact rest over b, without cancellation where r is near 1. */
static double tail_z(const tail_count *c, double b)
{
    return (c->rest > 0.0 ? -expm1(c->exact * c->lr) : 1.0) / b;
}

double spc_solve_mis_light(double A, double b, spc_solve_mis_trial trial, void *user, spc_rng *rng, int cap,
                           int *trials, bool *capped)
{
    if (cap < 1)
        cap = 1;
    bool cut = false;
    int n = 0;
    double z;
    if (!(b > 0.0)) {
        /* BSDF sampling never takes the path: the plain count, past the cap by roulette */
        while (++n < cap && !trial(user))
            ;
        z = n / A;
        if (n >= cap) {
            /* the cap-th attempt, then the roulette past it */
            cut = true;
            if (!trial(user)) {
                int more = 0;
                z = (n + spc_trial_count_on(trial, user, rng, n, &more)) / A;
                n = more < INT_MAX - n ? n + more : INT_MAX;
            }
        }
    } else {
        /* log r, and r^n as its exponent n log r while exact; rest: the roulette's value (0 or 1) */
        tail_count c = {.lr = -log1p(b / A), .r = A / (A + b), .n = 0, .exact = 0, .rest = 1.0};
        bool done = false;
        while (!done && c.n < cap)
            done = tail_step(&c, trial, user, rng);
        z = tail_z(&c, b);
        if (!done) {
            /* past the cap: blocks of twice the last one's attempts, each entered with probability
             * SPC_TRIAL_GO_ON, what they add to Z weighted by the inverse of every entry so far */
            cut = true;
            double w = 1.0;
            int block = cap;
            while (!done && spc_rng_next(rng) < SPC_TRIAL_GO_ON) {
                w /= SPC_TRIAL_GO_ON;
                if (block <= SPC_TRIAL_MAX_BLOCK / 2)
                    block *= 2;
                double z0 = tail_z(&c, b);
                for (int i = 0; i < block && !done; ++i)
                    done = tail_step(&c, trial, user, rng);
                z += w * (tail_z(&c, b) - z0);
            }
        }
        n = c.n;
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
    bool cut;
    double w = b * spc_solve_mis_light(A, b, trial, user, rng, cap, trials, &cut);
    /* the count's own value is at most 1 but for rounding; past the cap the roulette's weight can
     * carry it above 1, which its mean needs */
    return cut || w < 1.0 ? w : 1.0;
}
