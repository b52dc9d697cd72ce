#version 460
#extension GL_GOOGLE_include_directive : require
// One à-trous pass of the denoise stage on the device (core/render/denoise.c's atrous_rows):
// the 5×5 B3-spline kernel spread push.step pixels, weighted by the normal, depth and
// variance-scaled luminance guides, from one lighting buffer into the other, the variance
// carried along.

#include "denoise_filter.glsl"

const float b3[5] = float[5](1.0 / 16.0, 1.0 / 4.0, 3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0);

vec4 source(uint q)
{
    return push.direction == 0u ? lit_a[q] : lit_b[q];
}

// The 3×3 Gaussian of the variance at (x, y) (SVGF: a steadier edge-stopping scale).
float blurred_variance(int x, int y, int w, int h)
{
    float sum = 0.0, weights = 0.0;
    for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++) {
            int qx = x + dx, qy = y + dy;
            if (qx < 0 || qy < 0 || qx >= w || qy >= h)
                continue;
            int ring = abs(dx) + abs(dy);
            float k = ring == 0 ? 0.25 : ring == 1 ? 0.125 : 0.0625;
            sum += k * source(uint(qy * w + qx)).w;
            weights += k;
        }
    return sum / weights;
}

void main()
{
    uvec2 at = gl_GlobalInvocationID.xy;
    if (at.x >= push.width || at.y >= push.height)
        return;
    int w = int(push.width), h = int(push.height), x = int(at.x), y = int(at.y);
    int step = int(push.step);
    uint p = uint(y * w + x);
    float lp = denoise_luminance(source(p).rgb);
    float scale = DENOISE_SIGMA_LUMINANCE * sqrt(blurred_variance(x, y, w, h)) + 1e-6;
    vec3 sum = vec3(0.0);
    float variance = 0.0, weights = 0.0;
    for (int j = -2; j <= 2; j++)
        for (int i = -2; i <= 2; i++) {
            int qx = x + i * step, qy = y + j * step;
            if (qx < 0 || qy < 0 || qx >= w || qy >= h)
                continue;
            uint q = uint(qy * w + qx);
            vec4 tap = source(q);
            float weight = b3[i + 2] * b3[j + 2];
            if (q != p) {
                float offset = float(step) * sqrt(float(i * i + j * j));
                weight *= denoise_geometry_weight(p, q, offset) *
                          exp(-abs(lp - denoise_luminance(tap.rgb)) / scale);
            }
            sum += weight * tap.rgb;
            variance += weight * weight * tap.w;
            weights += weight;
        }
    vec4 result = vec4(sum / weights, variance / (weights * weights));
    if (push.direction == 0u)
        lit_b[p] = result;
    else
        lit_a[p] = result;
}
