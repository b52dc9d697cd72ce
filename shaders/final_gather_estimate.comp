#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// The `final` gather with its estimates in place, and the retrace of the
// rays final_gather.comp could not defer (final_gather.glsl).
#define FINAL_GATHER_ESTIMATES
#include "final_gather.glsl"
