// The pixel filters of every preset (pf_pixel_filter in core/render/pf_render.h).
#ifndef PF_PIXEL_FILTER_GLSL
#define PF_PIXEL_FILTER_GLSL

// The pixel filters (pf_pixel_filter), sampled exactly by inverting their
// CDFs (filter importance sampling, Ernst et al. 2006), so every sample
// weighs the same and a pixel is the plain mean of its samples. Each returns
// the offset in pixels from the pixel centre for xi in [0,1)².
const uint FILTER_GAUSSIAN = 0u;
const uint FILTER_BOX = 1u;
const uint FILTER_BLACKMAN_HARRIS = 2u;
// The filter a pipeline is made for (PF_SPEC_PIXEL_FILTER in core/render/pf_render.h: the
// renderer specialises its camera kernels to the frame's), or FILTER_FROM_PARAMS: the
// filter_kind the caller passes (params.pixel_filter) picks at run time. llvmpipe runs
// every branch's code for every ray, masked; a fixed filter compiles the others out.
const uint FILTER_FROM_PARAMS = 3u;
layout(constant_id = 1007) const uint PIXEL_FILTER = FILTER_FROM_PARAMS;

// Gaussian: radially symmetric, standard deviation FILTER_SIGMA pixels,
// truncated at FILTER_RADIUS pixels (3σ: the weight left out is e^-4.5 ≈
// 1.1%), by its radial CDF.
const float FILTER_SIGMA = 0.5;
const float FILTER_RADIUS = 1.5;

vec2 filter_gaussian_sample(vec2 xi)
{
    const float two_pi = 6.28318530717958647692;
    float kept_mass = 1.0 - exp(-FILTER_RADIUS * FILTER_RADIUS / (2.0 * FILTER_SIGMA * FILTER_SIGMA));
    float radius = FILTER_SIGMA * sqrt(max(0.0, -2.0 * log(1.0 - xi.x * kept_mass)));
    float angle = two_pi * xi.y;
    return radius * vec2(cos(angle), sin(angle));
}

// Blackman-Harris of width FILTER_BH_WIDTH pixels, separable (x and y drawn
// independently), as Cycles samples its default filter. Cycles' "1.5 px" is
// the half-width: its filter_table() doubles the width of Blackman-Harris
// before tabulating it over ±width/2, so the window spans ±1.5 px, 3 px in
// all (measured against Cycles 3.4 in bench/quality). On u = x/width + ½
// in [0, 1] the window is a0 − a1 cos 2πu + a2 cos 4πu − a3 cos 6πu; its
// CDF has the closed form below (the cosines integrate to sines, the total
// is a0), inverted by FILTER_BH_BISECTIONS bisection steps (2^-16 of the
// width: far below a pixel; Newton would stall where the window is ~0).
const float FILTER_BH_WIDTH = 3.0;
const uint FILTER_BH_BISECTIONS = 16u;

float filter_blackman_harris_cdf(float u)
{
    const float a0 = 0.35875, a1 = 0.48829, a2 = 0.14128, a3 = 0.01168;
    const float two_pi = 6.28318530717958647692;
    float angle = two_pi * u;
    return (a0 * u - a1 * sin(angle) / two_pi + a2 * sin(2.0 * angle) / (2.0 * two_pi) -
            a3 * sin(3.0 * angle) / (3.0 * two_pi)) / a0;
}

float filter_blackman_harris_1d(float xi)
{
    float low = 0.0, high = 1.0;
    for (uint step = 0u; step < FILTER_BH_BISECTIONS; step++) {
        float middle = 0.5 * (low + high);
        if (filter_blackman_harris_cdf(middle) < xi)
            low = middle;
        else
            high = middle;
    }
    return (0.5 * (low + high) - 0.5) * FILTER_BH_WIDTH;
}

vec2 filter_sample(uint filter_kind, vec2 xi)
{
    if (PIXEL_FILTER != FILTER_FROM_PARAMS)
        filter_kind = PIXEL_FILTER;
    if (filter_kind == FILTER_BOX)
        return xi - 0.5;
    if (filter_kind == FILTER_BLACKMAN_HARRIS)
        return vec2(filter_blackman_harris_1d(xi.x), filter_blackman_harris_1d(xi.y));
    return filter_gaussian_sample(xi);
}

#endif
