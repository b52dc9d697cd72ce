#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// final's gather rays' first segments for the host to trace (final_gather.glsl's
// WRITE_RAYS), in a module without the gather itself: llvmpipe builds a
// pipeline from its whole module before specialising it (~0.5 s for the
// textured gather's, against a few tens of ms for this).
#define FINAL_GATHER_RAYS_ONLY
#include "final_gather.glsl"
