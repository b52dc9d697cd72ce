/*
 * The stage planner as a pure function (issue 45): pf_plan_stages of a frame,
 * the settings, what the previous frame left (stage memory, the kept BIH) and
 * the device's limits, on the host. ctest runs it with no Vulkan driver to be
 * found (VK_ICD_FILENAMES points nowhere), so it cannot lean on a device.
 *   - a first frame builds and traces everything, "first frame";
 *   - a second frame whose inputs all match what the first left reuses every
 *     stage, and one whose light changed re-traces its photons naming the
 *     lights (the BIH is reused: the geometry is the same);
 *   - the BIH: reuse for bitwise-equal triangles, refit for moved ones, a
 *     build for another triangle count;
 *   - auto's pilot having replaced the previous frame's outputs is said;
 *   - fast's LPV settings against a device limit: too small a buffer range is
 *     PF_ERR_LIMIT naming it, decided without a device;
 *   - who traces reference's rays (issue 43): the host where the device is the
 *     CPU and nothing stands against it, else the device, saying why.
 */
#include "pf_test.h"
#include "reference_test_util.h"
#include "render_internal.h"

#include <stdio.h>
#include <string.h>

static ref_scene room;

/* A white box with a point light and a small emissive quad: a photon scene, Lambert only. */
static void build_room(void)
{
    ref_scene_init(&room);
    uint32_t white = ref_scene_add_material(&room, pf_material_lambert(0.8f, 0.8f, 0.8f));
    uint32_t lamp = ref_scene_add_material(&room, ref_material_emitter(5, 5, 5));
    const float min[3] = {-1, -1, -1}, max[3] = {1, 1, 1};
    ref_scene_add_box(&room, min, max, 1, white);
    const float centre[3] = {0, 0.99f, 0}, u[3] = {0.2f, 0, 0}, v[3] = {0, 0, 0.2f};
    ref_scene_add_quad(&room, centre, u, v, lamp);
    ref_scene_add_light(&room, (pf_light){{0.3f, 0.5f, 0.2f}, PF_LIGHT_POINT, {0, -1, 0}, 0,
                                          {2, 2, 2}, 1, 1});
    const float eye[3] = {0, 0, 0.9f}, target[3] = {0, 0, -1}, up[3] = {0, 1, 0};
    ref_scene_look_at(&room, eye, target, up, 1.0f);
}

static pf_render_settings settings_of(pf_quality quality)
{
    pf_render_settings settings = ref_settings(32, 24, 0, 1, 0);
    settings.quality = quality;
    return settings;
}

/* No memory, no tree: a first frame on a device whose buffers are as large as lavapipe's. */
static pf_stage_previous first_frame(const pf_stage_memory *memory)
{
    pf_stage_previous previous = {memory, NULL, 0, 0, 128u << 20};
    return previous;
}

static int has(const pf_stage_decision *decision, const char *text)
{
    return strstr(decision->reason, text) != NULL;
}

PF_TEST(a_first_frame_runs_every_stage_it_needs)
{
    pf_stage_memory memory = {0};
    const pf_quality presets[] = {PF_QUALITY_PREVIEW, PF_QUALITY_REFERENCE, PF_QUALITY_FINAL,
                                  PF_QUALITY_FAST};
    for (size_t p = 0; p < sizeof presets / sizeof *presets; p++) {
        pf_render_settings settings = settings_of(presets[p]);
        pf_stage_previous previous = first_frame(&memory);
        pf_stage_plan plan;
        pf_error err = {0};
        PF_REQUIRE_OK(pf_plan_stages(&room.frame, &settings, &previous, &plan, &err), &err);
        const pf_stage_decision *bih = &plan.stages[PF_STAGE_BIH_BUILD];
        PF_CHECK_MSG(bih->action == PF_STAGE_RUN && !strcmp(bih->reason, "built: first frame"),
                     "%s: bih_build %s", pf_quality_name(presets[p]), bih->reason);
        PF_CHECK(plan.stages[PF_STAGE_SHADE].action == PF_STAGE_RUN);
        if (presets[p] == PF_QUALITY_FINAL || presets[p] == PF_QUALITY_FAST) {
            const pf_stage_decision *trace = &plan.stages[PF_STAGE_PHOTON_TRACE];
            PF_CHECK_MSG(trace->action == PF_STAGE_RUN && has(trace, "first frame"),
                         "photon_trace: %s", trace->reason);
            /* Lambert only: no caustic map, and the row says why. */
            const pf_stage_decision *caustic = &plan.stages[PF_STAGE_CAUSTIC_MAP];
            PF_CHECK_MSG(caustic->action == PF_STAGE_SKIP && has(caustic, "no specular"),
                         "caustic_map: %s", caustic->reason);
            PF_CHECK(plan.emitters.count > 0);
        }
        if (presets[p] == PF_QUALITY_FAST)
            PF_CHECK(plan.stages[PF_STAGE_LPV_PROPAGATE].action == PF_STAGE_RUN);
        pf_stage_plan_release(&plan);
    }
}

/* Plans final, then remembers every stage as the frame's integrator would. */
static void plan_and_remember(const pf_stage_previous *previous, pf_stage_memory *memory,
                              pf_stage_plan *plan)
{
    pf_render_settings settings = settings_of(PF_QUALITY_FINAL);
    pf_error err = {0};
    PF_REQUIRE_OK(pf_plan_stages(&room.frame, &settings, previous, plan, &err), &err);
    for (int s = 0; s < PF_STAGE_COUNT; s++)
        if (plan->stages[s].action == PF_STAGE_RUN)
            pf_stage_remember(memory, plan, (pf_stage_id)s);
    memory->frames++;
    memory->kept_passes = plan->samples;
}

PF_TEST(a_second_frame_reuses_what_did_not_change)
{
    pf_stage_memory memory = {0};
    pf_stage_previous previous = first_frame(&memory);
    pf_stage_plan plan;
    plan_and_remember(&previous, &memory, &plan);
    pf_stage_plan_release(&plan);
    pf_render_settings settings = settings_of(PF_QUALITY_FINAL);
    pf_error err = {0};
    PF_REQUIRE_OK(pf_plan_stages(&room.frame, &settings, &previous, &plan, &err), &err);
    const pf_stage_decision *trace = &plan.stages[PF_STAGE_PHOTON_TRACE];
    PF_CHECK_MSG(trace->action == PF_STAGE_REUSE && has(trace, "photon maps reused"),
                 "photon_trace: %s", trace->reason);
    PF_CHECK(plan.reused_passes == plan.samples);
    pf_stage_plan_release(&plan);
    /* The point light brighter: the photons are traced again, naming the lights. */
    room.lights[0].intensity[0] = 3.0f;
    PF_REQUIRE_OK(pf_plan_stages(&room.frame, &settings, &previous, &plan, &err), &err);
    PF_CHECK_MSG(trace->action == PF_STAGE_RUN && has(trace, "lights changed"),
                 "photon_trace after the light changed: %s", trace->reason);
    room.lights[0].intensity[0] = 2.0f;
    pf_stage_plan_release(&plan);
    /* auto's pilot dropped what the previous frame kept: the reason says so. */
    pf_stage_forget(&memory);
    memory.pilot_replaced = 1;
    PF_REQUIRE_OK(pf_plan_stages(&room.frame, &settings, &previous, &plan, &err), &err);
    PF_CHECK_MSG(has(trace, "auto's pilot replaced"), "photon_trace: %s", trace->reason);
    pf_stage_plan_release(&plan);
}

PF_TEST(the_bih_decision_follows_the_kept_tree)
{
    pf_bih tree;
    pf_bih_build_options options = {.heuristic = PF_BIH_HEURISTIC_SAH};
    pf_error err = {0};
    PF_REQUIRE_OK(pf_bih_build_cpu(&room.frame, &options, &tree, &err), &err);
    pf_stage_previous previous = {NULL, &tree, 1, 0, 128u << 20};
    pf_stage_decision decision;
    pf_bih_plan(&previous, &room.frame, &decision);
    PF_CHECK_MSG(decision.action == PF_STAGE_REUSE &&
                     !strcmp(decision.reason, "geometry unchanged → BIH reused"),
                 "same triangles: %s", decision.reason);
    room.frame.vertices[0][0] += 0.01f;
    pf_bih_plan(&previous, &room.frame, &decision);
    PF_CHECK_MSG(decision.action == PF_STAGE_RUN && has(&decision, "refit"),
                 "a moved vertex: %s", decision.reason);
    room.frame.vertices[0][0] -= 0.01f;
    room.frame.triangle_count--;
    pf_bih_plan(&previous, &room.frame, &decision);
    PF_CHECK_MSG(decision.action == PF_STAGE_RUN && has(&decision, "triangle count changed"),
                 "a triangle fewer: %s", decision.reason);
    room.frame.triangle_count++;
    previous.tree = NULL;
    previous.bih_pilot_replaced = 1;
    pf_bih_plan(&previous, &room.frame, &decision);
    PF_CHECK_MSG(has(&decision, "auto's pilot replaced"), "%s", decision.reason);
    pf_bih_free(&tree);
}

PF_TEST(lpv_settings_are_checked_against_the_device_limit)
{
    pf_stage_memory memory = {0};
    pf_render_settings settings = settings_of(PF_QUALITY_FAST);
    settings.lpv.size = 128;
    settings.lpv.cascades = 8;
    pf_stage_previous previous = first_frame(&memory);
    previous.max_buffer_range = 1u << 20; /* 1 MiB: 8 cascades of 128³ cannot fit */
    pf_stage_plan plan;
    pf_error err = {0};
    PF_CHECK(pf_plan_stages(&room.frame, &settings, &previous, &plan, &err) == PF_ERR_LIMIT);
    PF_CHECK(strstr(err.message, "device allows 1 MiB") != NULL);
    printf("  refused: %s\n", err.message);
    previous.max_buffer_range = 128u << 20;
    settings.lpv.size = 0;
    settings.lpv.cascades = 0;
    PF_CHECK_OK(pf_plan_stages(&room.frame, &settings, &previous, &plan, &err), &err);
    pf_stage_plan_release(&plan);
}

/* reference's plan on a device that is the CPU, its tree on the host, with AVX2. */
static pf_stage_previous cpu_device(pf_trace_site site)
{
    pf_stage_previous previous = first_frame(NULL);
    previous.trace_site = site;
    previous.device_is_host = 1;
    previous.host_traversal = 1;
    previous.tree_on_host = 1;
    return previous;
}

static void check_trace_of(pf_quality quality, const pf_stage_previous *previous, int host,
                           const char *reason)
{
    pf_render_settings settings = settings_of(quality);
    pf_stage_plan plan;
    pf_error err = {0};
    PF_CHECK(pf_plan_stages(&room.frame, &settings, previous, &plan, &err) == PF_OK);
    PF_CHECK_MSG(plan.host_traces == host && has(&plan.stages[PF_STAGE_SHADE], reason),
                 "host_traces %d, reason '%s' (expected %d, '%s')", plan.host_traces,
                 plan.stages[PF_STAGE_SHADE].reason, host, reason);
    pf_stage_plan_release(&plan);
}

static void check_trace(const pf_stage_previous *previous, int host, const char *reason)
{
    check_trace_of(PF_QUALITY_REFERENCE, previous, host, reason);
}

PF_TEST(reference_rays_go_where_they_are_traced_best)
{
    pf_stage_previous previous = cpu_device(PF_TRACE_AUTO);
    check_trace(&previous, 1, "path samples: 64 per pixel (the preset's default); wavefront, "
                              "rays traced on the host (the device is the CPU)");
    previous.device_is_host = 0;
    check_trace(&previous, 0, "; rays traced on the device (the device is not the CPU)");
    previous.trace_site = PF_TRACE_HOST;
    check_trace(&previous, 0, "; rays traced on the device (the device's memory is not the host's)");
    previous = cpu_device(PF_TRACE_DEVICE);
    check_trace(&previous, 0, "; rays traced on the device (forced)");
    previous = cpu_device(PF_TRACE_HOST);
    check_trace(&previous, 1, "rays traced on the host (forced)");
    previous.host_traversal = 0;
    check_trace(&previous, 0, "(this CPU has no AVX2 for the host's wide traversal)");
    previous = cpu_device(PF_TRACE_AUTO);
    previous.tree_on_host = 0;
    check_trace(&previous, 0, "(the BIH is built on the device)");
    previous = cpu_device(PF_TRACE_AUTO);
    /* Alpha-tested materials too: the kernels test the host's hits (test_trace_site). */
    room.materials[0].alpha_mode = PF_ALPHA_MASK;
    check_trace(&previous, 1, "rays traced on the host (the device is the CPU)");
    room.materials[0].alpha_mode = PF_ALPHA_OPAQUE;
}

/* reference's wavefront tail (plan of spp at width × height on previous): its paths' bound
 * or 0, and the reason's line for it checked. */
static uint32_t tail_of(const pf_stage_previous *previous, uint32_t spp, uint32_t width,
                        uint32_t height)
{
    pf_render_settings settings = settings_of(PF_QUALITY_REFERENCE);
    settings.samples_per_pixel = spp;
    settings.width = width;
    settings.height = height;
    pf_stage_plan plan;
    pf_error err = {0};
    uint32_t tail = UINT32_MAX;
    if (pf_plan_stages(&room.frame, &settings, previous, &plan, &err) == PF_OK) {
        tail = plan.wave_tail_paths;
        int said = has(&plan.stages[PF_STAGE_SHADE], "; a slice's last ≤ 512 paths traced on the "
                                                     "device");
        PF_CHECK_MSG(said == (tail > 0), "tail %u, reason '%s'", tail,
                     plan.stages[PF_STAGE_SHADE].reason);
        pf_stage_plan_release(&plan);
    }
    return tail;
}

PF_TEST(the_wavefront_tail_runs_where_it_pays_for_its_kernel)
{
    pf_stage_previous previous = cpu_device(PF_TRACE_AUTO);
    /* A tail a slice a pass: 64 passes of one slice are too few for a first compile... */
    PF_CHECK(tail_of(&previous, 64, 32, 24) == 0);
    PF_CHECK(tail_of(&previous, PF_REFERENCE_WAVE_TAIL_MIN_TAILS, 32, 24) ==
             PF_REFERENCE_WAVE_TAIL_PATHS);
    /* ... 32 passes of 4 slices (1024 × 1024 pixels) are enough... */
    PF_CHECK(tail_of(&previous, 32, 1024, 1024) == PF_REFERENCE_WAVE_TAIL_PATHS);
    PF_CHECK(tail_of(&previous, 31, 1024, 1024) == 0);
    /* ... as are 64 passes after the renderer's frames had 64 tails (a worker's job)... */
    previous.wave_tails_before = PF_REFERENCE_WAVE_TAIL_MIN_TAILS - 64;
    PF_CHECK(tail_of(&previous, 64, 32, 24) == PF_REFERENCE_WAVE_TAIL_PATHS);
    PF_CHECK(tail_of(&previous, 63, 32, 24) == 0);
    previous.wave_tails_before = 0;
    /* ... and once the kernel is compiled for the scene's surfaces, any frame has one. */
    uint32_t variant = pf_scene_frame_surface_features(&room.frame) % PF_SURFACE_VARIANTS;
    previous.wave_tail_compiled[0] = UINT64_C(1) << ((variant + 1u) % 64u);
    PF_CHECK(tail_of(&previous, 1, 32, 24) == 0);
    previous.wave_tail_compiled[0] = 0;
    previous.wave_tail_compiled[variant / 64u] = UINT64_C(1) << (variant % 64u);
    PF_CHECK(tail_of(&previous, 1, 32, 24) == PF_REFERENCE_WAVE_TAIL_PATHS);
    /* Past PF_DIRECT_LIGHTS_EVERY_MAX punctual lights (a vertex samples a few), a tail too,
     * once compiled for that frame's surfaces (another variant). */
    pf_light *own_lights = room.frame.lights;
    uint32_t own_count = room.frame.light_count;
    pf_light lights[PF_DIRECT_LIGHTS_EVERY_MAX + 1] = {0};
    for (uint32_t i = 0; i <= PF_DIRECT_LIGHTS_EVERY_MAX; i++)
        lights[i] = (pf_light){.position = {0.0f, 0.5f, 0.0f}, .kind = PF_LIGHT_POINT,
                               .intensity = {1.0f, 1.0f, 1.0f}};
    room.frame.lights = lights;
    room.frame.light_count = PF_DIRECT_LIGHTS_EVERY_MAX + 1;
    uint32_t many = pf_scene_frame_surface_features(&room.frame) % PF_SURFACE_VARIANTS;
    PF_CHECK(many != variant);
    PF_CHECK(tail_of(&previous, 1, 32, 24) == 0);
    previous.wave_tail_compiled[many / 64u] |= UINT64_C(1) << (many % 64u);
    PF_CHECK(tail_of(&previous, 1, 32, 24) == PF_REFERENCE_WAVE_TAIL_PATHS);
    memset(previous.wave_tail_compiled, 0, sizeof previous.wave_tail_compiled);
    PF_CHECK(tail_of(&previous, 64, 1024, 1024) == PF_REFERENCE_WAVE_TAIL_PATHS);
    room.frame.lights = own_lights;
    room.frame.light_count = own_count;
    /* Forced onto the host, or on the device, there is none. */
    previous.trace_site = PF_TRACE_HOST;
    PF_CHECK(tail_of(&previous, 1024, 32, 24) == 0);
    previous = cpu_device(PF_TRACE_DEVICE);
    PF_CHECK(tail_of(&previous, 1024, 32, 24) == 0);
}

/* The photon_trace row's reason (plan of quality on previous). */
static void check_photon_site(pf_quality quality, const pf_stage_previous *previous, int host,
                              const char *reason)
{
    pf_render_settings settings = settings_of(quality);
    pf_stage_plan plan;
    pf_error err = {0};
    PF_CHECK_OK(pf_plan_stages(&room.frame, &settings, previous, &plan, &err), &err);
    const char *said = plan.stages[PF_STAGE_PHOTON_TRACE].reason;
    PF_CHECK_MSG(plan.host_traces == host && strstr(said, reason),
                 "%s: host_traces %d, photon_trace '%s' (expected %d, '%s')",
                 pf_quality_name(quality), plan.host_traces, said, host, reason);
    pf_stage_plan_release(&plan);
}

/* final's camera and gather rays and final's and fast's photons, by the same rules; fast's
 * shading and preview trace on the device, unsaid. */
PF_TEST(final_and_fast_rays_go_where_they_are_traced_best)
{
    pf_stage_previous previous = cpu_device(PF_TRACE_AUTO);
    check_trace_of(PF_QUALITY_FINAL, &previous, 1,
                   "passes: 4 per pixel (the preset's default); camera and gather rays traced on "
                   "the host (the device is the CPU)");
    check_photon_site(PF_QUALITY_FINAL, &previous, 1,
                      "traced: first frame; photons traced on the host (the device is the CPU)");
    check_photon_site(PF_QUALITY_FAST, &previous, 1,
                      "traced: first frame; photons traced on the host (the device is the CPU)");
    previous.device_is_host = 0;
    check_trace_of(PF_QUALITY_FINAL, &previous, 0,
                   "; camera and gather rays traced on the device (the device is not the CPU)");
    check_photon_site(PF_QUALITY_FAST, &previous, 0,
                      "; photons traced on the device (the device is not the CPU)");
    previous = cpu_device(PF_TRACE_AUTO);
    previous.tree_on_host = 0;
    check_trace_of(PF_QUALITY_FINAL, &previous, 0, "(the BIH is built on the device)");
    check_photon_site(PF_QUALITY_FINAL, &previous, 0, "photons traced on the device (the BIH");
    previous = cpu_device(PF_TRACE_AUTO);
    pf_quality others[] = {PF_QUALITY_FAST, PF_QUALITY_PREVIEW};
    for (size_t q = 0; q < sizeof others / sizeof others[0]; q++) {
        pf_render_settings settings = settings_of(others[q]);
        pf_stage_plan plan;
        pf_error err = {0};
        PF_CHECK_OK(pf_plan_stages(&room.frame, &settings, &previous, &plan, &err), &err);
        PF_CHECK_MSG(!strstr(plan.stages[PF_STAGE_SHADE].reason, "traced"), "%s: shade '%s'",
                     pf_quality_name(others[q]), plan.stages[PF_STAGE_SHADE].reason);
        pf_stage_plan_release(&plan);
    }
}

int main(void)
{
    build_room();
    PF_RUN(a_first_frame_runs_every_stage_it_needs);
    PF_RUN(a_second_frame_reuses_what_did_not_change);
    PF_RUN(the_bih_decision_follows_the_kept_tree);
    PF_RUN(lpv_settings_are_checked_against_the_device_limit);
    PF_RUN(reference_rays_go_where_they_are_traced_best);
    PF_RUN(the_wavefront_tail_runs_where_it_pays_for_its_kernel);
    PF_RUN(final_and_fast_rays_go_where_they_are_traced_best);
    ref_scene_free(&room);
    return pf_test_finish();
}
