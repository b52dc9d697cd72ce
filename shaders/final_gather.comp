#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// The `final` gather with deferred estimates (final_gather.glsl).
#include "final_gather.glsl"
