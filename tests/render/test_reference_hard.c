/*
 * Hard cases of the reference path tracer (issue 5):
 * - lights inside a closed mesh: nothing escapes, the outside stays black;
 * - lights exactly on a surface (a point light in a wall's plane, an emitter
 *   coplanar with a wall): finite image, discards counted;
 * - the camera inside a closed mesh: finite, covered image; a light outside
 *   does not get in;
 * - degenerate shading normals (zero, NaN, Inf) and zero-area triangles (one
 *   of them emissive): no NaN/Inf in any channel, and the report's discard
 *   count agrees with the shade row's.
 * Every image must also satisfy the layer invariants (R = direct + indirect,
 * caustic ≤ indirect, nothing negative).
 */
#include "pf_test.h"
#include "reference_test_util.h"
#include "render_test_env.h"

#include <math.h>
#include <string.h>

static pf_vk_context *ctx;
static pf_renderer *renderer;

#define EDGE 40u
#define SPP 16u

/*
 * Renders scene (with AOVs) and checks what holds for any scene: success,
 * finite values and layer invariants, a discard count equal in the report and
 * the shade row and at most the number of paths.
 */
static int render_checked(const ref_scene *scene, uint64_t seed, const char *what,
                          pf_image *image, pf_frame_report *report)
{
    pf_render_settings settings = ref_settings(EDGE, EDGE, SPP, seed, 1);
    pf_error err = {0};
    memset(report, 0, sizeof *report);
    if (pf_render_frame(renderer, &scene->frame, &settings, image, report, &err) != PF_OK) {
        PF_CHECK_MSG(0, "%s: %s", what, err.message);
        return 0;
    }
    size_t non_finite = ref_image_non_finite(image);
    PF_CHECK_MSG(non_finite == 0, "%s: %zu non-finite values", what, non_finite);
    PF_CHECK_MSG(ref_layer_violations(image, what) == 0, "%s: layer invariants broken", what);
    double counted = ref_stage_counter(report, "shade", "discarded_samples");
    double paths = ref_stage_counter(report, "shade", "paths");
    PF_CHECK_MSG(counted == (double)report->discarded_samples,
                 "%s: report says %llu discarded samples, the shade row %g", what,
                 (unsigned long long)report->discarded_samples, counted);
    PF_CHECK_MSG(paths == (double)EDGE * EDGE * SPP, "%s: %g paths", what, paths);
    PF_CHECK_MSG(counted <= paths, "%s: %g of %g samples discarded", what, counted, paths);
    printf("  %s: %llu of %g samples discarded\n", what,
           (unsigned long long)report->discarded_samples, paths);
    return 1;
}

/* Pixels with any nonzero value in R, G, B or the direct/indirect/caustic layers. */
static uint32_t lit_pixels(const pf_image *image)
{
    static const char *const names[] = {"R",          "G",          "B",         "direct.R",
                                        "direct.G",   "direct.B",   "indirect.R", "indirect.G",
                                        "indirect.B", "caustic.R",  "caustic.G", "caustic.B"};
    uint32_t lit = 0;
    for (uint32_t y = 0; y < image->height; y++) {
        for (uint32_t x = 0; x < image->width; x++) {
            int any = 0;
            for (size_t n = 0; n < sizeof names / sizeof names[0]; n++) {
                int channel = pf_image_channel(image, names[n]);
                any |= channel < 0 || ref_pixel(image, channel, x, y) != 0.0;
            }
            lit += any;
        }
    }
    return lit;
}

/* Appends a Lambert material of albedo (r, g, b); returns its index. */
static uint32_t lambert(ref_scene *scene, float r, float g, float b)
{
    return ref_scene_add_material(scene, ref_material(PF_MATERIAL_LAMBERT, r, g, b));
}

/* A 10 m × 10 m Lambert floor at z = 0 facing up. */
static void add_floor(ref_scene *scene)
{
    uint32_t material = lambert(scene, 0.8f, 0.8f, 0.8f);
    const float centre[3] = {0, 0, 0}, half_u[3] = {5, 0, 0}, half_v[3] = {0, 5, 0};
    ref_scene_add_quad(scene, centre, half_u, half_v, material);
}

PF_TEST(lights_inside_a_closed_box_light_nothing_outside)
{
    ref_scene scene;
    ref_scene_init(&scene);
    add_floor(&scene);
    /* A closed box just above the floor; inside, a point light and two emitters,
     * one facing down, one facing a wall from 1 cm away. */
    uint32_t walls = lambert(&scene, 0.7f, 0.7f, 0.7f);
    const float box_min[3] = {-0.5f, -0.5f, 0.01f}, box_max[3] = {0.5f, 0.5f, 1.01f};
    ref_scene_add_box(&scene, box_min, box_max, 0, walls);
    ref_scene_add_light(&scene, (pf_light){{0.1f, -0.1f, 0.5f}, PF_LIGHT_POINT, {0, 0, -1}, 0,
                                           {50, 50, 50}, 1, 1});
    uint32_t emitter = ref_scene_add_material(&scene, ref_material_emitter(20, 20, 20));
    const float down_centre[3] = {0, 0, 0.9f}, down_u[3] = {0.1f, 0, 0}, down_v[3] = {0, -0.1f, 0};
    ref_scene_add_quad(&scene, down_centre, down_u, down_v, emitter);
    const float side_centre[3] = {0.49f, 0, 0.5f}, side_u[3] = {0, 0.1f, 0},
                side_v[3] = {0, 0, 0.1f};
    ref_scene_add_quad(&scene, side_centre, side_u, side_v, emitter);
    const float eye[3] = {2.5f, -3.0f, 2.0f}, target[3] = {0, 0, 0.4f}, up_hint[3] = {0, 0, 1};
    ref_scene_look_at(&scene, eye, target, up_hint, 0.8f);
    pf_image image = {0};
    pf_frame_report report;
    if (render_checked(&scene, 41, "lights in a box", &image, &report)) {
        PF_CHECK_MSG(lit_pixels(&image) == 0, "%u of %u pixels receive light from inside the box",
                     lit_pixels(&image), EDGE * EDGE);
        /* The box is in view: its centre pixel is covered. */
        PF_CHECK(ref_pixel(&image, pf_image_channel(&image, "A"), EDGE / 2, EDGE / 2) == 1.0);
    }
    pf_image_free(&image);
    ref_scene_free(&scene);
}

PF_TEST(lights_exactly_on_a_surface_stay_finite)
{
    ref_scene scene;
    ref_scene_init(&scene);
    add_floor(&scene);
    /* Back wall in the plane y = 1, facing -y (towards the camera). */
    uint32_t wall = lambert(&scene, 0.6f, 0.5f, 0.4f);
    const float wall_centre[3] = {0, 1, 1}, wall_u[3] = {2, 0, 0}, wall_v[3] = {0, 0, 1};
    ref_scene_add_quad(&scene, wall_centre, wall_u, wall_v, wall);
    /* An emitter coplanar with the wall, overlapping it, facing the same way. */
    uint32_t emitter = ref_scene_add_material(&scene, ref_material_emitter(5, 5, 5));
    const float patch_centre[3] = {0.5f, 1, 1.2f}, patch_u[3] = {0.3f, 0, 0},
                patch_v[3] = {0, 0, 0.3f};
    ref_scene_add_quad(&scene, patch_centre, patch_u, patch_v, emitter);
    /* Point lights exactly in the wall's plane and in the floor's plane. */
    ref_scene_add_light(&scene, (pf_light){{-0.5f, 1.0f, 0.5f}, PF_LIGHT_POINT, {0, 0, -1}, 0,
                                           {4, 4, 4}, 1, 1});
    ref_scene_add_light(&scene, (pf_light){{0.3f, 0.2f, 0.0f}, PF_LIGHT_POINT, {0, 0, -1}, 0,
                                           {4, 4, 4}, 1, 1});
    const float eye[3] = {0, -2.0f, 1.0f}, target[3] = {0, 1, 0.5f}, up_hint[3] = {0, 0, 1};
    ref_scene_look_at(&scene, eye, target, up_hint, 1.0f);
    pf_image image = {0};
    pf_frame_report report;
    if (render_checked(&scene, 42, "lights on surfaces", &image, &report)) {
        /* The wall light still lights the floor, the floor light the wall. */
        PF_CHECK(lit_pixels(&image) > EDGE * EDGE / 2);
    }
    pf_image_free(&image);
    ref_scene_free(&scene);
}

PF_TEST(camera_inside_a_closed_box)
{
    ref_scene scene;
    ref_scene_init(&scene);
    /* Faces out: the camera at the centre sees only back faces. */
    uint32_t walls = lambert(&scene, 0.6f, 0.6f, 0.6f);
    const float box_min[3] = {-1, -1, -1}, box_max[3] = {1, 1, 1};
    ref_scene_add_box(&scene, box_min, box_max, 0, walls);
    /* Lights outside only: a point light above, a directional light, an emitter
     * facing the box. None may get in. */
    ref_scene_add_light(&scene, (pf_light){{0.2f, 0.1f, 3.0f}, PF_LIGHT_POINT, {0, 0, -1}, 0,
                                           {100, 100, 100}, 1, 1});
    ref_scene_add_light(&scene, (pf_light){{0, 0, 0}, PF_LIGHT_DIRECTIONAL, {0.3f, 0.4f, -0.866f},
                                           0, {5, 5, 5}, 1, 1});
    uint32_t emitter = ref_scene_add_material(&scene, ref_material_emitter(10, 10, 10));
    const float outside_centre[3] = {0, -1.5f, 0}, outside_u[3] = {-0.5f, 0, 0},
                outside_v[3] = {0, 0, 0.5f};
    ref_scene_add_quad(&scene, outside_centre, outside_u, outside_v, emitter);
    const float eye[3] = {0.1f, 0.05f, 0.0f}, target[3] = {0.3f, 1.0f, -0.2f},
                up_hint[3] = {0, 0, 1};
    ref_scene_look_at(&scene, eye, target, up_hint, 1.4f);
    pf_image image = {0};
    pf_frame_report report;
    const ref_region whole = {0, 0, EDGE, EDGE};
    if (render_checked(&scene, 43, "camera in a box, lights outside", &image, &report)) {
        PF_CHECK(ref_region_stats(&image, pf_image_channel(&image, "A"), whole).mean == 1.0);
        PF_CHECK_MSG(lit_pixels(&image) == 0, "%u of %u pixels receive light from outside",
                     lit_pixels(&image), EDGE * EDGE);
    }
    pf_image_free(&image);
    /* A light inside as well: whatever the walls show, the image is finite and covered. */
    ref_scene_add_light(&scene, (pf_light){{-0.3f, 0.2f, 0.4f}, PF_LIGHT_POINT, {0, 0, -1}, 0,
                                           {3, 3, 3}, 1, 1});
    if (render_checked(&scene, 44, "camera in a box, light inside", &image, &report))
        PF_CHECK(ref_region_stats(&image, pf_image_channel(&image, "A"), whole).mean == 1.0);
    pf_image_free(&image);
    ref_scene_free(&scene);
}

/* Overwrites the three vertex normals of triangle t. */
static void set_normals(ref_scene *scene, uint32_t t, float value)
{
    for (int corner = 0; corner < 3; corner++)
        for (int k = 0; k < 3; k++)
            scene->frame.normals[3 * t + corner][k] = value;
}

PF_TEST(degenerate_normals_and_triangles_never_reach_the_film)
{
    ref_scene scene;
    ref_scene_init(&scene);
    add_floor(&scene); /* triangles 0, 1 */
    uint32_t grey = lambert(&scene, 0.5f, 0.5f, 0.5f);
    uint32_t glass = ref_scene_add_material(&scene, ref_material(PF_MATERIAL_GLASS, 1, 1, 1));
    uint32_t mirror =
        ref_scene_add_material(&scene, ref_material(PF_MATERIAL_MIRROR, 0.9f, 0.9f, 0.9f));
    uint32_t emitter = ref_scene_add_material(&scene, ref_material_emitter(8, 8, 8));
    const float lambert_min[3] = {-1.0f, -0.3f, 0}, lambert_max[3] = {-0.4f, 0.3f, 0.6f};
    ref_scene_add_box(&scene, lambert_min, lambert_max, 0, grey); /* triangles 2..13 */
    const float glass_min[3] = {-0.2f, -0.3f, 0}, glass_max[3] = {0.3f, 0.2f, 0.5f};
    ref_scene_add_box(&scene, glass_min, glass_max, 0, glass); /* 14..25 */
    const float mirror_min[3] = {0.5f, -0.2f, 0}, mirror_max[3] = {1.0f, 0.3f, 0.7f};
    ref_scene_add_box(&scene, mirror_min, mirror_max, 0, mirror); /* 26..37 */
    /* The light: an emitter facing down, and a point light. */
    const float light_centre[3] = {0, 0, 2.0f}, light_u[3] = {0.4f, 0, 0},
                light_v[3] = {0, -0.4f, 0};
    ref_scene_add_quad(&scene, light_centre, light_u, light_v, emitter); /* 38, 39 */
    ref_scene_add_light(&scene, (pf_light){{-0.5f, -1.0f, 1.5f}, PF_LIGHT_POINT, {0, 0, -1}, 0,
                                           {3, 3, 3}, 1, 1});
    /* Zero-area triangles: collinear corners (a grey one and an emissive one)
     * and one collapsed to a point, all in view. */
    const float line_a[3] = {-0.5f, -0.6f, 0.2f}, line_b[3] = {0.0f, -0.6f, 0.4f},
                line_c[3] = {0.5f, -0.6f, 0.6f};
    ref_scene_add_triangle(&scene, line_a, line_b, line_c, grey);    /* 40 */
    ref_scene_add_triangle(&scene, line_c, line_b, line_a, emitter); /* 41 */
    ref_scene_add_triangle(&scene, line_b, line_b, line_b, grey);    /* 42 */
    /* Injected shading normals: zero, NaN and Inf on triangles of every material. */
    const float zero = 0.0f, not_a_number = NAN, infinite = INFINITY;
    set_normals(&scene, 0, zero);          /* half the floor */
    set_normals(&scene, 3, not_a_number);  /* Lambert box */
    set_normals(&scene, 10, zero);
    set_normals(&scene, 12, infinite);
    set_normals(&scene, 14, not_a_number); /* glass box */
    set_normals(&scene, 17, zero);
    set_normals(&scene, 24, infinite);
    set_normals(&scene, 26, zero);         /* mirror box */
    set_normals(&scene, 33, not_a_number);
    set_normals(&scene, 38, not_a_number); /* the emitter */
    const float eye[3] = {0.3f, -2.5f, 1.6f}, target[3] = {0, 0, 0.3f}, up_hint[3] = {0, 0, 1};
    ref_scene_look_at(&scene, eye, target, up_hint, 1.0f);
    pf_image image = {0};
    pf_frame_report report;
    if (render_checked(&scene, 45, "degenerate normals", &image, &report)) {
        /* The scene is lit and in view: the guard must not blank it. */
        PF_CHECK(lit_pixels(&image) > EDGE * EDGE / 2);
    }
    pf_image_free(&image);
    ref_scene_free(&scene);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(lights_inside_a_closed_box_light_nothing_outside);
    PF_RUN(lights_exactly_on_a_surface_stay_finite);
    PF_RUN(camera_inside_a_closed_box);
    PF_RUN(degenerate_normals_and_triangles_never_reach_the_film);
    return render_test_finish(ctx, renderer);
}
