/*
 * manifold/polish.c: a root of an exact enumeration (sphere_chains.c, cylinder_chains.c,
 * plane_chains.c, flat_chains.c) made a chain: a few steps of the angular solver toward the query's light point,
 * whose trace also proves the segments before the last unblocked (solver.h).
 */
#include "manifold/solver.h"

bool spc_snee_exact_polish(const spc_snee_query *q, const spc_shape *s, int k, const unsigned char *events,
                           spc_vec3 dir, spc_chain *out, int n, int *iterations)
{
    const spc_shape *shapes[SPC_CHAIN_MAX_VERTICES];
    if (k < 1 || k > SPC_CHAIN_MAX_VERTICES)
        return false;
    for (int j = 0; j < k; ++j)
        shapes[j] = s;
    return spc_snee_exact_polish_shapes(q, shapes, k, events, dir, out, n, iterations);
}

static bool polish(const spc_snee_query *q, const spc_shape *const *shapes, int k, const unsigned char *events,
                   spc_vec3 dir, spc_chain *out, int n, int *iterations, bool flat)
{
    const spc_scene *sc = q->scene;
    spc_chain_opts opts = spc_chain_opts_default(k);
    opts.events = events;
    opts.any_surface = q->any_surface;
    /* the seed's final segment is not traced: the solve takes the seed whatever it meets (an
     * escape, a surface or one more chain surface), and nothing reads the end hit */
    opts.skip_end = true;
    spc_angular_target tg = {q->y, q->ny, sc->radius, q->light_size};
    spc_angular_options ao;
    if (q->params)
        ao = q->params->angular;
    else
        spc_angular_options_default(&ao);
    ao.window = 0;         /* from a root, no stagnation to cut short */
    ao.max_iterations = 8; /* one or two traces as a rule */
    if (flat) {
        ao.tol_scene = SPC_SNEE_FLAT_POLISH_TOL_SCENE;
        ao.tol_light = SPC_SNEE_FLAT_POLISH_TOL_LIGHT;
    }
    spc_angular_result res;
    spc_chain *c = &out[n];
    bool conv = spc_angular_solve(sc, q->x, &tg, dir, &opts, &ao, c, &res);
    if (iterations)
        *iterations += res.iterations;
    if (!conv || c->n != k)
        return false;
    for (int j = 0; j < k; ++j)
        if (c->v[j].h.shape != shapes[j] || c->v[j].event != events[j])
            return false;
    for (int o = 0; o < n; ++o)
        if (spc_snee_same_solution(&out[o], c, sc->radius))
            return false;
    return true;
}

bool spc_snee_exact_polish_shapes(const spc_snee_query *q, const spc_shape *const *shapes, int k,
                                  const unsigned char *events, spc_vec3 dir, spc_chain *out, int n, int *iterations)
{
    return polish(q, shapes, k, events, dir, out, n, iterations, false);
}

bool spc_snee_exact_polish_flat(const spc_snee_query *q, const spc_shape *const *shapes, int k,
                                const unsigned char *events, spc_vec3 dir, spc_chain *out, int n, int *iterations)
{
    return polish(q, shapes, k, events, dir, out, n, iterations, true);
}
