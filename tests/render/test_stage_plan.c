/*
 * The stage planner (core/render/stage_plan.c, issue 12 item 2): before a
 * frame renders, each stage of its preset is planned to run (its reason
 * naming what changed), to reuse the previous frame's output, or to be
 * skipped (what the scene lacks). Asserted on the rows' skipped flags,
 * reasons and counters, on a room built by hand (no shared scenes):
 *   - fast: first frame → every stage runs, "first frame"; the same frame
 *     again → everything but shade reused; a light moves → photons,
 *     injection and propagation run ("lights changed"), the geometry volume
 *     is reused; a material changes → "materials"; the seed → "seed";
 *     the camera crosses cells → only the LPV's cascade-bound stages run
 *     ("cascade origins"); a mirror moves → BIH refit, photons and geometry
 *     volume run ("geometry");
 *   - every row of every frame carries a reason; every preset reports each
 *     of its stages once, in order, whether run or reused;
 *   - final: two more passes than the previous frame → only those are
 *     traced ("passes 3–4", 2 reused), then the same 4 → all reused; a
 *     scene returning to earlier lights is recognised by content only
 *     against the frame right before it (the memory is one frame deep).
 * Validation must stay silent.
 */
#include "pf_render.h"
#include "pf_test.h"
#include "reference_test_util.h"
#include "render_test_env.h"

#include <stdio.h>
#include <string.h>

static pf_vk_context *ctx;
static pf_renderer *renderer;

#define WIDTH 16u
#define HEIGHT 12u

/* A closed room, a mirror quad (a caustic map) and a point light; the camera inside. */
static void build_room(ref_scene *room, float mirror_x)
{
    ref_scene_init(room);
    uint32_t white =
        ref_scene_add_material(room, ref_material(PF_MATERIAL_LAMBERT, 0.7f, 0.7f, 0.7f));
    uint32_t mirror =
        ref_scene_add_material(room, ref_material(PF_MATERIAL_MIRROR, 0.9f, 0.9f, 0.9f));
    const float min[3] = {-2.0f, -1.0f, -2.0f}, max[3] = {2.0f, 1.0f, 2.0f};
    ref_scene_add_box(room, min, max, 1, white);
    const float centre[3] = {mirror_x, -0.5f, -1.0f}, u[3] = {0.3f, 0.0f, 0.0f},
                v[3] = {0.0f, 0.3f, 0.0f};
    ref_scene_add_quad(room, centre, u, v, mirror);
    ref_scene_add_light(room, (pf_light){.position = {0.0f, 0.8f, 0.0f},
                                         .kind = PF_LIGHT_POINT,
                                         .intensity = {2.0f, 2.0f, 2.0f}});
    const float eye[3] = {0.0f, 0.0f, 1.5f}, target[3] = {0.0f, 0.0f, -1.0f},
                up[3] = {0.0f, 1.0f, 0.0f};
    ref_scene_look_at(room, eye, target, up, 1.0f);
}

static pf_render_settings settings_of(pf_quality quality, uint32_t spp, uint64_t seed)
{
    pf_render_settings settings = ref_settings(WIDTH, HEIGHT, spp, seed, 0);
    settings.quality = quality;
    settings.photons_per_pass = 4000;
    return settings;
}

static int render(const pf_scene_frame *frame, const pf_render_settings *settings,
                  pf_frame_report *report)
{
    pf_error err = {0};
    pf_image image = {0};
    memset(report, 0, sizeof *report);
    pf_status status = pf_render_frame(renderer, frame, settings, &image, report, &err);
    if (status != PF_OK)
        printf("  render: %s\n", err.message);
    pf_image_free(&image);
    return status == PF_OK;
}

/* Row `stage` ran (1) or was skipped (0) with a reason containing `part`. */
static int row_is(const pf_frame_report *report, const char *stage, int ran, const char *part)
{
    const pf_stage_timing *row = ref_row(report, stage);
    if (!row) {
        printf("  no %s row\n", stage);
        return 0;
    }
    if (row->skipped == !ran && strstr(row->reason, part))
        return 1;
    printf("  %s: %s, '%s' (expected %s with '%s')\n", stage, row->skipped ? "skipped" : "ran",
           row->reason, ran ? "ran" : "skipped", part);
    return 0;
}

/* Every row carries its reason: the planner's decision, or why it was skipped. */
static int every_row_has_a_reason(const pf_frame_report *report)
{
    for (uint32_t i = 0; i < report->stage_count; i++) {
        if (!report->stages[i].reason[0]) {
            printf("  %s has no reason\n", report->stages[i].stage);
            return 0;
        }
    }
    return report->stage_count > 0;
}

static const char *const lpv_stages[3] = {"lpv_geometry", "lpv_inject", "lpv_propagate"};

PF_TEST(fast_stages_run_only_for_what_changed)
{
    ref_scene room;
    build_room(&room, 0.0f);
    pf_render_settings settings = settings_of(PF_QUALITY_FAST, 1, 3);
    pf_frame_report report;

    PF_REQUIRE(render(&room.frame, &settings, &report));
    PF_CHECK(row_is(&report, "photon_trace", 1, "traced: first frame"));
    PF_CHECK(row_is(&report, "caustic_map", 1, "built: first frame"));
    PF_CHECK(row_is(&report, "lpv_geometry", 1, "built: first frame"));
    PF_CHECK(row_is(&report, "lpv_inject", 1, "injected: first frame"));
    PF_CHECK(row_is(&report, "lpv_propagate", 1, "propagated: first frame"));
    PF_CHECK(row_is(&report, "shade", 1, "camera samples: 1 per pixel (asked)"));
    PF_CHECK(every_row_has_a_reason(&report));

    /* The same frame: everything but the film is kept. */
    PF_REQUIRE(render(&room.frame, &settings, &report));
    PF_CHECK(row_is(&report, "bih_build", 0, "geometry unchanged"));
    PF_CHECK(row_is(&report, "photon_trace", 0, "unchanged"));
    PF_CHECK(row_is(&report, "caustic_map", 0, "unchanged"));
    for (int i = 0; i < 3; i++)
        PF_CHECK(row_is(&report, lpv_stages[i], 0, "unchanged"));
    PF_CHECK(row_is(&report, "shade", 1, "camera samples"));
    PF_CHECK(every_row_has_a_reason(&report));

    /* A light moves: photons and what they feed run again; the geometry volume does not. */
    room.lights[0].position[0] = 0.5f;
    PF_REQUIRE(render(&room.frame, &settings, &report));
    PF_CHECK(row_is(&report, "bih_build", 0, "geometry unchanged"));
    PF_CHECK(row_is(&report, "photon_trace", 1, "traced: lights changed"));
    PF_CHECK(row_is(&report, "caustic_map", 1, "built: lights changed"));
    PF_CHECK(row_is(&report, "lpv_geometry", 0, "unchanged"));
    PF_CHECK(row_is(&report, "lpv_inject", 1, "injected: lights changed"));
    PF_CHECK(row_is(&report, "lpv_propagate", 1, "propagated: lights changed"));

    /* A wall's colour changes: the photons (their reflected flux) again, named. */
    room.materials[0].albedo[0] = 0.4f;
    PF_REQUIRE(render(&room.frame, &settings, &report));
    PF_CHECK(row_is(&report, "photon_trace", 1, "traced: materials changed"));
    PF_CHECK(row_is(&report, "lpv_geometry", 0, "unchanged"));

    /* Another seed: only what depends on it. */
    settings.seed = 4;
    PF_REQUIRE(render(&room.frame, &settings, &report));
    PF_CHECK(row_is(&report, "photon_trace", 1, "traced: seed, photon count or bounces changed"));
    PF_CHECK(row_is(&report, "lpv_geometry", 0, "unchanged"));

    /* The camera crosses cells: the cascades follow it, the photons stay. */
    room.frame.camera.position[0] = 1.5f;
    room.frame.camera.position[2] = -1.5f;
    PF_REQUIRE(render(&room.frame, &settings, &report));
    PF_CHECK(row_is(&report, "bih_build", 0, "geometry unchanged"));
    PF_CHECK(row_is(&report, "photon_trace", 0, "unchanged"));
    PF_CHECK(row_is(&report, "lpv_geometry", 1, "built: cascade origins changed"));
    PF_CHECK(row_is(&report, "lpv_inject", 1, "injected: cascade origins changed"));
    PF_CHECK(row_is(&report, "lpv_propagate", 1, "propagated: cascade origins changed"));
    PF_CHECK(every_row_has_a_reason(&report));
    pf_camera camera = room.frame.camera;
    ref_scene_free(&room);

    /* The mirror moves (same triangle count): refit, and every geometry-bound stage. */
    ref_scene moved;
    build_room(&moved, 0.4f);
    moved.materials[0].albedo[0] = 0.4f;
    moved.frame.camera = camera;
    moved.lights[0].position[0] = 0.5f;
    PF_REQUIRE(render(&moved.frame, &settings, &report));
    PF_CHECK(row_is(&report, "bih_build", 1, "refit"));
    PF_CHECK(row_is(&report, "photon_trace", 1, "traced: geometry changed"));
    PF_CHECK(row_is(&report, "lpv_geometry", 1, "built: geometry changed"));
    PF_CHECK(row_is(&report, "lpv_propagate", 1, "geometry"));
    ref_scene_free(&moved);
}

PF_TEST(final_traces_only_the_passes_it_has_not_kept)
{
    ref_scene room;
    build_room(&room, 0.0f);
    pf_render_settings settings = settings_of(PF_QUALITY_FINAL, 2, 11);
    pf_frame_report report;
    PF_REQUIRE(render(&room.frame, &settings, &report));
    PF_CHECK(row_is(&report, "photon_trace", 1, "traced: first frame"));
    PF_CHECK(row_is(&report, "shade", 1, "passes: 2 per pixel (asked)"));
    PF_CHECK(ref_stage_counter(&report, "photon_trace", "traced_passes") == 2.0);

    settings.samples_per_pixel = 4;
    PF_REQUIRE(render(&room.frame, &settings, &report));
    PF_CHECK(row_is(&report, "photon_trace", 1,
                    "traced: passes 3–4 (1–2 kept from the previous frame)"));
    PF_CHECK(row_is(&report, "photon_grid", 1, "gridded: passes 3–4"));
    PF_CHECK(ref_stage_counter(&report, "photon_trace", "traced_passes") == 2.0);
    PF_CHECK(ref_stage_counter(&report, "photon_trace", "reused_passes") == 2.0);
    PF_CHECK(every_row_has_a_reason(&report));

    PF_REQUIRE(render(&room.frame, &settings, &report));
    PF_CHECK(row_is(&report, "photon_trace", 0, "photon maps reused"));
    PF_CHECK(row_is(&report, "photon_grid", 0, "photon grids reused"));
    PF_CHECK(ref_stage_counter(&report, "photon_trace", "reused_passes") == 4.0);

    /* The light changes and changes back: each time against the frame before it. */
    room.lights[0].intensity[1] = 1.0f;
    PF_REQUIRE(render(&room.frame, &settings, &report));
    PF_CHECK(row_is(&report, "photon_trace", 1, "traced: lights changed"));
    room.lights[0].intensity[1] = 2.0f;
    PF_REQUIRE(render(&room.frame, &settings, &report));
    PF_CHECK(row_is(&report, "photon_trace", 1, "traced: lights changed"));
    PF_CHECK(ref_stage_counter(&report, "photon_trace", "reused_passes") == 0.0);
    ref_scene_free(&room);
}

/* The rows of a frame, in order: every stage of the preset, run or skipped, each once. */
static int rows_are(const pf_frame_report *report, const char *const *names, uint32_t count)
{
    int same = report->stage_count == count;
    for (uint32_t i = 0; same && i < count; i++)
        same = !strcmp(report->stages[i].stage, names[i]);
    if (!same) {
        printf("  rows:");
        for (uint32_t i = 0; i < report->stage_count; i++)
            printf(" %s", report->stages[i].stage);
        printf("\n");
    }
    return same;
}

PF_TEST(every_preset_reports_each_of_its_stages_once_in_order)
{
    static const char *const preview[] = {"textures", "bih_build", "shade"};
    static const char *const reference[] = {"textures", "bih_build", "shade", "caustics"};
    static const char *const fast[] = {"textures",   "bih_build",     "photon_trace",
                                       "caustic_map", "lpv_geometry", "lpv_inject",
                                       "lpv_propagate", "shade"};
    static const char *const final[] = {"textures",    "bih_build", "photon_trace",
                                        "photon_grid", "caustic_map", "shade"};
    const struct {
        pf_quality quality;
        const char *const *rows;
        uint32_t count;
    } presets[] = {{PF_QUALITY_PREVIEW, preview, 3},
                   {PF_QUALITY_REFERENCE, reference, 4},
                   {PF_QUALITY_FAST, fast, 8},
                   {PF_QUALITY_FINAL, final, 6}};
    ref_scene room;
    build_room(&room, 0.0f);
    pf_frame_report report;
    for (size_t i = 0; i < sizeof presets / sizeof presets[0]; i++) {
        pf_render_settings settings = settings_of(presets[i].quality, 2, 5);
        for (int frame = 0; frame < 2; frame++) { /* run, then reused */
            PF_REQUIRE(render(&room.frame, &settings, &report));
            PF_CHECK_MSG(rows_are(&report, presets[i].rows, presets[i].count), "%s frame %d",
                         pf_quality_name(presets[i].quality), frame + 1);
            PF_CHECK(report.quality == presets[i].quality);
        }
    }
    ref_scene_free(&room);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(fast_stages_run_only_for_what_changed);
    PF_RUN(final_traces_only_the_passes_it_has_not_kept);
    PF_RUN(every_preset_reports_each_of_its_stages_once_in_order);
    return render_test_finish(ctx, renderer);
}
