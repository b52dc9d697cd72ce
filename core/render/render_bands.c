/*
 * A frame whose film exceeds one device buffer, rendered in bands of rows (pf_render_preset).
 *
 * fast's, final's and reference's film (48 bytes a pixel: three vec4 of sums) and their other
 * per-pixel buffers, none larger, are each one storage buffer that their kernels bind whole,
 * and a device binds at most maxStorageBufferRange bytes of one: lavapipe 128 MiB, which a
 * 2560x1440 film (169 MiB) or a 3840x2160 one (380 MiB) exceeds. Such a frame is rendered as
 * bands of whole rows, each band a render of its own (pf_render_band) with its own film, the
 * bands as even as the rows allow. A band renders with the whole image's camera, samples'
 * seeds and size-dependent decisions (pf_render_settings.band_*), so its rows are those the
 * whole image would have. What does not depend on the image (the tree, the photon maps, the
 * LPV) the first band makes and the later ones reuse through the renderer's stage memory, as
 * a next frame would; the renderer counts the bands as one frame.
 *
 * The image is the bands' rows joined. The report keeps one row a stage, the first band's
 * (its decisions and reasons are the frame's), with the later bands' wall and GPU times and
 * their counts of work and traffic added (BAND_SUMMED); the shade row says how many bands.
 * A time budget is the first band's share of it, and the later bands render the samples
 * (final: passes) the first reached, so that no seam shows between them.
 */
#include "render_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Bytes a pixel of the largest per-pixel buffer the split integrators keep: the film. */
#define BAND_FILM_BYTES_PER_PIXEL ((uint64_t)PF_SPLIT_FILM_VEC4_PER_PIXEL * 16u)

/* Counters that count a band's work or traffic, summed over the bands; every other counter
 * (samples per pixel, radii, sites, threads) is the first band's, which the others share. */
static const char *const BAND_SUMMED[] = {
    "paths", "rays", "pixels", "discarded_samples", "loop_truncated", "gather_dropped",
    "deferred_estimates", "deferred_overflow", "host_traces", "host_trace_ms", "waves",
    "tail_paths", "submits", "host_waits", "readback_bytes", "upload_bytes", "wait_ms",
    "allocate_ms", "copy_ms", "gpu_ms_map_grid", "gpu_ms_irradiance_points"};

void pf_renderer_set_band_bytes(pf_renderer *renderer, uint64_t film_bytes)
{
    renderer->band_bytes = film_bytes;
}

uint64_t pf_renderer_buffer_limit(const pf_renderer *renderer)
{
    uint64_t limit = pf_vk_info(renderer->ctx)->max_storage_buffer_range;
    return renderer->band_bytes && renderer->band_bytes < limit ? renderer->band_bytes : limit;
}

uint32_t pf_render_band_rows(const pf_renderer *renderer, const pf_render_settings *settings)
{
    if (settings->quality == PF_QUALITY_PREVIEW) /* tiles of its own, no film of the image */
        return settings->height;
    uint64_t limit = pf_renderer_buffer_limit(renderer);
    uint64_t row_bytes = (uint64_t)settings->width * BAND_FILM_BYTES_PER_PIXEL;
    uint64_t fits = limit / row_bytes; /* ≥ 1: a 16384-pixel row is 768 KiB */
    if (fits == 0)
        fits = 1;
    if (fits >= settings->height)
        return settings->height;
    uint64_t bands = (settings->height + fits - 1) / fits;
    return (uint32_t)((settings->height + bands - 1) / bands);
}

static int summed(const char *name)
{
    for (size_t i = 0; i < sizeof BAND_SUMMED / sizeof *BAND_SUMMED; i++)
        if (!strcmp(name, BAND_SUMMED[i]))
            return 1;
    return 0;
}

/* Adds a later band's row to the frame's row of the same stage (from first on), or appends
 * it where the first band had none. */
static void merge_row(pf_frame_report *report, uint32_t first, const pf_stage_timing *part)
{
    pf_stage_timing *row = NULL;
    for (uint32_t i = first; i < report->stage_count && !row; i++)
        if (!strcmp(report->stages[i].stage, part->stage))
            row = &report->stages[i];
    if (!row) {
        pf_stage_timing *added = pf_frame_report_add(report, part->stage);
        if (added)
            *added = *part;
        return;
    }
    row->wall_ms += part->wall_ms;
    if (part->gpu_ms >= 0.0)
        row->gpu_ms = (row->gpu_ms > 0.0 ? row->gpu_ms : 0.0) + part->gpu_ms;
    for (uint32_t c = 0; c < part->counter_count; c++) {
        const pf_stage_counter *counter = &part->counters[c];
        if (!summed(counter->name))
            continue;
        uint32_t k = 0;
        while (k < row->counter_count && strcmp(row->counters[k].name, counter->name))
            k++;
        if (k < row->counter_count)
            row->counters[k].value += counter->value;
        else
            pf_stage_add_counter(row, counter->name, counter->value);
    }
}

/* The frame's shade row says the bands (its reason, where they fit in it: the counters
 * always). */
static void note_bands(pf_frame_report *report, uint32_t first, uint32_t bands,
                       uint32_t band_rows)
{
    for (uint32_t i = first; i < report->stage_count; i++) {
        pf_stage_timing *row = &report->stages[i];
        if (strcmp(row->stage, "shade"))
            continue;
        pf_stage_add_counter(row, "bands", bands);
        pf_stage_add_counter(row, "band_rows", band_rows);
        size_t used = strlen(row->reason);
        snprintf(row->reason + used, sizeof row->reason - used, "; %u bands of %u rows", bands,
                 band_rows);
    }
}

pf_status pf_render_bands(pf_renderer *renderer, const pf_scene_frame *frame,
                          const pf_render_settings *settings, uint32_t band_rows,
                          pf_image *image, pf_frame_report *report, pf_error *err)
{
    memset(image, 0, sizeof *image);
    uint32_t bands = (settings->height + band_rows - 1) / band_rows;
    uint32_t first_row = report ? report->stage_count : 0;
    pf_frame_report *part = report ? malloc(sizeof *part) : NULL;
    if (report && !part)
        return pf_error_set(err, PF_ERR_NOMEM, "bands: out of memory");
    pf_stage_memory *memory = &renderer->stage_memory[settings->quality];
    uint64_t frames_before = memory->frames;
    /* The motion vectors meant to overlap the frame's readback go with the last band's. */
    void (*overlap)(void *, int) = renderer->overlap;
    void *overlap_arg = renderer->overlap_arg;
    /* The frame's image first: a size the host cannot hold fails before any band renders. */
    pf_status status = pf_split_image_create(image, settings->width, settings->height,
                                             settings->aovs, settings->later_layers, err);
    if (status != PF_OK) {
        free(part);
        pf_error_prefix(err, "%s render of %ux%u", pf_quality_name(settings->quality),
                        settings->width, settings->height);
        return status;
    }
    pf_render_settings band = *settings;
    band.band_image_height = settings->height;
    if (settings->time_budget_ms > 0.0)
        band.time_budget_ms = settings->time_budget_ms / bands;
    for (uint32_t b = 0; status == PF_OK && b < bands; b++) {
        band.band_row_first = b * band_rows;
        band.height = settings->height - band.band_row_first < band_rows
                          ? settings->height - band.band_row_first
                          : band_rows;
        renderer->overlap = b + 1 == bands ? overlap : NULL;
        renderer->overlap_arg = b + 1 == bands ? overlap_arg : NULL;
        pf_frame_report *into = b == 0 ? report : part;
        if (into && b > 0)
            memset(into, 0, sizeof *into);
        pf_image rows = {0};
        uint32_t samples = 0;
        status = pf_render_band(renderer, frame, &band, &rows, into, &samples, err);
        if (status == PF_OK && rows.channel_count != image->channel_count)
            status = pf_error_set(err, PF_ERR_INTERNAL, "a band has %u channels, its frame %u",
                                  rows.channel_count, image->channel_count);
        if (status == PF_OK) {
            size_t row_floats = (size_t)settings->width * rows.channel_count;
            memcpy(image->pixels + (size_t)band.band_row_first * row_floats, rows.pixels,
                   (size_t)band.height * row_floats * sizeof(float));
            if (b > 0 && report) {
                for (uint32_t i = 0; i < part->stage_count; i++)
                    merge_row(report, first_row, &part->stages[i]);
                report->discarded_samples += part->discarded_samples;
            }
        }
        pf_image_free(&rows);
        /* The later bands render what the first did within its budget. */
        if (b == 0 && settings->time_budget_ms > 0.0) {
            band.time_budget_ms = 0.0;
            band.samples_per_pixel = samples;
            band.sample_scale = 0;
        }
    }
    renderer->overlap = overlap;
    renderer->overlap_arg = overlap_arg;
    memory->frames = frames_before + 1;
    free(part);
    if (status != PF_OK) {
        pf_image_free(image);
        pf_error_prefix(err, "rows %u..%u of %u (a band: the film exceeds one device buffer)",
                        band.band_row_first, band.band_row_first + band.height - 1,
                        settings->height);
        return status;
    }
    if (report)
        note_bands(report, first_row, bands, band_rows);
    return PF_OK;
}
