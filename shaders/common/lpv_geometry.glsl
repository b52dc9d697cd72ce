// The LPV geometry volume at the face between two LPV cells, shared by the
// propagation (lpv_propagate.comp: blocking of the flux crossing it) and
// the lookup (lpv_lookup.glsl: no interpolation across a wall).
//
// The including shader declares lpv_geometry_texels, a samplerBuffer of the
// geometry volumes (three RGBA32F texels of SH coefficients per cell, one
// per axis: the surfaces around the cell's lower face normal to that axis;
// cascade after cascade; core/lpv/pf_lpv.h). A texel buffer, not a storage
// buffer: llvmpipe loads a storage buffer lane by lane in a branchy loop and
// a texel fetch as one gather (bench/RESULTS.md, "The storage-buffer loads").
#ifndef PF_LPV_GEOMETRY_GLSL
#define PF_LPV_GEOMETRY_GLSL

// The face between LPV cells d and d − s·e_k: d's lower face (s > 0) or
// the lower face of d + e_k (s < 0); none outside the volume.
vec4 lpv_face_geometry(ivec3 d, int k, int s, uint base, uint size)
{
    ivec3 g = d;
    if (s < 0)
        g[k] += 1;
    if (any(lessThan(g, ivec3(0))) || any(greaterThanEqual(g, ivec3(size))))
        return vec4(0.0);
    uint cell = base + (uint(g.z) * size + uint(g.y)) * size + uint(g.x);
    return texelFetch(lpv_geometry_texels, int(3u * cell + uint(k)));
}

#endif
