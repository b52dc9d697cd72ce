#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// The `fast` shade kernel of frames without caustic photons (fast_shade.glsl).
#include "fast_shade.glsl"
