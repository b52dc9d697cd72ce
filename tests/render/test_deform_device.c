/*
 * The `deform` stage on the device (issue 39, shaders/deform.comp) against the host's
 * loop (pf_deform_vertices_host), forced on lavapipe (where AUTO picks the host): on
 * scenes/character, Blender's export of an arm skinned to a bending two-bone armature and a
 * sheet bulged by a shape key, every vertex, normal and corner texel of frames 1, 12 and 24
 * agree to float rounding; the rows say where it ran; the rest poses go to the device once
 * and stay (the second frame uploads none) until another load of a scene comes; one
 * submission a deformed node.
 */
#include "pf_test.h"
#include "render_test_env.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static pf_vk_context *ctx;
static pf_renderer *renderer;

static double row_counter(const pf_frame_report *report, const char *name)
{
    for (uint32_t s = 0; s < report->stage_count; s++)
        if (!strcmp(report->stages[s].stage, "deform"))
            for (uint32_t c = 0; c < report->stages[s].counter_count; c++)
                if (!strcmp(report->stages[s].counters[c].name, name))
                    return report->stages[s].counters[c].value;
    return NAN;
}

static const char *row_reason(const pf_frame_report *report)
{
    for (uint32_t s = 0; s < report->stage_count; s++)
        if (!strcmp(report->stages[s].stage, "deform"))
            return report->stages[s].reason;
    return "";
}

/* The frame at time, deformed at site; 1 on success. */
static int deformed_frame(const pf_scene *scene, double time, pf_deform_site site,
                          pf_scene_frame *frame, pf_frame_report *report)
{
    pf_error err = {0};
    memset(report, 0, sizeof *report);
    pf_renderer_set_deform_site(renderer, site);
    int ok = pf_scene_eval_rigid(scene, time, frame, &err) == PF_OK &&
             pf_render_deform(renderer, scene, time, frame, report, &err) == PF_OK;
    pf_renderer_set_deform_site(renderer, PF_DEFORM_AUTO);
    PF_CHECK_MSG(ok, "deform at %g s: %s", time, err.message);
    return ok;
}

/* Largest difference between two float arrays, relative to max(1, |host|). */
static double largest_difference(const float *device, const float *host, size_t count)
{
    double largest = 0.0;
    for (size_t i = 0; i < count; i++) {
        double scale = fabs((double)host[i]) > 1.0 ? fabs((double)host[i]) : 1.0;
        double d = fabs((double)device[i] - host[i]) / scale;
        if (!(d <= largest))
            largest = d; /* NaN too */
    }
    return largest;
}

PF_TEST(the_device_deforms_as_the_host_does)
{
    const char *source = getenv("PF_SOURCE_DIR");
    char path[1024];
    snprintf(path, sizeof path, "%s/scenes/character/character.gltf", source ? source : ".");
    pf_scene *scene = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_scene_load(path, &scene, &err), &err);
    double fps = pf_scene_get_info(scene)->fps;
    static const int frames[] = {1, 12, 24};
    for (size_t f = 0; f < sizeof frames / sizeof *frames; f++) {
        double time = (frames[f] - 1) / fps;
        pf_scene_frame host = {0}, device = {0};
        pf_frame_report host_report, device_report;
        if (deformed_frame(scene, time, PF_DEFORM_HOST, &host, &host_report) &&
            deformed_frame(scene, time, PF_DEFORM_DEVICE, &device, &device_report)) {
            size_t corners = 3u * host.triangle_count;
            double positions = largest_difference(&device.vertices[0][0], &host.vertices[0][0],
                                                  4u * corners);
            double normals = largest_difference(&device.normals[0][0], &host.normals[0][0],
                                                4u * corners);
            double texels = host.corners ? largest_difference(&device.corners[0][0],
                                                              &host.corners[0][0],
                                                              4u * PF_CORNER_TEXELS * corners)
                                         : 0.0;
            printf("  frame %d: positions %.3g, normals %.3g, corner texels %.3g apart\n",
                   frames[f], positions, normals, texels);
            PF_CHECK_MSG(positions <= 1e-5 && normals <= 1e-5 && texels <= 1e-5,
                         "frame %d: positions %g, normals %g, texels %g apart", frames[f],
                         positions, normals, texels);
            for (int k = 0; k < 3; k++)
                PF_CHECK(fabsf(device.bounds_min[k] - host.bounds_min[k]) <= 1e-5f &&
                         fabsf(device.bounds_max[k] - host.bounds_max[k]) <= 1e-5f);
            PF_CHECK(row_counter(&host_report, "on_device") == 0.0);
            PF_CHECK(row_counter(&device_report, "on_device") == 1.0);
            PF_CHECK(strstr(row_reason(&device_report), "on the device (forced)") != NULL);
            PF_CHECK(strstr(row_reason(&host_report), "on the host (forced)") != NULL);
            double nodes = row_counter(&device_report, "skinned_meshes") +
                           row_counter(&device_report, "morphed_meshes");
            PF_CHECK_MSG(row_counter(&device_report, "submits") == nodes,
                         "%g submissions for %g nodes",
                         row_counter(&device_report, "submits"), nodes);
            /* The rest poses went to the device with the first frame, and stayed. */
            PF_CHECK(row_counter(&device_report, "rest_poses_uploaded") == (f == 0 ? nodes : 0));
        }
        pf_scene_frame_free(&host);
        pf_scene_frame_free(&device);
    }
    /* AUTO: the host on a CPU device, saying why. */
    pf_scene_frame frame = {0};
    pf_frame_report report;
    if (deformed_frame(scene, 0.0, PF_DEFORM_AUTO, &frame, &report)) {
        int cpu = strcmp(pf_vk_info(ctx)->type, "cpu") == 0;
        PF_CHECK(strstr(row_reason(&report), cpu ? "on the host (the device is the CPU"
                                                 : "on the device (a GPU)") != NULL);
    }
    pf_scene_frame_free(&frame);
    /* The same file loaded again is another load (a worker's next job): its rest poses go
     * to the device anew, in place of the first load's. */
    pf_scene *again = NULL;
    PF_REQUIRE_OK(pf_scene_load(path, &again, &err), &err);
    uint64_t held = pf_vk_memory_use_of(ctx).current;
    if (deformed_frame(again, 0.0, PF_DEFORM_DEVICE, &frame, &report)) {
        PF_CHECK(row_counter(&report, "rest_poses_uploaded") ==
                 row_counter(&report, "skinned_meshes") + row_counter(&report, "morphed_meshes"));
        /* The first load's buffers were released: the device holds no more than before. */
        uint64_t now = pf_vk_memory_use_of(ctx).current;
        PF_CHECK_MSG(now <= held, "device memory %llu bytes, %llu before the second load",
                     (unsigned long long)now, (unsigned long long)held);
    }
    pf_scene_frame_free(&frame);
    pf_scene_destroy(again);
    pf_scene_destroy(scene);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(the_device_deforms_as_the_host_does);
    return render_test_finish(ctx, renderer);
}
