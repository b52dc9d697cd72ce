/*
 * Helpers shared by the photon tests: a closed diffuse box of 12 triangles
 * (plus a few more), traced on the GPU as the renderer would (the scene's
 * buffers and its BIH uploaded), and the stored flux of a map.
 */
#ifndef PHOTON_TEST_BOX_H
#define PHOTON_TEST_BOX_H

#include "pf_photon.h"

typedef struct box_scene {
    pf_scene_frame frame;
    float vertices[60][4];
    float normals[60][4];
    uint32_t triangle_material[20];
    pf_material materials[2];
    pf_light lights[2];
} box_scene;

/* What tracing needs, created once per test program. */
typedef struct box_tracer {
    pf_vk_context *ctx;
    pf_photon_tracer *tracer;
    pf_bih_gpu *bih_gpu;
    int host_traces; /* box_trace: the host traces the rays, through the scene's CPU tree */
} box_tracer;

/* Appends the quad a b c d (two triangles) with material. */
void box_add_quad(box_scene *s, const float a[3], const float b[3], const float c[3],
                  const float d[3], uint32_t material);

/* The closed cube [-1, 1]³ with material 0 (Lambert, albedo), material 1 a mirror, no lights. */
void box_init(box_scene *s, float albedo);

/*
 * Uploads the scene and its BIH, traces one pass and downloads both maps
 * (global and caustic may be NULL: not downloaded). maps must be released
 * by the caller when this returns PF_OK.
 */
pf_status box_trace(box_tracer *t, const box_scene *s, const pf_photon_trace_settings *settings,
                    pf_photon_maps *maps, pf_photon **global, pf_photon **caustic, pf_error *err);

/* Σ flux × scale over photons (W per channel). */
void box_flux_sum(const pf_photon *photons, uint32_t count, double scale, double sum[3]);

#endif
