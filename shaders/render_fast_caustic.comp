#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// The `fast` shade kernel with the caustic map's estimate (fast_shade.glsl).
#define FAST_CAUSTICS
#include "fast_shade.glsl"
