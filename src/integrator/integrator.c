/*
 * integrator/integrator.c: integrator names, and the dispatch of a camera sample to the integrator.
 */
#include "integrator/integrator.h"

#include <stdio.h>
#include <string.h>

#include "integrator/bdpt.h"
#include "integrator/path.h"
#include "integrator/volpath.h"

/* The integrators by name: the one list the parser and the names read. */
static const struct {
    const char *name;
    spc_integrator_kind kind;
} integrators[] = {
    {"path", SPC_INTEGRATOR_PATH},       {"ipt", SPC_INTEGRATOR_IPT},         {"bdpt", SPC_INTEGRATOR_BDPT},
    {"volpath", SPC_INTEGRATOR_VOLPATH}, {"ptracer", SPC_INTEGRATOR_PTRACER},
};

bool spc_integrator_kind_from_name(const char *name, spc_integrator_kind *kind)
{
    for (size_t i = 0; i < sizeof integrators / sizeof integrators[0]; ++i) {
        if (!strcmp(name, integrators[i].name)) {
            *kind = integrators[i].kind;
            return true;
        }
    }
    return false;
}

const char *spc_integrator_kind_name(spc_integrator_kind kind)
{
    for (size_t i = 0; i < sizeof integrators / sizeof integrators[0]; ++i)
        if (integrators[i].kind == kind)
            return integrators[i].name;
    return "?";
}

void spc_integrator_kind_names(char *buf, size_t size)
{
    size_t used = 0;
    if (size)
        buf[0] = '\0';
    for (size_t i = 0; i < sizeof integrators / sizeof integrators[0]; ++i) {
        int n = snprintf(buf + used, size - used, "%s%s", i ? ", " : "", integrators[i].name);
        if (n < 0 || (size_t)n >= size - used)
            break;
        used += (size_t)n;
    }
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
