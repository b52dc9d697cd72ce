// The denoise stage's device kernels (denoise_variance.comp, denoise_atrous.comp): their
// bindings and the edge-stopping weights, the same arithmetic as core/render/denoise.c's
// host filter (whose comment explains the method). One pixel per invocation.

layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant) uniform Push {
    uint width;
    uint height;
    uint step;      // the à-trous pass's spread in pixels (denoise_atrous)
    uint direction; // 0: read lit_a, write lit_b; 1: the other way (denoise_atrous)
} push;

// This frame's own demodulated lighting (RGB; the variance is estimated from it).
layout(std430, set = 0, binding = 0) readonly buffer Noisy { vec4 noisy[]; };
// Normal (XYZ) and depth (W, 0: nothing seen).
layout(std430, set = 0, binding = 1) readonly buffer Guides { vec4 guides[]; };
// The depth's change per pixel (X) and the temporal blend's variance factor (Y).
layout(std430, set = 0, binding = 2) readonly buffer Aux { vec2 aux[]; };
// The lighting the filter works on (RGB, blended with history where that held) and its
// variance (W); the passes go back and forth between the two.
layout(std430, set = 0, binding = 3) buffer LitA { vec4 lit_a[]; };
layout(std430, set = 0, binding = 4) buffer LitB { vec4 lit_b[]; };
// The variance the filter started from (the EXR's variance.Y).
layout(std430, set = 0, binding = 5) writeonly buffer Estimate { float estimate[]; };

#define DENOISE_NORMAL_SQUARINGS 7
#define DENOISE_SIGMA_LUMINANCE 4.0

float denoise_luminance(vec3 rgb)
{
    return 0.2126 * rgb.r + 0.7152 * rgb.g + 0.0722 * rgb.b;
}

// Normal and depth weight of tap q for pixel p, offset pixels apart.
float denoise_geometry_weight(uint p, uint q, float offset)
{
    vec4 gp = guides[p], gq = guides[q];
    float zp = gp.w, zq = gq.w;
    if ((zp > 0.0) != (zq > 0.0))
        return 0.0;
    if (zp == 0.0)
        return 1.0; // both see nothing
    float w_normal = max(dot(gp.xyz, gq.xyz), 0.0);
    for (int k = 0; k < DENOISE_NORMAL_SQUARINGS; k++)
        w_normal *= w_normal;
    float w_depth = exp(-abs(zp - zq) / (aux[p].x * offset + 1e-3 * zp));
    return w_normal * w_depth;
}
