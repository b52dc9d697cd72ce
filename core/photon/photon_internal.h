/*
 * What photon_trace.c and photon_trace_wave.c share (not part of the module's
 * interface, pf_photon.h): photon_path.glsl's parameters, push constants,
 * counters and bindings, and its pipelines.
 */
#ifndef PF_PHOTON_INTERNAL_H
#define PF_PHOTON_INTERNAL_H

#include "pf_photon.h"

/* The photon modules' bindings (photon_path.glsl): the scene's, the tree's three, the two
 * maps, the counters, then the waves' seven (state, rays, hits, queue, active; state and rays
 * as texel views). */
#define TRACE_COUNTERS (PF_SCENE_BINDING_COUNT + 5u)
#define TRACE_BUFFERS (PF_SCENE_BINDING_COUNT + 13u)
/* photon_path.glsl's PHOTON_STEP specialisation constant; its modules by step: photon_trace.comp
 * (the flat loop), photon_wave_emit.comp, photon_wave_bounce.comp. */
#define PHOTON_STEP_CONSTANT 0u

typedef enum pf_photon_step {
    PF_PHOTON_TRACED_HERE = 0, /* the flat loop: the device traces every ray */
    PF_PHOTON_EMIT = 1,        /* the waves: a batch's photons emitted, their first rays */
    PF_PHOTON_BOUNCE = 2,      /* the waves: a bounce at each hit the host traced */
    PF_PHOTON_STEPS
} pf_photon_step;

/* PhotonTraceParams in photon_path.glsl (std430, 128 bytes). */
typedef struct photon_trace_params {
    float bih_bounds_min[4];
    float bih_bounds_max[4];
    float scene_sphere[4];
    uint32_t photon_count;
    uint32_t emitter_count;
    uint32_t store_direct;
    uint32_t triangle_count;
    uint32_t bih_node_count;
    uint32_t seed_lo, seed_hi;
    uint32_t max_depth;
    uint32_t global_capacity;
    uint32_t caustic_capacity;
    float ray_offset;
    uint32_t global_reflected;
    float arrival_box_min[4]; /* xyz; an empty box counts no arrival */
    float arrival_box_max[4];
} photon_trace_params;

typedef struct trace_counters {
    uint32_t global_stored;
    uint32_t caustic_stored;
    uint32_t traversal_failures;
    uint32_t non_finite;
    uint32_t loop_truncated;
    /* By facing direction, 2^-16 flux units, low word at 2d (count_arrival). */
    uint32_t arrivals[2 * PF_PHOTON_ARRIVAL_DIRECTIONS];
} trace_counters;

/* photon_path.glsl's Push. */
typedef struct trace_push {
    uint32_t first_photon;
    uint32_t photon_count;
    uint32_t photon_stride;
    uint32_t loop_sentinel;
} trace_push;

/* What a trace uploads before its dispatches: recorded with them (issue 44). */
typedef struct trace_uploads {
    const photon_trace_params *params;
    const pf_photon_emitters *emitters;
    pf_vk_buffer *placeholder; /* zeroed: the texture bindings of a scene without them */
} trace_uploads;

/* The kernel of a step for a scene with these surface features, made at first use. */
pf_status pf_photon_trace_pipeline(pf_photon_tracer *tracer, pf_photon_step step,
                                   uint32_t features, pf_vk_pipeline **out, pf_error *err);
/* Records the uploads and the counters' zeroing into cmds. */
pf_status pf_photon_trace_uploads(pf_vk_commands *cmds, pf_vk_buffer *const *buffers,
                                  const trace_uploads *uploads, pf_error *err);
/*
 * Traces count photons into the maps bound in buffers (photon_trace_wave.c): in waves of a
 * bounce each, their rays traced by the host through host_tree between them. Reads back the
 * counters; adds the GPU time, the waves and the host's trace time to out.
 */
pf_status pf_photon_trace_waves(pf_vk_context *ctx, pf_photon_tracer *tracer, uint32_t features,
                                pf_vk_buffer *const *buffers, const trace_uploads *uploads,
                                const pf_bih *host_tree, const pf_bih_wide *host_wide,
                                uint32_t count, trace_counters *counters, pf_photon_maps *out,
                                pf_error *err);

#endif
