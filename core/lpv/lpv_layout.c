/*
 * LPV settings, the focus point and the snapped cascade layout (pf_lpv.h).
 */
#include "pf_lpv.h"

#include <math.h>
#include <string.h>

/* Cells of margin the snapping may cost on each side of a cascade. */
#define SNAP_MARGIN_CELLS 2u
/* The scene's box is enlarged by this fraction of its size for "camera inside". */
#define INSIDE_MARGIN 0.1f

static pf_status refuse(pf_lpv_setting setting, pf_lpv_setting *which, pf_error *err,
                        pf_status status, const char *format, double value, double low,
                        double high)
{
    if (which)
        *which = setting;
    return pf_error_set(err, status, format, value, low, high);
}

pf_status pf_lpv_settings_check(const pf_lpv_settings *settings, uint64_t max_buffer_bytes,
                                pf_lpv_setting *which, pf_error *err)
{
    if (which)
        *which = PF_LPV_SETTING_NONE;
    uint32_t cascades = settings->cascades ? settings->cascades : PF_LPV_DEFAULT_CASCADES;
    uint32_t size = settings->size ? settings->size : PF_LPV_DEFAULT_SIZE;
    if (cascades > PF_LPV_MAX_CASCADES)
        return refuse(PF_LPV_SETTING_CASCADES, which, err, PF_ERR_INVALID,
                      "LPV cascade count %.0f: expected %.0f..%.0f", cascades, 1,
                      PF_LPV_MAX_CASCADES);
    if (size < PF_LPV_MIN_SIZE || size > PF_LPV_MAX_SIZE || size % 4u != 0)
        return refuse(PF_LPV_SETTING_SIZE, which, err, PF_ERR_INVALID,
                      "LPV cascade size %.0f: expected a multiple of 4 in %.0f..%.0f", size,
                      PF_LPV_MIN_SIZE, PF_LPV_MAX_SIZE);
    uint64_t bytes = (uint64_t)cascades * size * size * size * PF_LPV_FLOATS_PER_CELL * 4u;
    if (max_buffer_bytes > 0 && bytes > max_buffer_bytes) {
        uint32_t fits = PF_LPV_MIN_SIZE;
        while (fits + 4u <= PF_LPV_MAX_SIZE &&
               (uint64_t)cascades * (fits + 4u) * (fits + 4u) * (fits + 4u) *
                       PF_LPV_FLOATS_PER_CELL * 4u <=
                   max_buffer_bytes)
            fits += 4u;
        return refuse(PF_LPV_SETTING_SIZE, which, err, PF_ERR_LIMIT,
                      "LPV cascade size %.0f: the volume would not fit one device buffer "
                      "(largest that fits: %.0f; the device allows %.0f MiB)",
                      size, fits, (double)(max_buffer_bytes >> 20));
    }
    for (uint32_t k = 0; k < PF_LPV_MAX_CASCADES; k++) {
        if (settings->iterations[k] > PF_LPV_MAX_ITERATIONS)
            return refuse(PF_LPV_SETTING_ITERATIONS, which, err, PF_ERR_INVALID,
                          "LPV iterations %.0f: expected %.0f..%.0f", settings->iterations[k], 1,
                          PF_LPV_MAX_ITERATIONS);
    }
    if (!(settings->cell_size >= 0.0f) || isinf(settings->cell_size))
        return refuse(PF_LPV_SETTING_CELL_SIZE, which, err, PF_ERR_INVALID,
                      "LPV cell size %g: expected a finite size > %g m (or %g: from the scene)",
                      settings->cell_size, 0, 0);
    if (!(settings->offset_cells >= 0.0f) || settings->offset_cells > 2.0f)
        return refuse(PF_LPV_SETTING_OFFSET, which, err, PF_ERR_INVALID,
                      "LPV injection offset %g cells: expected (%g, %g]", settings->offset_cells,
                      0, 2);
    return PF_OK;
}

void pf_lpv_focus(const pf_scene_frame *frame, float focus[3])
{
    const pf_camera *camera = &frame->camera;
    int inside = 1;
    float centre[3];
    for (int i = 0; i < 3; i++) {
        float extent = frame->bounds_max[i] - frame->bounds_min[i];
        float margin = INSIDE_MARGIN * extent;
        if (camera->position[i] < frame->bounds_min[i] - margin ||
            camera->position[i] > frame->bounds_max[i] + margin)
            inside = 0;
        centre[i] = 0.5f * (frame->bounds_min[i] + frame->bounds_max[i]);
    }
    float along = 0.0f;
    for (int i = 0; i < 3; i++)
        along += (centre[i] - camera->position[i]) * camera->forward[i];
    if (inside || !(along > 0.0f))
        along = 0.0f;
    for (int i = 0; i < 3; i++)
        focus[i] = camera->position[i] + along * camera->forward[i];
}

float pf_lpv_default_cell_size(const pf_scene_frame *frame, const float focus[3],
                                uint32_t cascades, uint32_t size, uint32_t coarsest_iterations)
{
    float half_span = 0.0f, extent = 0.0f;
    for (int i = 0; i < 3; i++) {
        half_span = fmaxf(half_span, fmaxf(frame->bounds_max[i] - focus[i],
                                           focus[i] - frame->bounds_min[i]));
        extent = fmaxf(extent, frame->bounds_max[i] - frame->bounds_min[i]);
    }
    if (!(half_span > 0.0f) || !isfinite(half_span))
        half_span = 1.0f;
    if (!(extent > 0.0f) || !isfinite(extent))
        extent = 1.0f;
    /*
     * The coarsest cascade holds the scene (rounded up to a power of two),
     * and its iterations carry light twice across the scene's largest
     * extent (rounded to the nearest power of two: 1.4 to 2.8 times): light
     * crossing the scene diagonally takes more axis steps than cells it
     * crosses, and a closed 2 m box measured 0.61 of the reference's
     * indirect light at one extent of reach, 0.80 at two and 0.84 at four.
     */
    double cover = ldexp(1.0, (int)ceil(log2(half_span / (double)(size / 2u - SNAP_MARGIN_CELLS))));
    double reach = ldexp(1.0, (int)lround(log2(2.0 * extent /
                                               (double)(coarsest_iterations ? coarsest_iterations
                                                                            : 1u))));
    return (float)ldexp(fmax(cover, reach), -(int)(cascades - 1u));
}

void pf_lpv_layout_make(const pf_lpv_settings *settings, const float focus[3], float finest_cell,
                        const pf_scene_frame *frame, pf_lpv_layout *out)
{
    memset(out, 0, sizeof *out);
    out->count = settings->cascades ? settings->cascades : PF_LPV_DEFAULT_CASCADES;
    out->size = settings->size ? settings->size : PF_LPV_DEFAULT_SIZE;
    out->offset_cells = settings->offset_cells > 0.0f ? settings->offset_cells
                                                      : PF_LPV_DEFAULT_OFFSET_CELLS;
    memcpy(out->focus, focus, sizeof out->focus);
    uint32_t default_iterations =
        settings->iterations[0] ? settings->iterations[0] : PF_LPV_DEFAULT_ITERATIONS;
    for (uint32_t k = 0; k < out->count; k++)
        out->cascades[k].iterations = settings->iterations[k] ? settings->iterations[k]
                                                              : default_iterations;
    if (!(finest_cell > 0.0f))
        finest_cell = pf_lpv_default_cell_size(frame, focus, out->count, out->size,
                                               out->cascades[out->count - 1].iterations);
    for (uint32_t k = 0; k < out->count; k++) {
        pf_lpv_cascade *cascade = &out->cascades[k];
        cascade->cell_size = ldexpf(finest_cell, (int)k);
        for (int i = 0; i < 3; i++) {
            cascade->origin_cell[i] =
                (int32_t)floor((double)focus[i] / cascade->cell_size) - (int32_t)(out->size / 2u);
            cascade->origin[i] = (float)cascade->origin_cell[i] * cascade->cell_size;
        }
    }
    for (uint32_t k = 1; k < out->count; k++) {
        pf_lpv_cascade *cascade = &out->cascades[k];
        const pf_lpv_cascade *finer = &out->cascades[k - 1];
        double reach = (double)finer->iterations * finer->cell_size / cascade->cell_size;
        uint32_t snapshot = (uint32_t)floor(reach + 0.5);
        cascade->snapshot_iterations = snapshot < cascade->iterations ? snapshot
                                                                      : cascade->iterations;
    }
    out->covers_scene = 1;
    if (frame && frame->triangle_count > 0) {
        const pf_lpv_cascade *coarsest = &out->cascades[out->count - 1u];
        float far = coarsest->cell_size * (float)out->size;
        for (int i = 0; i < 3; i++) {
            if (frame->bounds_min[i] < coarsest->origin[i] ||
                frame->bounds_max[i] > coarsest->origin[i] + far)
                out->covers_scene = 0;
        }
    }
}

uint64_t pf_lpv_volume_floats(const pf_lpv_layout *layout, uint32_t floats_per_cell)
{
    return (uint64_t)layout->count * layout->size * layout->size * layout->size * floats_per_cell;
}
