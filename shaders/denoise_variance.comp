#version 460
#extension GL_GOOGLE_include_directive : require
// The denoise stage's variance estimate on the device (core/render/denoise.c's
// estimate_variance): per pixel the smallest of the guided luminance variances of the four
// 4×4 windows with the pixel in a corner, times the temporal blend's factor, into lit_a's W
// and the estimate.

#include "denoise_filter.glsl"

#define DENOISE_VARIANCE_RADIUS 3

void main()
{
    uvec2 at = gl_GlobalInvocationID.xy;
    if (at.x >= push.width || at.y >= push.height)
        return;
    int w = int(push.width), h = int(push.height), x = int(at.x), y = int(at.y);
    uint p = uint(y * w + x);
    float smallest = 1.0 / 0.0;
    for (int quadrant = 0; quadrant < 4; quadrant++) {
        int sx = (quadrant & 1) != 0 ? 1 : -1, sy = (quadrant & 2) != 0 ? 1 : -1;
        float sum = 0.0, sum2 = 0.0, weights = 0.0;
        int taps = 0;
        for (int j = 0; j <= DENOISE_VARIANCE_RADIUS; j++)
            for (int i = 0; i <= DENOISE_VARIANCE_RADIUS; i++) {
                int qx = x + sx * i, qy = y + sy * j;
                if (qx < 0 || qy < 0 || qx >= w || qy >= h)
                    continue;
                uint q = uint(qy * w + qx);
                float weight =
                    q == p ? 1.0 : denoise_geometry_weight(p, q, sqrt(float(i * i + j * j)));
                float l = denoise_luminance(noisy[q].rgb);
                sum += weight * l;
                sum2 += weight * l * l;
                weights += weight;
                taps += weight > 0.5 ? 1 : 0;
            }
        if (taps < 4)
            continue; // a quadrant cut off by the border or the geometry says little
        float mean = sum / weights;
        smallest = min(smallest, max(0.0, sum2 / weights - mean * mean));
    }
    float variance = isinf(smallest) ? 0.0 : smallest * aux[p].y;
    lit_a[p].w = variance;
    estimate[p] = variance;
}
