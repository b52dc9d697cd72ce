#version 460
#extension GL_GOOGLE_include_directive : require
// Textures as the renderer reads them (shaders/common/scene_textures.glsl):
// every mip chain of every texture in one R32_UINT texel buffer of RGBA8
// words, bilinear within a level, repeat wrap and the sRGB decode in GLSL:
// by the formula (pow per channel per texel, as the renderer does), or, in
// the _table variant, from a 256-entry table each workgroup fills first.
// pf-variant: table PF_SRGB_TABLE
#include "texture_fetch_common.glsl"

layout(set = 0, binding = 1) uniform usamplerBuffer texels;

float srgb_formula(float c)
{
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

#ifdef PF_SRGB_TABLE
shared float srgb_table[256];

void prepare()
{
    for (uint i = gl_LocalInvocationID.x; i < 256u; i += gl_WorkGroupSize.x)
        srgb_table[i] = srgb_formula(float(i) / 255.0);
    barrier();
}

float srgb_to_linear(float c)
{
    return srgb_table[uint(c * 255.0 + 0.5)];
}
#else
void prepare()
{
}

float srgb_to_linear(float c)
{
    return srgb_formula(c);
}
#endif

int wrap(int x, int n)
{
    float fx = float(x), fn = float(n);
    return clamp(int(fx - fn * floor(fx / fn)), 0, n - 1);
}

vec4 texel(uint first, int size, ivec2 xy)
{
    vec4 c = unpackUnorm4x8(texelFetch(texels, int(first) + wrap(xy.y, size) * size +
                                                   wrap(xy.x, size)).x);
    return vec4(srgb_to_linear(c.r), srgb_to_linear(c.g), srgb_to_linear(c.b), c.a);
}

vec4 fetch(uint texture_index, vec2 uv, uint level)
{
    // The chains are laid out one after another; a chain of edge² texels and its mips.
    uint chain = 0u;
    int size = int(push.edge);
    for (uint k = 0u; k < push.levels; k++) {
        chain += uint(size * size);
        size = max(size / 2, 1);
    }
    uint first = texture_index * chain;
    size = int(push.edge);
    for (uint k = 0u; k < level; k++) {
        first += uint(size * size);
        size = max(size / 2, 1);
    }
    vec2 p = uv * float(size) - 0.5;
    ivec2 i = ivec2(floor(p));
    vec2 f = p - floor(p);
    vec4 a = mix(texel(first, size, i), texel(first, size, i + ivec2(1, 0)), f.x);
    vec4 b = mix(texel(first, size, i + ivec2(0, 1)), texel(first, size, i + ivec2(1, 1)), f.x);
    return mix(a, b, f.y);
}
