/*
 * The `motion` stage (issue 39): the motion vectors AOV that vector blur in
 * Blender's compositor or Nuke, and a temporal denoiser, read. For each pixel
 * the surface seen through the pixel's centre is found by tracing that ray
 * through the frame's BIH on the host (the CPU copy every bih_build leaves in
 * the renderer; packets of coherent primary rays, the image in slices on every
 * core), its point is carried to the previous frame by its triangle's
 * barycentric coordinates (triangles keep their index from frame to frame, so
 * skinning, morphing and node animation all move it), and projected by the
 * previous frame's camera.
 *
 * Convention, as Cycles' Vector pass (checked against Blender 3.4's: a plane
 * moving 8 px right and 4 px up reads (-8, -4)): motion.X and motion.Y are
 * the previous raster position minus this one, in pixels, x to the right and
 * y up. A pixel that sees nothing, or whose point was behind the previous
 * camera, reads 0, and so, exactly, does one whose triangle and camera did not
 * move. A still shot (the camera and every vertex as in the previous frame) traces nothing.
 */
#include "render_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Rays traced per call: a few rows of primary rays, in pixel order. */
#define MOTION_RAY_BATCH 4096u

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* Raster position (x right from the left edge, y down from the top, in pixels) of world
 * point p seen by camera, whose image plane's half extents are tan_x, tan_y (an
 * orthographic camera's view's, in world units: pf_camera_image_plane); 0 when it lies
 * behind the camera. */
static int project(const pf_camera *camera, float tan_x, float tan_y, uint32_t width,
                   uint32_t height, const double p[3], double *x, double *y)
{
    double d[3], forward[3], right[3], up[3];
    for (int k = 0; k < 3; k++) {
        d[k] = p[k] - camera->position[k];
        forward[k] = camera->forward[k];
        right[k] = camera->right[k];
        up[k] = camera->up[k];
    }
    double z = dot3(d, forward);
    if (!(z > 0.0))
        return 0;
    if (camera->orthographic)
        z = 1.0; /* parallel rays: the offset from the axis alone */
    double ndc_x = dot3(d, right) / (z * tan_x), ndc_y = dot3(d, up) / (z * tan_y);
    *x = (ndc_x + 1.0) * 0.5 * width;
    *y = (1.0 - ndc_y) * 0.5 * height;
    return isfinite(*x) && isfinite(*y);
}

/* Barycentric weights of p in triangle v (the hit point's, whatever the tracer's u, v
 * convention): areas of the sub-triangles against the whole, in the triangle's plane. */
static void barycentric(const float (*v)[4], const double p[3], double w[3])
{
    double e1[3], e2[3], ep[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = (double)v[1][k] - v[0][k];
        e2[k] = (double)v[2][k] - v[0][k];
        ep[k] = p[k] - v[0][k];
    }
    double d11 = dot3(e1, e1), d12 = dot3(e1, e2), d22 = dot3(e2, e2);
    double dp1 = dot3(ep, e1), dp2 = dot3(ep, e2);
    double det = d11 * d22 - d12 * d12;
    if (!(det > 0.0)) {
        w[0] = 1.0;
        w[1] = w[2] = 0.0;
        return;
    }
    w[1] = (d22 * dp1 - d12 * dp2) / det;
    w[2] = (d11 * dp2 - d12 * dp1) / det;
    w[0] = 1.0 - w[1] - w[2];
}

/* Most threads tracing the stage's rays (one a core). */
#define MOTION_MAX_THREADS 64u

/* One thread's slice of the image: pixels [first, end), traced and projected into out. */
typedef struct motion_slice {
    const pf_bih *tree;
    const pf_scene_frame *frame, *previous;
    float tan_x, tan_y, previous_tan_x, previous_tan_y;
    uint32_t width, height, channels; /* out's channels, of which motion.X/Y */
    uint32_t first_channel;           /* are these two */
    int same_camera;
    float *out;
    float *depth_change;
    size_t first, end;
    uint64_t moving, seen;
    pf_status status;
    pf_error err;
} motion_slice;

static void motion_rows(void *argument)
{
    motion_slice *s = argument;
    const pf_scene_frame *frame = s->frame, *previous = s->previous;
    uint32_t width = s->width, height = s->height, channels = s->channels;
    pf_ray *rays = malloc(MOTION_RAY_BATCH * sizeof *rays);
    pf_hit *hits = malloc(MOTION_RAY_BATCH * sizeof *hits);
    s->status = rays && hits ? PF_OK : pf_error_set(&s->err, PF_ERR_NOMEM, "out of memory");
    for (size_t first = s->first; s->status == PF_OK && first < s->end;
         first += MOTION_RAY_BATCH) {
        uint32_t count = (uint32_t)(s->end - first < MOTION_RAY_BATCH ? s->end - first
                                                                      : MOTION_RAY_BATCH);
        for (uint32_t i = 0; i < count; i++) {
            size_t p = first + i;
            double ndc_x = 2.0 * ((double)(p % width) + 0.5) / width - 1.0;
            double ndc_y = 1.0 - 2.0 * ((double)(p / width) + 0.5) / height;
            double origin[3], direction[3];
            pf_camera_ray(&frame->camera, s->tan_x, s->tan_y, ndc_x, ndc_y, origin, direction);
            for (int k = 0; k < 3; k++) {
                rays[i].origin[k] = (float)origin[k];
                rays[i].direction[k] = (float)direction[k];
            }
            rays[i].tmin = 0.0f;
            rays[i].tmax = INFINITY;
        }
        s->status = pf_bih_trace_cpu_rays(s->tree, rays, count, 0, hits, &s->err);
        for (uint32_t i = 0; s->status == PF_OK && i < count; i++) {
            size_t p = first + i;
            float *out = s->out + p * channels + s->first_channel;
            out[0] = out[1] = 0.0f;
            if (s->depth_change)
                s->depth_change[p] = 0.0f;
            if (hits[i].triangle == PF_NO_HIT)
                continue;
            s->seen++;
            double point[3], w[3], before[3] = {0, 0, 0};
            for (int k = 0; k < 3; k++)
                point[k] = rays[i].origin[k] + (double)hits[i].t * rays[i].direction[k];
            const float(*now)[4] = frame->vertices + 3 * (size_t)hits[i].triangle;
            const float(*then)[4] = previous->vertices + 3 * (size_t)hits[i].triangle;
            /* A still triangle under a still camera: exactly 0, not the rounding of a
             * round trip through the projection. */
            if (s->same_camera && memcmp(now, then, 3 * sizeof *now) == 0)
                continue;
            barycentric(now, point, w);
            for (int c = 0; c < 3; c++)
                for (int k = 0; k < 3; k++)
                    before[k] += w[c] * then[c][k];
            double x, y;
            if (!project(&previous->camera, s->previous_tan_x, s->previous_tan_y, width, height,
                         before, &x, &y))
                continue;
            if (s->depth_change) {
                /* The depth the previous camera saw the point at: its distance from the
                 * pinhole, or from the view's plane (orthographic), as the depth layer's. */
                double away[3], forward[3];
                for (int k = 0; k < 3; k++) {
                    away[k] = before[k] - previous->camera.position[k];
                    forward[k] = previous->camera.forward[k];
                }
                double depth_then = previous->camera.orthographic ? dot3(away, forward)
                                                                  : sqrt(dot3(away, away));
                s->depth_change[p] = (float)(depth_then - (double)hits[i].t);
            }
            /* Previous minus this pixel's centre, y up (Cycles' Vector pass). */
            out[0] = (float)(x - ((double)(p % width) + 0.5));
            out[1] = (float)(((double)(p / width) + 0.5) - y);
            s->moving += out[0] != 0.0f || out[1] != 0.0f;
        }
    }
    free(rays);
    free(hits);
}

pf_status pf_motion_compute(pf_renderer *renderer, const pf_scene_frame *frame,
                            const pf_scene_frame *previous, uint32_t width, uint32_t height,
                            pf_motion_field *out, pf_error *err)
{
    double start = pf_time_ms();
    memset(out, 0, sizeof *out);
    if (!renderer->bih_valid || renderer->bih.triangle_count != frame->triangle_count)
        return pf_error_set(err, PF_ERR_INVALID, "motion: no tree of this frame's triangles");
    const pf_bih *tree = NULL;
    pf_status status = pf_renderer_bih_host(renderer, &tree, err);
    if (status != PF_OK)
        return status;
    if (previous->triangle_count != frame->triangle_count)
        return pf_error_set(err, PF_ERR_INVALID,
                            "motion: the previous frame has %u triangles, this one %u",
                            previous->triangle_count, frame->triangle_count);
    size_t pixels = (size_t)width * height;
    out->width = width;
    out->height = height;
    out->vectors = calloc(2 * pixels, sizeof *out->vectors);
    out->depth_change = calloc(pixels, sizeof *out->depth_change);
    if (!out->vectors || !out->depth_change) {
        pf_motion_field_free(out);
        return pf_error_set(err, PF_ERR_NOMEM, "motion: out of memory");
    }
    float tan_x, tan_y, previous_tan_x, previous_tan_y;
    pf_camera_image_plane(&frame->camera, width, height, &tan_x, &tan_y);
    pf_camera_image_plane(&previous->camera, width, height, &previous_tan_x, &previous_tan_y);
    int same_camera = memcmp(&frame->camera, &previous->camera, sizeof frame->camera) == 0;
    /* A still shot (camera and every vertex as they were): every vector is 0 (as calloc left
     * them), known without tracing a ray. */
    out->still = same_camera && memcmp(frame->vertices, previous->vertices,
                                       (size_t)frame->triangle_count * 3 *
                                           sizeof *frame->vertices) == 0;
    /* Otherwise the pixels in slices of whole batches, one a core: the tree is only read,
     * and each slice writes its own pixels. */
    uint32_t batches = (uint32_t)((pixels + MOTION_RAY_BATCH - 1) / MOTION_RAY_BATCH);
    uint32_t threads = pf_cpu_cores(MOTION_MAX_THREADS);
    if (threads > batches)
        threads = batches;
    motion_slice slices[MOTION_MAX_THREADS];
    for (uint32_t t = 0; !out->still && t < threads; t++) {
        size_t first = (size_t)batches * t / threads * MOTION_RAY_BATCH;
        size_t end = (size_t)batches * (t + 1) / threads * MOTION_RAY_BATCH;
        slices[t] = (motion_slice){tree, frame, previous, tan_x, tan_y, previous_tan_x,
                                   previous_tan_y, width, height, 2, 0, same_camera,
                                   out->vectors, out->depth_change, first,
                                   end < pixels ? end : pixels, 0, 0, PF_OK, {0}};
    }
    if (!out->still)
        pf_run_parallel(slices, sizeof slices[0], threads, motion_rows);
    for (uint32_t t = 0; !out->still && t < threads; t++) {
        out->moving += slices[t].moving;
        out->seen += slices[t].seen;
        if (status == PF_OK && slices[t].status != PF_OK) {
            status = slices[t].status;
            if (err)
                *err = slices[t].err;
        }
    }
    if (status != PF_OK) {
        pf_motion_field_free(out);
        pf_error_prefix(err, "motion");
        return status;
    }
    out->ms = pf_time_ms() - start;
    return PF_OK;
}

void pf_motion_field_free(pf_motion_field *field)
{
    free(field->vectors);
    free(field->depth_change);
    field->vectors = field->depth_change = NULL;
}

/* Pixels [begin, end) of the motion layer from the field. */
typedef struct apply_job {
    const pf_motion_field *field;
    pf_image *image;
    uint32_t channel;
} apply_job;

static void apply_pixels(void *context, uint64_t begin, uint64_t end)
{
    const apply_job *job = context;
    uint32_t channels = job->image->channel_count;
    for (uint64_t p = begin; p < end; p++) {
        float *out = job->image->pixels + p * channels + job->channel;
        out[0] = job->field->vectors[2 * p];
        out[1] = job->field->vectors[2 * p + 1];
    }
}

pf_status pf_motion_apply(const pf_motion_field *field, pf_image *image, float *depth_change,
                          int overlapped, pf_frame_report *report, pf_error *err)
{
    double start = pf_time_ms();
    if (!field->vectors || field->width != image->width || field->height != image->height)
        return pf_error_set(err, PF_ERR_INTERNAL, "motion: no vectors of a %ux%u image",
                            image->width, image->height);
    uint32_t motion_channel = 0, channels_before = image->channel_count;
    pf_status status = pf_image_later_layer(image, pf_motion_channels, 2, &motion_channel, err);
    if (status != PF_OK)
        return status;
    size_t pixels = (size_t)image->width * image->height;
    /* In slices, one a core: each pixel's two words sit a whole texel apart (26 channels at
     * 1080p), so the loop is a cache line a pixel, 24-32 ms of a 1080p frame on one core of
     * a GPU host. */
    apply_job job = {field, image, motion_channel};
    pf_run_ranges(pixels, MOTION_MAX_THREADS, image->width, apply_pixels, &job);
    if (depth_change)
        memcpy(depth_change, field->depth_change, pixels * sizeof *depth_change);
    pf_stage_timing *row =
        pf_frame_report_row(report, "motion", NULL, field->ms + pf_time_ms() - start, -1.0);
    /* 0: written into the layer the image was created with (PF_LATER_LAYER_MOTION). */
    int image_copied = image->channel_count != channels_before;
    if (row && field->still) {
        snprintf(row->reason, sizeof row->reason,
                 "camera and geometry still, not traced; 0 of %llu pixels moved",
                 (unsigned long long)pixels);
        pf_stage_add_counter(row, "pixels", (double)pixels);
        pf_stage_add_counter(row, "moving_pixels", 0);
        pf_stage_add_counter(row, "traced", 0);
    } else if (row) {
        snprintf(row->reason, sizeof row->reason,
                 "pixel centres traced on the host; %llu of %llu pixels moved",
                 (unsigned long long)field->moving, (unsigned long long)field->seen);
        pf_stage_add_counter(row, "pixels", (double)pixels);
        pf_stage_add_counter(row, "surface_pixels", (double)field->seen);
        pf_stage_add_counter(row, "moving_pixels", (double)field->moving);
        pf_stage_add_counter(row, "traced", 1);
    }
    if (row) {
        pf_stage_add_counter(row, "image_copied", image_copied);
        /* 1: computed while the device finished the frame's last submission (shade's
         * overlap_ms): its wall time is inside shade's, not after it. */
        pf_stage_add_counter(row, "overlapped", overlapped);
    }
    return PF_OK;
}

pf_status pf_render_motion(pf_renderer *renderer, const pf_scene_frame *frame,
                           const pf_scene_frame *previous, pf_image *image, float *depth_change,
                           pf_frame_report *report, pf_error *err)
{
    pf_motion_field field;
    pf_status status =
        pf_motion_compute(renderer, frame, previous, image->width, image->height, &field, err);
    if (status == PF_OK)
        status = pf_motion_apply(&field, image, depth_change, 0, report, err);
    pf_motion_field_free(&field);
    return status;
}
