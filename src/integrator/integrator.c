/*
 * integrator/integrator.c: integrator names, and the dispatch of a camera sample to the integrator.
 */
#include "integrator/integrator.h"

#include <string.h>

#include "integrator/bdpt.h"
#include "integrator/path.h"
#include "integrator/volpath.h"

bool spc_integrator_kind_from_name(const char *name, spc_integrator_kind *kind)
{
    if (!strcmp(name, "path")) {
        *kind = SPC_INTEGRATOR_PATH;
        return true;
    }
    if (!strcmp(name, "ipt")) {
        *kind = SPC_INTEGRATOR_IPT;
        return true;
    }
    if (!strcmp(name, "bdpt")) {
        *kind = SPC_INTEGRATOR_BDPT;
        return true;
    }
    if (!strcmp(name, "volpath")) {
        *kind = SPC_INTEGRATOR_VOLPATH;
        return true;
    }
    if (!strcmp(name, "ptracer")) {
        *kind = SPC_INTEGRATOR_PTRACER;
        return true;
    }
    return false;
}

const char *spc_integrator_kind_name(spc_integrator_kind kind)
{
    switch (kind) {
    case SPC_INTEGRATOR_PATH: return "path";
    case SPC_INTEGRATOR_IPT: return "ipt";
    case SPC_INTEGRATOR_BDPT: return "bdpt";
    case SPC_INTEGRATOR_VOLPATH: return "volpath";
    case SPC_INTEGRATOR_PTRACER: return "ptracer";
    }
    return "?";
}

void spc_integrator_sample(const spc_render_ctx *ctx, spc_tls *tls, const spc_ray *ray, spc_sampler *smp,
                           spc_sample_out *out)
{
    switch (ctx->kind) {
    case SPC_INTEGRATOR_PATH:
    case SPC_INTEGRATOR_IPT: spc_path_sample(ctx, tls, ray, smp, out); return;
    case SPC_INTEGRATOR_BDPT:
    case SPC_INTEGRATOR_PTRACER: spc_bdpt_sample(ctx, tls, ray, smp, out); return;
    case SPC_INTEGRATOR_VOLPATH: spc_volpath_sample(ctx, tls, ray, smp, out); return;
    }
}
