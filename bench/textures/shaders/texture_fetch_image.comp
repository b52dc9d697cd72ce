#version 460
#extension GL_GOOGLE_include_directive : require
// Textures as a sampled image: every texture a layer of one R8G8B8A8_SRGB
// array image with its mip chain (a per-lane index into an array of
// descriptors needs shaderSampledImageArrayNonUniformIndexing, which
// lavapipe 22.3 lacks; a layer is a coordinate, legal per lane), bilinear
// within the level, repeat wrap and the sRGB decode by the sampler.
#include "texture_fetch_common.glsl"

layout(set = 0, binding = 1) uniform sampler2DArray images;

void prepare()
{
}

vec4 fetch(uint texture_index, vec2 uv, uint level)
{
    return textureLod(images, vec3(uv, float(texture_index)), float(level));
}
