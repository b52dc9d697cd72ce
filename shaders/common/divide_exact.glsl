// Division rounded to nearest, as the CPU divides: the one copy every shader uses where a
// quotient must match the host's (ray/triangle distances, BIH slab reciprocals) or be exact
// (a material's sampling weight f/pdf where f = pdf, which must be exactly 1).
#ifndef PF_DIVIDE_EXACT_GLSL
#define PF_DIVIDE_EXACT_GLSL

// 1 (the host's default for every device but llvmpipe, PF_VK_SPEC_DIVIDE_REFINE
// in core/vk/pf_vk.h): the device's division needs divide_exact's refinement.
layout(constant_id = 1000) const bool DIVIDE_REFINE = true;

// x / y rounded to nearest, as the CPU divides. Vulkan lets a shader's `/`
// be 2.5 ulp off; lavapipe's is exact, NVIDIA's is not (on an H200 the t of
// 1 in ~400 hits differed from the CPU's by 1-4 ulp, which moved hits at a
// ray's tmax across it). A Newton step from the device's quotient brings it
// within an ulp, and of it and its two neighbours the one whose exact
// remainder x - q y (one fma) is smallest is the rounded quotient (a
// quotient of floats is never a tie). Infinite, NaN or zero quotients are
// left as the device gives them. Skipped where the division is exact
// already (llvmpipe, whose fma() may also round its product, which would
// make the remainders inexact).
float divide_exact(float x, float y)
{
    precise float q = x / y;
    if (!DIVIDE_REFINE || isinf(q) || isnan(q) || q == 0.0)
        return q;
    precise float r = fma(-q, y, x);
    precise float step_q = fma(r, 1.0 / y, q);
    uint bits = floatBitsToUint(step_q);
    float below = uintBitsToFloat(bits - 1u), above = uintBitsToFloat(bits + 1u);
    precise float r_mid = abs(fma(-step_q, y, x));
    precise float r_below = abs(fma(-below, y, x));
    precise float r_above = abs(fma(-above, y, x));
    float best = r_below < r_mid ? below : step_q;
    return r_above < min(r_mid, r_below) ? above : best;
}

#endif
