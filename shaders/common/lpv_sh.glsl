// 2-band spherical harmonics of the light propagation volumes: the basis and
// clamped-cosine lobe of core/lpv/pf_lpv.h (keep the constants in step).
// A cell's intensity is three vec4 of coefficients (R, G, B).
#ifndef PF_LPV_SH_GLSL
#define PF_LPV_SH_GLSL

const float SH_Y00 = 0.28209479177387814;
const float SH_Y1 = 0.48860251190291992;
const float SH_COSINE0 = 0.88622692545275801;
const float SH_COSINE1 = 1.02332670794648848;

vec4 sh_basis(vec3 direction)
{
    return vec4(SH_Y00, -SH_Y1 * direction.y, SH_Y1 * direction.z, -SH_Y1 * direction.x);
}

// Coefficients of max(0, n·ω).
vec4 sh_cosine_lobe(vec3 normal)
{
    return vec4(SH_COSINE0, -SH_COSINE1 * normal.y, SH_COSINE1 * normal.z,
                -SH_COSINE1 * normal.x);
}

// Blocking of a geometry-volume cell for light travelling along ω
// (core/lpv/pf_lpv.h): the surfaces it meets face −ω, B = clamp(GV(−ω), 0, 1).
float sh_blocking(vec4 gv, vec3 direction)
{
    return clamp(dot(gv, sh_basis(-direction)), 0.0, 1.0);
}

#endif
