/*
 * GPU photon tracing: energy (in a closed diffuse box the first-bounce
 * photons carry the emitted power × albedo, within 1%), the storage rules
 * (no caustic map without specular surfaces; caustic photons behind a
 * mirror), colour kept through roulette, and the hard cases: a light
 * touching a wall, a zero-power light, a map budget beyond one buffer.
 */
#include "../vk/vk_test_util.h"
#include "pf_photon.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static pf_vk_context *ctx;
static pf_photon_tracer *tracer;
static pf_bih_gpu *bih_gpu;

/* A closed cube [-1, 1]³ of 12 triangles with material 0, plus up to 8 more triangles. */
typedef struct box_scene {
    pf_scene_frame frame;
    float vertices[60][4];
    float normals[60][4];
    uint32_t triangle_material[20];
    pf_material materials[2];
    pf_light lights[2];
} box_scene;

static void add_quad(box_scene *s, const float a[3], const float b[3], const float c[3],
                     const float d[3], uint32_t material)
{
    const float *corners[6] = {a, b, c, a, c, d};
    uint32_t t = s->frame.triangle_count;
    for (int i = 0; i < 6; i++) {
        for (int k = 0; k < 3; k++)
            s->vertices[3 * t + i][k] = corners[i][k];
        s->vertices[3 * t + i][3] = 0.0f;
    }
    s->triangle_material[t] = s->triangle_material[t + 1] = material;
    s->frame.triangle_count += 2;
}

static void box_init(box_scene *s, float albedo)
{
    memset(s, 0, sizeof *s);
    s->frame.vertices = s->vertices;
    s->frame.normals = s->normals; /* all zero: the face normal is used */
    s->frame.triangle_material = s->triangle_material;
    s->frame.materials = s->materials;
    s->frame.material_count = 2;
    s->frame.lights = s->lights;
    s->materials[0] = (pf_material){.albedo = {albedo, albedo, albedo}, .kind = PF_MATERIAL_LAMBERT,
                                    .ior = 1.5f};
    s->materials[1] = (pf_material){.albedo = {1, 1, 1}, .kind = PF_MATERIAL_MIRROR, .ior = 1.5f};
    const float p[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                           {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
    const int faces[6][4] = {{0, 1, 2, 3}, {4, 7, 6, 5}, {0, 4, 5, 1},
                             {3, 2, 6, 7}, {0, 3, 7, 4}, {1, 5, 6, 2}};
    for (int f = 0; f < 6; f++)
        add_quad(s, p[faces[f][0]], p[faces[f][1]], p[faces[f][2]], p[faces[f][3]], 0);
    for (int k = 0; k < 3; k++) {
        s->frame.bounds_min[k] = -1.0f;
        s->frame.bounds_max[k] = 1.0f;
    }
}

/* Uploads the scene and its BIH, traces, downloads the global map; returns the status. */
static pf_status trace_scene(const box_scene *s, const pf_photon_trace_settings *settings,
                             pf_photon_maps *maps, pf_photon **global, pf_photon **caustic,
                             pf_error *err)
{
    const pf_scene_frame *frame = &s->frame;
    pf_vk_buffer *buffers[5] = {0};
    const void *data[5] = {frame->vertices, frame->normals, frame->triangle_material,
                           frame->materials, frame->lights};
    uint64_t sizes[5] = {(uint64_t)frame->triangle_count * 48, (uint64_t)frame->triangle_count * 48,
                         (uint64_t)frame->triangle_count * 4, sizeof s->materials,
                         sizeof s->lights};
    pf_status status = PF_OK;
    for (int i = 0; status == PF_OK && i < 5; i++) {
        status = pf_vk_buffer_create(ctx, sizes[i], "test scene", &buffers[i], err);
        if (status == PF_OK)
            status = pf_vk_buffer_upload(ctx, buffers[i], 0, data[i], sizes[i], err);
    }
    pf_bih bih;
    pf_bih_build_options options = {0};
    if (status == PF_OK)
        status = pf_bih_build_cpu(frame, &options, &bih, err);
    if (status == PF_OK) {
        status = pf_bih_gpu_upload(bih_gpu, &bih, err);
        pf_bih_free(&bih);
    }
    pf_photon_scene scene = {buffers[0], buffers[1], buffers[2], buffers[3], buffers[4],
                             frame->triangle_count, {0}, 1e-4f};
    if (status == PF_OK)
        status = pf_bih_gpu_view_get(bih_gpu, &scene.bih, err);
    pf_photon_emitters emitters = {0};
    if (status == PF_OK)
        status = pf_photon_emitters_build(frame, &emitters, err);
    if (status == PF_OK)
        status = pf_photon_trace(tracer, &scene, &emitters, settings, maps, err);
    if (status == PF_OK)
        status = pf_photon_map_download(ctx, maps->global, maps->global_count, global, err);
    if (status == PF_OK)
        status = pf_photon_map_download(ctx, maps->caustic, maps->caustic_count, caustic, err);
    pf_photon_emitters_free(&emitters);
    for (int i = 0; i < 5; i++)
        pf_vk_buffer_destroy(ctx, buffers[i]);
    return status;
}

static void flux_sum(const pf_photon *photons, uint32_t count, double scale, double sum[3])
{
    sum[0] = sum[1] = sum[2] = 0.0;
    for (uint32_t i = 0; i < count; i++) {
        float position[3], flux[3], incoming[3], normal[3];
        pf_photon_unpack(&photons[i], position, flux, incoming, normal);
        for (int c = 0; c < 3; c++)
            sum[c] += flux[c] * scale;
    }
}

PF_TEST(first_bounce_flux_equals_power_times_albedo)
{
    box_scene s;
    box_init(&s, 0.5f);
    s.frame.light_count = 1;
    s.lights[0] = (pf_light){.position = {0.1f, 0.2f, -0.3f}, .kind = PF_LIGHT_POINT,
                             .intensity = {2.0f, 1.0f, 0.5f}};
    /* Two hits: photons are stored only at their second hit (the first bounce). */
    pf_photon_trace_settings settings = {.photon_count = 1000000, .seed = 7, .max_depth = 2};
    pf_photon_maps maps;
    pf_photon *global = NULL, *caustic = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(trace_scene(&s, &settings, &maps, &global, &caustic, &err), &err);
    double sum[3];
    flux_sum(global, maps.global_count, maps.flux_scale, sum);
    const double power[3] = {4 * M_PI * 2.0, 4 * M_PI * 1.0, 4 * M_PI * 0.5};
    for (int c = 0; c < 3; c++)
        PF_CHECK_MSG(fabs(sum[c] / (0.5 * power[c]) - 1.0) < 0.01,
                     "channel %d: stored %.4f W, expected %.4f W", c, sum[c], 0.5 * power[c]);
    printf("  stored %u photons (of %u emitted): %.4f %.4f %.4f W, expected %.4f %.4f %.4f\n",
           maps.global_count, maps.emitted, sum[0], sum[1], sum[2], 0.5 * power[0],
           0.5 * power[1], 0.5 * power[2]);
    PF_CHECK(maps.caustic_count == 0 && maps.caustic_offered == 0);
    PF_CHECK(maps.global_offered == maps.global_count);
    PF_CHECK(maps.non_finite == 0);
    /* Every photon lies on the box's surface. */
    uint32_t off_surface = 0;
    for (uint32_t i = 0; i < maps.global_count; i++) {
        float m = fmaxf(fabsf(global[i].position[0]),
                        fmaxf(fabsf(global[i].position[1]), fabsf(global[i].position[2])));
        off_surface += fabsf(m - 1.0f) > 1e-3f;
    }
    PF_CHECK_MSG(off_surface == 0, "%u photons off the walls", off_surface);
    free(global);
    free(caustic);
    pf_photon_maps_release(ctx, &maps);
}

PF_TEST(all_bounces_converge_to_the_closed_box_total)
{
    /*
     * A closed box with albedo a: the stored flux of all bounces after the
     * first sums to Φ (a + a² + …) = Φ a / (1 − a), truncated at max_depth
     * hits: Φ Σ_{k=1}^{depth-1} a^k.
     */
    box_scene s;
    box_init(&s, 0.5f);
    s.frame.light_count = 1;
    s.lights[0] = (pf_light){.position = {0.0f, 0.0f, 0.0f}, .kind = PF_LIGHT_POINT,
                             .intensity = {1.0f, 1.0f, 1.0f}};
    pf_photon_trace_settings settings = {.photon_count = 200000, .seed = 11, .max_depth = 8};
    pf_photon_maps maps;
    pf_photon *global = NULL, *caustic = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(trace_scene(&s, &settings, &maps, &global, &caustic, &err), &err);
    double sum[3];
    flux_sum(global, maps.global_count, maps.flux_scale, sum);
    double expected = 0.0;
    for (int k = 1; k < 8; k++)
        expected += pow(0.5, k);
    expected *= 4 * M_PI;
    PF_CHECK_MSG(fabs(sum[1] / expected - 1.0) < 0.01, "stored %.4f W, expected %.4f W", sum[1],
                 expected);
    free(global);
    free(caustic);
    pf_photon_maps_release(ctx, &maps);
}

PF_TEST(caustic_photons_need_a_specular_bounce)
{
    /* A mirror quad inside the box under a spot aimed at it: L S D photons go to the caustic map. */
    box_scene s;
    box_init(&s, 0.8f);
    const float a[3] = {-0.5f, -0.9f, -0.5f}, b[3] = {0.5f, -0.9f, -0.5f},
                c[3] = {0.5f, -0.9f, 0.5f}, d[3] = {-0.5f, -0.9f, 0.5f};
    add_quad(&s, a, d, c, b, 1);
    s.frame.light_count = 1;
    s.lights[0] = (pf_light){.position = {0.0f, 0.5f, 0.0f}, .kind = PF_LIGHT_SPOT,
                             .direction = {0.0f, -1.0f, 0.0f}, .intensity = {1.0f, 1.0f, 1.0f},
                             .cos_inner_cone = 0.95f, .cos_outer_cone = 0.9f};
    pf_photon_trace_settings settings = {.photon_count = 100000, .seed = 3, .max_depth = 2};
    pf_photon_maps maps;
    pf_photon *global = NULL, *caustic = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(trace_scene(&s, &settings, &maps, &global, &caustic, &err), &err);
    /*
     * The cone (half-angle 25.8°) from 1.4 m above the mirror covers a disk
     * of radius 0.68 m, most of it on the 1 m mirror. With two hits only
     * first-bounce photons are stored: L S D ones (off the mirror, so above
     * its plane) in both maps, L D D ones (off the floor) in the global map.
     */
    PF_CHECK_MSG(maps.caustic_count > settings.photon_count * 2 / 5, "%u caustic photons",
                 maps.caustic_count);
    PF_CHECK(maps.global_count > maps.caustic_count);
    uint32_t below_mirror = 0;
    for (uint32_t i = 0; i < maps.caustic_count; i++)
        below_mirror += caustic[i].position[1] < -0.9f;
    PF_CHECK_MSG(below_mirror == 0, "%u caustic photons below the mirror", below_mirror);
    free(global);
    free(caustic);
    pf_photon_maps_release(ctx, &maps);
}

PF_TEST(hard_cases_light_on_a_wall_zero_power_and_a_budget_beyond_memory)
{
    box_scene s;
    box_init(&s, 0.5f);
    s.frame.light_count = 1;
    /* Exactly on the floor: half the photons start below it, nothing crashes, loops stay bounded. */
    s.lights[0] = (pf_light){.position = {0.0f, -1.0f, 0.0f}, .kind = PF_LIGHT_POINT,
                             .intensity = {1.0f, 1.0f, 1.0f}};
    pf_photon_trace_settings settings = {.photon_count = 50000, .seed = 5};
    pf_photon_maps maps;
    pf_photon *global = NULL, *caustic = NULL;
    pf_error err = {0};
    PF_CHECK_OK(trace_scene(&s, &settings, &maps, &global, &caustic, &err), &err);
    PF_CHECK(maps.non_finite == 0);
    free(global);
    free(caustic);
    pf_photon_maps_release(ctx, &maps);

    s.lights[0].intensity[0] = s.lights[0].intensity[1] = s.lights[0].intensity[2] = 0.0f;
    PF_CHECK_OK(trace_scene(&s, &settings, &maps, &global, &caustic, &err), &err);
    PF_CHECK(maps.emitted == 0 && maps.global_count == 0 && maps.caustic_count == 0);
    pf_photon_maps_release(ctx, &maps);

    s.lights[0].intensity[0] = 1.0f;
    settings.global_capacity = (uint32_t)(pf_vk_info(ctx)->max_storage_buffer_range / 20) + 1;
    PF_CHECK(trace_scene(&s, &settings, &maps, &global, &caustic, &err) == PF_ERR_LIMIT);
    PF_CHECK_MSG(strstr(err.message, "fit") != NULL, "%s", err.message);
}

PF_TEST(irradiance_under_a_point_light_matches_the_closed_form)
{
    /* A plane 1 m below a point light: E = I h / d³; photons stored at their first hit. */
    box_scene s;
    box_init(&s, 0.5f);
    s.frame.triangle_count = 0;
    const float a[3] = {-4, 0, -4}, b[3] = {4, 0, -4}, c[3] = {4, 0, 4}, d[3] = {-4, 0, 4};
    add_quad(&s, a, b, c, d, 0);
    for (int k = 0; k < 3; k++) {
        s.frame.bounds_min[k] = k == 1 ? 0.0f : -4.0f;
        s.frame.bounds_max[k] = k == 1 ? 0.0f : 4.0f;
    }
    s.frame.light_count = 1;
    s.lights[0] = (pf_light){.position = {0.0f, 1.0f, 0.0f}, .kind = PF_LIGHT_POINT,
                             .intensity = {1.0f, 1.0f, 1.0f}};
    pf_photon_trace_settings settings = {.photon_count = 4000000, .seed = 21, .max_depth = 1,
                                         .store_direct = 1};
    pf_photon_maps maps;
    pf_photon *global = NULL, *caustic = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(trace_scene(&s, &settings, &maps, &global, &caustic, &err), &err);
    pf_photon_grid *grid = NULL;
    const float radius = 0.1f;
    PF_REQUIRE_OK(pf_photon_grid_create(ctx, &grid, &err), &err);
    PF_REQUIRE_OK(pf_photon_grid_build_device(grid, maps.global, maps.global_count,
                                              s.frame.bounds_min, s.frame.bounds_max, radius, &err),
                  &err);
    /* The centre, and 8 points on a ring of radius 0.5 m (same closed form, independent photons). */
    enum { RING = 8 };
    float queries[1 + RING][4], normals[1 + RING][4], irradiance[1 + RING][4];
    for (int q = 0; q <= RING; q++) {
        float angle = 6.2831853f * (float)q / RING;
        float rho = q == 0 ? 0.0f : 0.5f;
        queries[q][0] = rho * cosf(angle);
        queries[q][1] = 0.0f;
        queries[q][2] = rho * sinf(angle);
        queries[q][3] = radius;
        normals[q][0] = normals[q][2] = normals[q][3] = 0.0f;
        normals[q][1] = 1.0f;
    }
    PF_REQUIRE_OK(pf_photon_grid_irradiance(grid, queries, normals, 1 + RING, irradiance, &err),
                  &err);
    double centre = irradiance[0][1] * maps.flux_scale;
    double ring = 0.0;
    for (int q = 1; q <= RING; q++)
        ring += irradiance[q][1] * maps.flux_scale / RING;
    double ring_expected = 1.0 / pow(1.25, 1.5);
    printf("  irradiance: centre %.4f (closed form 1), ring %.4f (closed form %.4f), %u photons\n",
           centre, ring, ring_expected, maps.global_count);
    PF_CHECK_MSG(fabs(centre - 1.0) < 0.02, "centre %.4f W/m², closed form 1", centre);
    PF_CHECK_MSG(fabs(ring / ring_expected - 1.0) < 0.02, "ring %.4f, closed form %.4f", ring,
                 ring_expected);
    /* Seen from below (normal -y) the plane's photons arrived from the other side: none count. */
    for (int q = 0; q <= RING; q++)
        normals[q][1] = -1.0f;
    PF_REQUIRE_OK(pf_photon_grid_irradiance(grid, queries, normals, 1 + RING, irradiance, &err),
                  &err);
    PF_CHECK(irradiance[0][0] == 0.0f && irradiance[1][1] == 0.0f);
    pf_photon_grid_destroy(grid);
    free(global);
    free(caustic);
    pf_photon_maps_release(ctx, &maps);
}

int main(void)
{
    pf_error err = {0};
    ctx = vk_test_context(&err);
    if (!ctx || pf_photon_tracer_create(ctx, &tracer, &err) != PF_OK ||
        pf_bih_gpu_create(ctx, &bih_gpu, &err) != PF_OK) {
        fprintf(stderr, "setup: %s\n", err.message);
        return 1;
    }
    PF_RUN(first_bounce_flux_equals_power_times_albedo);
    PF_RUN(all_bounces_converge_to_the_closed_box_total);
    PF_RUN(caustic_photons_need_a_specular_bounce);
    PF_RUN(hard_cases_light_on_a_wall_zero_power_and_a_budget_beyond_memory);
    PF_RUN(irradiance_under_a_point_light_matches_the_closed_form);
    pf_bih_gpu_destroy(bih_gpu);
    pf_photon_tracer_destroy(tracer);
    VK_TEST_FINISH(ctx);
    return pf_test_finish();
}
