// Radiance estimates from a photon grid (Jensen 2001, ch. 7), the code every
// integrator that reads photon maps uses.
//
// The including shader declares, before including this file:
//   buffer ... { uint grid_words[]; };    // photons in cell order (PHOTON_WORDS each)
//   buffer ... { uvec2 grid_ranges[]; };  // [start, end) per cell key
// and includes photon_types.glsl and photon_grid.glsl (or photon_grid_push.glsl).
//
// A photon counts at a surface point x with normal n only if it arrived from
// n's side (incoming · n < 0) and was stored on a surface facing the same
// way (its normal · n >= PHOTON_NORMAL_AGREEMENT): photons from the other
// side of a thin wall or round a corner would leak light (REFERENCE.md).
#ifndef PF_PHOTON_ESTIMATE_GLSL
#define PF_PHOTON_ESTIMATE_GLSL

#include "materials.glsl"

// cos 25°: wider than the 8-bit normal quantisation (< 1°), narrow enough
// that a wall meeting the floor (90°) never shares photons with it.
const float PHOTON_NORMAL_AGREEMENT = 0.9063;
// Cone filter (Jensen 2001, eq. 7.8): weight 1 − d/(k r), normalised by
// 1 − 2/(3k); k = 1.1 as REFERENCE.md gives.
const float PHOTON_CONE_K = 1.1;
const float PHOTON_CONE_NORMALISATION = 1.0 - 2.0 / (3.0 * PHOTON_CONE_K);

Photon grid_photon(uint i)
{
    uint base = PHOTON_WORDS * i;
    return photon_unpack(grid_words[base], grid_words[base + 1u], grid_words[base + 2u],
                         grid_words[base + 3u], grid_words[base + 4u]);
}

bool photon_accepted(Photon photon, vec3 normal)
{
    return dot(photon.incoming, normal) < 0.0 &&
           dot(photon.normal, normal) >= PHOTON_NORMAL_AGREEMENT;
}

// Irradiance at x (flux-scale units per m²) from the photons within radius
// (<= the grid's build radius), cone-filtered.
vec3 photon_irradiance(vec3 x, vec3 normal, float radius, PhotonGrid grid)
{
    uint keys[PHOTON_GRID_MAX_KEYS];
    uint key_count = photon_grid_candidate_keys(x, radius, grid, keys);
    vec3 sum = vec3(0.0);
    float radius2 = radius * radius;
    for (uint k = 0u; k < key_count; k++) {
        uvec2 range = grid_ranges[keys[k]];
        for (uint i = range.x; i < range.y; i++) {
            Photon photon = grid_photon(i);
            vec3 d = photon.position - x;
            float distance2 = dot(d, d);
            if (distance2 > radius2 || !photon_accepted(photon, normal))
                continue;
            sum += photon.flux * (1.0 - sqrt(distance2) / (PHOTON_CONE_K * radius));
        }
    }
    return sum / (PHOTON_CONE_NORMALISATION * PI * radius2);
}

#endif
