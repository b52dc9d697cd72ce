/*
 * The denoise stage's filter on the device (issue 40): the variance estimate and the five
 * à-trous passes of denoise.c as compute kernels (shaders/denoise_variance.comp,
 * shaders/denoise_atrous.comp), recorded in one submission with the uploads before them and
 * the readbacks after, so the stage waits for the device once. The temporal blend runs on
 * the host before it (denoise_temporal.c: a gather from the history's few taps per pixel,
 * under a millisecond at 160×120), and so does the write-back into the image.
 */
#include "denoise_internal.h"
#include "render_internal.h"

#include <stdlib.h>
#include <string.h>

#define DENOISE_GROUP 8u
#define DENOISE_DEVICE_BUFFERS 6u

/* The host's planes as the kernels' vec4 and vec2 arrays, and the result back. */
typedef struct repack_job {
    denoise_planes *planes;
    const float *noisy;
    float *noisy4, *guides, *aux, *lit;
} repack_job;

static void repack_rows(void *context, uint64_t begin, uint64_t end)
{
    const repack_job *job = context;
    const denoise_planes *planes = job->planes;
    for (size_t p = (size_t)begin * planes->width; p < (size_t)end * planes->width; p++) {
        for (int c = 0; c < 3; c++) {
            if (job->noisy4)
                job->noisy4[4 * p + c] = job->noisy[3 * p + c];
            job->guides[4 * p + c] = planes->normal[3 * p + c];
            job->lit[4 * p + c] = planes->lighting[3 * p + c];
        }
        if (job->noisy4)
            job->noisy4[4 * p + 3] = 0.0f;
        job->guides[4 * p + 3] = planes->depth[p];
        job->lit[4 * p + 3] = 0.0f;
        job->aux[2 * p] = planes->depth_step[p];
        job->aux[2 * p + 1] = planes->variance_factor[p];
    }
}

static void unpack_rows(void *context, uint64_t begin, uint64_t end)
{
    const repack_job *job = context;
    denoise_planes *planes = job->planes;
    for (size_t p = (size_t)begin * planes->width; p < (size_t)end * planes->width; p++) {
        memcpy(planes->lighting + 3 * p, job->lit + 4 * p, 3 * sizeof(float));
        planes->variance[p] = job->lit[4 * p + 3];
    }
}

pf_status denoise_device_filter(pf_renderer *renderer, denoise_planes *planes,
                                const float *noisy, int passes, float *estimate,
                                double *gpu_ms, pf_error *err)
{
    pf_vk_context *ctx = pf_renderer_context(renderer);
    size_t pixels = (size_t)planes->width * planes->height;
    *gpu_ms = -1.0;
    pf_vk_pipeline *variance_kernel = NULL, *atrous_kernel = NULL;
    pf_status status = pf_renderer_pipeline(renderer, PF_PIPELINE_DENOISE_VARIANCE,
                                            &variance_kernel, err);
    if (status == PF_OK)
        status = pf_renderer_pipeline(renderer, PF_PIPELINE_DENOISE_ATROUS, &atrous_kernel, err);
    if (status != PF_OK)
        return status;
    /* Without a blend the noisy lighting is the lighting: the variance kernel reads it from
     * lighting a, whose W alone it writes (a 1080p frame's 33 MB less to upload). */
    float *noisy4 = noisy ? malloc(4 * pixels * sizeof(float)) : NULL;
    float *guides = malloc(4 * pixels * sizeof(float));
    float *aux = malloc(2 * pixels * sizeof(float));
    float *lit = malloc(4 * pixels * sizeof(float));
    if ((noisy && !noisy4) || !guides || !aux || !lit) {
        free(noisy4);
        free(guides);
        free(aux);
        free(lit);
        return pf_error_set(err, PF_ERR_NOMEM, "denoise: out of memory for the device's copy");
    }
    repack_job repack = {planes, noisy, noisy4, guides, aux, lit};
    pf_run_ranges(planes->height, DENOISE_MAX_THREADS, 1, repack_rows, &repack);
    pf_vk_commands *cmds = NULL;
    pf_vk_buffer *buffers[DENOISE_DEVICE_BUFFERS] = {0};
    static const char *const labels[DENOISE_DEVICE_BUFFERS] = {
        "denoise noisy", "denoise guides", "denoise aux", "denoise lighting a",
        "denoise lighting b", "denoise estimate"};
    const void *data[DENOISE_DEVICE_BUFFERS] = {noisy4, guides, aux, lit, NULL, NULL};
    const uint64_t bytes[DENOISE_DEVICE_BUFFERS] = {
        16 * pixels, 16 * pixels, 8 * pixels, 16 * pixels, 16 * pixels, 4 * pixels};
    status = pf_vk_commands_begin(ctx, &cmds, err);
    for (int b = noisy ? 0 : 1; status == PF_OK && b < (int)DENOISE_DEVICE_BUFFERS; b++)
        status = pf_render_buffer_recorded(ctx, cmds, labels[b], data[b],
                                           data[b] ? bytes[b] : 0, bytes[b], &buffers[b], err);
    if (!noisy)
        buffers[0] = buffers[3];
    uint32_t push[4] = {planes->width, planes->height, 0, 0};
    uint32_t groups_x = (planes->width + DENOISE_GROUP - 1) / DENOISE_GROUP;
    uint32_t groups_y = (planes->height + DENOISE_GROUP - 1) / DENOISE_GROUP;
    int begin = status == PF_OK ? pf_vk_cmd_timestamp(cmds) : -1;
    if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, variance_kernel, buffers, DENOISE_DEVICE_BUFFERS, push,
                                    sizeof push, groups_x, groups_y, 1, err);
    for (int pass = 0; status == PF_OK && pass < passes; pass++) {
        pf_vk_cmd_barrier(cmds);
        push[2] = 1u << pass;
        push[3] = (uint32_t)(pass & 1); /* A → B, then back */
        status = pf_vk_cmd_dispatch(cmds, atrous_kernel, buffers, DENOISE_DEVICE_BUFFERS, push,
                                    sizeof push, groups_x, groups_y, 1, err);
    }
    int end = status == PF_OK ? pf_vk_cmd_timestamp(cmds) : -1;
    if (status == PF_OK)
        pf_vk_cmd_barrier(cmds);
    /* An odd number of passes ends in B, an even one in A. */
    pf_vk_buffer *result = buffers[(passes & 1) ? 4 : 3];
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, result, 0, lit, 16 * pixels, err);
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, buffers[5], 0, estimate, 4 * pixels, err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    if (status == PF_OK)
        *gpu_ms = pf_commands_gpu_ms(cmds, begin, end);
    if (status == PF_OK)
        pf_run_ranges(planes->height, DENOISE_MAX_THREADS, 1, unpack_rows, &repack);
    if (cmds)
        pf_vk_commands_destroy(cmds);
    if (!noisy)
        buffers[0] = NULL; /* lighting a's, released once */
    for (int b = 0; b < (int)DENOISE_DEVICE_BUFFERS; b++)
        pf_render_buffer_release(ctx, &buffers[b]);
    free(noisy4);
    free(guides);
    free(aux);
    free(lit);
    return status;
}
