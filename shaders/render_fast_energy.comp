#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// The energy `fast`'s light propagation volumes deliver to the frame's diffuse surfaces
// (fast_shade.glsl, FAST_ENERGY): the shade kernels' bindings, so one set serves all three.
#define FAST_ENERGY
#include "fast_shade.glsl"
