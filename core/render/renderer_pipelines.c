/* The renderer's compute pipelines, each made at its first use (render_internal.h). */
#include "render_internal.h"

#include <pthread.h>
#include <stdlib.h>
#include <stdio.h>

/* raycast_brute.comp: constant_id 0 selects the any-hit (shadow) variant. */
#define RAYCAST_SPEC_ANY_HIT 0u
#define RAYCAST_BUFFERS 3u
/* raycast_brute.comp's Push: ray count, triangle range begin/end, carry flag. */
#define RAYCAST_PUSH_BYTES 16u
#define RENDER_DIRECT_BUFFERS (PF_SCENE_BINDING_COUNT + 5u)
#define RENDER_DIRECT_PUSH_BYTES 20u
/* render_reference.comp: constant_id 0 says whether the AOV film is written. */
#define REFERENCE_SPEC_AOVS 0u
#define RENDER_REFERENCE_BUFFERS (PF_SCENE_BINDING_COUNT + 6u)
#define RENDER_REFERENCE_PUSH_BYTES 8u
/* render_final.comp (primary), final_caustic.comp, final_gather.comp,
 * final_gather_estimate.comp, final_deferred.comp and final_resolve.comp: PF_FINAL_BUFFERS
 * buffers and the same 124-byte Push (final_shared.glsl); the primary's and the gathers'
 * constant_id 0 says who traces their rays' first segments (host_rays.glsl: TRACED_HERE
 * 0, WRITE_RAYS 1, HITS_GIVEN 2). */
#define RENDER_FINAL_PUSH_BYTES 124u
#define TRACE_STEP_CONSTANT 0u
/* render_fast.comp, render_fast_caustic.comp and render_fast_energy.comp: PF_FAST_BUFFERS
 * buffers and the same 76-byte Push (fast_shade.glsl). */
#define RENDER_FAST_PUSH_BYTES 76u
/* denoise_variance.comp and denoise_atrous.comp: the same 6 buffers and 16-byte Push
 * (denoise_filter.glsl). */
#define DENOISE_BUFFERS 6u
#define DENOISE_PUSH_BYTES 16u
/* The reference wavefront's modules (reference_wave.glsl): the reference kernel's buffers
 * and 12 of their own, a 20-byte Push, constant_id 0 the mode (render_reference_wave.comp's
 * WAVE_SHADE 0; render_reference_wave_ends.comp's WAVE_GENERATE 1, WAVE_FINISH_RGB 2 and
 * WAVE_FINISH 3; render_reference_wave_tail.comp's WAVE_TAIL 4). */
#define REFERENCE_WAVE_BUFFERS (RENDER_REFERENCE_BUFFERS + 12u)
#define REFERENCE_WAVE_PUSH_BYTES 20u
/* deform.comp: 13 buffers and a 16-byte Push (deform_device.c). */
#define DEFORM_BUFFERS 13u
#define DEFORM_PUSH_BYTES 16u
/* split_film.comp: film, AOV film, a band of the image; Push width, rows, aovs,
 * aov_own_count, row_first. */
#define SPLIT_FILM_BUFFERS 3u
#define SPLIT_FILM_PUSH_BYTES 24u
#define MATERIAL_PROBE_BUFFERS 3u
#define MATERIAL_PROBE_PUSH_BYTES 4u

typedef struct pipeline_spec {
    const char *shader;
    uint32_t buffers, push_bytes;
    int specialized;
    pf_vk_spec_constant constant;
    int surfaces; /* reads the scene's surfaces: has a "_surfaces" variant */
    int camera;   /* samples camera rays: made for the frame's pixel filter */
} pipeline_spec;

static const pipeline_spec pipeline_specs[PF_PIPELINE_COUNT] = {
    [PF_PIPELINE_RAYCAST_CLOSEST] = {"raycast_brute", RAYCAST_BUFFERS, RAYCAST_PUSH_BYTES, 1,
                                     {RAYCAST_SPEC_ANY_HIT, 0}},
    [PF_PIPELINE_RAYCAST_ANY] = {"raycast_brute", RAYCAST_BUFFERS, RAYCAST_PUSH_BYTES, 1,
                                 {RAYCAST_SPEC_ANY_HIT, 1}},
    [PF_PIPELINE_DIRECT] = {"render_direct", RENDER_DIRECT_BUFFERS, RENDER_DIRECT_PUSH_BYTES, 0,
                            {0, 0}, 1, 1},
    [PF_PIPELINE_REFERENCE] = {"render_reference", RENDER_REFERENCE_BUFFERS,
                               RENDER_REFERENCE_PUSH_BYTES, 1, {REFERENCE_SPEC_AOVS, 1}, 1, 1},
    [PF_PIPELINE_REFERENCE_RGB] = {"render_reference", RENDER_REFERENCE_BUFFERS,
                                   RENDER_REFERENCE_PUSH_BYTES, 1, {REFERENCE_SPEC_AOVS, 0}, 1, 1},
    [PF_PIPELINE_MATERIAL_PROBE] = {"material_probe", MATERIAL_PROBE_BUFFERS,
                                    MATERIAL_PROBE_PUSH_BYTES, 0, {0, 0}},
    [PF_PIPELINE_FINAL_PRIMARY] = {"render_final", PF_FINAL_BUFFERS, RENDER_FINAL_PUSH_BYTES,
                                   0, {0, 0}, 1, 1},
    [PF_PIPELINE_FINAL_GATHER] = {"final_gather", PF_FINAL_BUFFERS, RENDER_FINAL_PUSH_BYTES,
                                  0, {0, 0}, 1},
    [PF_PIPELINE_FINAL_GATHER_ESTIMATE] = {"final_gather_estimate", PF_FINAL_BUFFERS,
                                           RENDER_FINAL_PUSH_BYTES, 0, {0, 0}, 1},
    [PF_PIPELINE_FINAL_FALLBACK] = {"final_deferred", PF_FINAL_BUFFERS,
                                    RENDER_FINAL_PUSH_BYTES, 0, {0, 0}, 1},
    [PF_PIPELINE_FINAL_RESOLVE] = {"final_resolve", PF_FINAL_BUFFERS, RENDER_FINAL_PUSH_BYTES,
                                   0, {0, 0}, 1},
    [PF_PIPELINE_FINAL_CAUSTIC] = {"final_caustic", PF_FINAL_BUFFERS, RENDER_FINAL_PUSH_BYTES,
                                   0, {0, 0}, 1},
    [PF_PIPELINE_FINAL_PRIMARY_GIVEN] = {"render_final", PF_FINAL_BUFFERS,
                                         RENDER_FINAL_PUSH_BYTES, 1, {TRACE_STEP_CONSTANT, 2}, 1, 1},
    [PF_PIPELINE_FINAL_GATHER_RAYS] = {"final_gather_rays", PF_FINAL_BUFFERS,
                                       RENDER_FINAL_PUSH_BYTES, 1, {TRACE_STEP_CONSTANT, 1}, 1},
    [PF_PIPELINE_FINAL_GATHER_GIVEN] = {"final_gather", PF_FINAL_BUFFERS,
                                        RENDER_FINAL_PUSH_BYTES, 1, {TRACE_STEP_CONSTANT, 2}, 1},
    [PF_PIPELINE_FINAL_GATHER_ESTIMATE_GIVEN] = {"final_gather_estimate", PF_FINAL_BUFFERS,
                                                 RENDER_FINAL_PUSH_BYTES, 1,
                                                 {TRACE_STEP_CONSTANT, 2}, 1},
    [PF_PIPELINE_CAMERA_RAYS] = {"camera_rays", PF_CAMERA_RAYS_BUFFERS,
                                 sizeof(pf_camera_rays_push), 0, {0, 0}, 0, 1},
    [PF_PIPELINE_FAST] = {"render_fast", PF_FAST_BUFFERS, RENDER_FAST_PUSH_BYTES, 0, {0, 0}, 1, 1},
    [PF_PIPELINE_FAST_CAUSTIC] = {"render_fast_caustic", PF_FAST_BUFFERS, RENDER_FAST_PUSH_BYTES,
                                  0, {0, 0}, 1, 1},
    [PF_PIPELINE_FAST_ENERGY] = {"render_fast_energy", PF_FAST_BUFFERS, RENDER_FAST_PUSH_BYTES,
                                 0, {0, 0}, 1},
    [PF_PIPELINE_DENOISE_VARIANCE] = {"denoise_variance", DENOISE_BUFFERS, DENOISE_PUSH_BYTES, 0,
                                      {0, 0}},
    [PF_PIPELINE_DENOISE_ATROUS] = {"denoise_atrous", DENOISE_BUFFERS, DENOISE_PUSH_BYTES, 0,
                                    {0, 0}},
    [PF_PIPELINE_REFERENCE_WAVE_GENERATE] = {"render_reference_wave_ends", REFERENCE_WAVE_BUFFERS,
                                             REFERENCE_WAVE_PUSH_BYTES, 1, {0, 1}, 1, 1},
    [PF_PIPELINE_REFERENCE_WAVE] = {"render_reference_wave", REFERENCE_WAVE_BUFFERS,
                                    REFERENCE_WAVE_PUSH_BYTES, 1, {0, 0}, 1},
    [PF_PIPELINE_REFERENCE_WAVE_FINISH] = {"render_reference_wave_ends", REFERENCE_WAVE_BUFFERS,
                                           REFERENCE_WAVE_PUSH_BYTES, 1, {0, 3}, 1},
    [PF_PIPELINE_REFERENCE_WAVE_FINISH_RGB] = {"render_reference_wave_ends",
                                               REFERENCE_WAVE_BUFFERS,
                                               REFERENCE_WAVE_PUSH_BYTES, 1, {0, 2}, 1},
    [PF_PIPELINE_REFERENCE_WAVE_TAIL] = {"render_reference_wave_tail", REFERENCE_WAVE_BUFFERS,
                                         REFERENCE_WAVE_PUSH_BYTES, 1, {0, 4}, 1},
    [PF_PIPELINE_DEFORM] = {"deform", DEFORM_BUFFERS, DEFORM_PUSH_BYTES, 0, {0, 0}},
    [PF_PIPELINE_SPLIT_FILM] = {"split_film", SPLIT_FILM_BUFFERS, SPLIT_FILM_PUSH_BYTES, 0,
                                {0, 0}},
    [PF_PIPELINE_FINAL_RETRACE_ARGS] = {"final_retrace_args", 2, 12, 0, {0, 0}},
};

/* Where pipeline id for the current frame lives: its surface features, and its pixel filter
 * (below PF_PIXEL_FILTER_COUNT: run_stages sets it) where it samples the camera (the others
 * share filter 0's slot). */
static pf_vk_pipeline **pipeline_slot(pf_renderer *renderer, pf_renderer_pipeline_id id)
{
    uint32_t filter = pipeline_specs[id].camera ? renderer->pixel_filter : 0u;
    return &renderer->pipelines[filter][renderer->surface_features % PF_SURFACE_VARIANTS][id];
}

pf_status pf_renderer_pipeline(pf_renderer *renderer, pf_renderer_pipeline_id id,
                               pf_vk_pipeline **out, pf_error *err)
{
    if ((unsigned)id >= PF_PIPELINE_COUNT)
        return pf_error_set(err, PF_ERR_INTERNAL, "renderer: no pipeline %d", (int)id);
    uint32_t features = renderer->surface_features % PF_SURFACE_VARIANTS;
    pf_vk_pipeline **slot = pipeline_slot(renderer, id);
    if (!*slot) {
        const pipeline_spec *spec = &pipeline_specs[id];
        pf_vk_spec_constant constants[PF_SCENE_SPEC_CONSTANTS + 2];
        uint32_t ids[PF_SCENE_SPEC_CONSTANTS], values[PF_SCENE_SPEC_CONSTANTS];
        pf_scene_spec_constants(features, ids, values);
        uint32_t count = 0;
        for (uint32_t c = 0; c < PF_SCENE_SPEC_CONSTANTS; c++)
            constants[count++] = (pf_vk_spec_constant){ids[c], values[c]};
        if (spec->camera)
            constants[count++] = (pf_vk_spec_constant){PF_SPEC_PIXEL_FILTER,
                                                       renderer->pixel_filter};
        if (spec->specialized)
            constants[count++] = spec->constant;
        /* The kernel's "_surfaces" variant where the frame uses them (pf_scene.h). */
        char name[64];
        snprintf(name, sizeof name, "%s%s", spec->shader,
                 (features & PF_SURFACE_TEXTURED) && spec->surfaces ? "_surfaces" : "");
        pf_status status = pf_vk_pipeline_create_named(renderer->ctx, name, spec->buffers,
                                                       spec->push_bytes, constants, count, slot,
                                                       err);
        if (status != PF_OK)
            return status;
    }
    *out = *slot;
    return PF_OK;
}

/* One pipeline created on a thread of its own (pf_renderer_pipelines_prepare). */
typedef struct pipeline_job {
    pf_renderer *renderer;
    pf_renderer_pipeline_id id;
    pthread_t thread;
    int started;
    pf_status status;
    pf_error err;
} pipeline_job;

static void *pipeline_job_run(void *arg)
{
    pipeline_job *job = arg;
    pf_vk_pipeline *unused;
    job->status = pf_renderer_pipeline(job->renderer, job->id, &unused, &job->err);
    return NULL;
}

pf_status pf_renderer_pipelines_prepare(pf_renderer *renderer, const pf_renderer_pipeline_id *ids,
                                        size_t count, pf_error *err)
{
    pipeline_job jobs[PF_PIPELINE_COUNT];
    size_t missing = 0;
    for (size_t i = 0; i < count && missing < PF_PIPELINE_COUNT; i++) {
        if ((unsigned)ids[i] >= PF_PIPELINE_COUNT)
            return pf_error_set(err, PF_ERR_INTERNAL, "renderer: no pipeline %d", (int)ids[i]);
        int listed = *pipeline_slot(renderer, ids[i]) != NULL;
        for (size_t j = 0; j < missing; j++)
            listed = listed || jobs[j].id == ids[i];
        if (!listed)
            jobs[missing++] = (pipeline_job){.renderer = renderer, .id = ids[i]};
    }
    /* All but the first on threads of their own, the first on this one; a thread that cannot
     * be started leaves its pipeline to this thread too. */
    for (size_t j = 1; j < missing; j++)
        jobs[j].started = pthread_create(&jobs[j].thread, NULL, pipeline_job_run, &jobs[j]) == 0;
    for (size_t j = 0; j < missing; j++) {
        if (j == 0 || !jobs[j].started)
            pipeline_job_run(&jobs[j]);
    }
    pf_status status = PF_OK;
    for (size_t j = 0; j < missing; j++) {
        if (jobs[j].started)
            pthread_join(jobs[j].thread, NULL);
        if (status == PF_OK && jobs[j].status != PF_OK) {
            status = jobs[j].status;
            *err = jobs[j].err;
        }
    }
    return status;
}
