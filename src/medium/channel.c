/*
 * medium/channel.c: the spectral channel choice both medium variants share (homogeneous.c,
 * heterogeneous.c): the probabilities of the RGB channels in proportion to the path throughput
 * (spc_medium_channel_pmf, medium.h), and the pick of one by a uniform number
 * (spc_medium_pick_channel, variants.h). Below both variants and the dispatcher, calling neither.
 */
#include <math.h>

#include "medium/variants.h"

void spc_medium_channel_pmf(spc_rgb beta, double q[3])
{
    double b[3] = {spc_max(beta.r, 0.0), spc_max(beta.g, 0.0), spc_max(beta.b, 0.0)};
    double sum = b[0] + b[1] + b[2];
    if (!(sum > 0.0) || !isfinite(sum)) {
        q[0] = q[1] = q[2] = 1.0 / 3.0;
        return;
    }
    for (int i = 0; i < 3; ++i)
        q[i] = b[i] / sum;
}

int spc_medium_pick_channel(const double q[3], double u)
{
    int c = -1;
    double cum = 0.0;
    for (int i = 0; i < 3; ++i) {
        if (!(q[i] > 0.0))
            continue;
        c = i;
        cum += q[i];
        if (u < cum)
            break;
    }
    return c;
}
