/* 2-band spherical harmonics (pf_lpv.h's basis and clamped-cosine lobe). */
#include "pf_lpv.h"

void pf_sh_basis(const float direction[3], float out[4])
{
    out[0] = PF_SH_Y00;
    out[1] = -PF_SH_Y1 * direction[1];
    out[2] = PF_SH_Y1 * direction[2];
    out[3] = -PF_SH_Y1 * direction[0];
}

void pf_sh_cosine_lobe(const float normal[3], float out[4])
{
    out[0] = PF_SH_COSINE0;
    out[1] = -PF_SH_COSINE1 * normal[1];
    out[2] = PF_SH_COSINE1 * normal[2];
    out[3] = -PF_SH_COSINE1 * normal[0];
}

float pf_sh_eval(const float coefficients[4], const float direction[3])
{
    float basis[4];
    pf_sh_basis(direction, basis);
    return coefficients[0] * basis[0] + coefficients[1] * basis[1] + coefficients[2] * basis[2] +
           coefficients[3] * basis[3];
}

double pf_sh_integral(const float coefficients[4])
{
    return (double)coefficients[0] * PF_SH_Y00 * 4.0 * 3.14159265358979323846;
}
