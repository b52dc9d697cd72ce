/*
 * The reference path tracer (pf_render_frame, quality reference): the white
 * furnace (inside a closed emitting sphere of albedo a every pixel is
 * Le/(1 − a)), determinism per seed, the channel contract (R = direct +
 * indirect, caustic ⊆ indirect), and convergence on the Cornell box: a 2×
 * longer render agrees with a shorter one within the noise that the sample
 * count predicts. Validation must stay silent.
 */
#include "pf_render.h"
#include "pf_test.h"
#include "render_test_env.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define PI_D 3.14159265358979323846

static pf_vk_context *ctx;
static pf_renderer *renderer;

/* A frame over caller-owned arrays (released by sphere_free). */
typedef struct test_frame {
    pf_scene_frame frame;
    pf_material material;
} test_frame;

/*
 * A closed UV sphere of radius 1 around the origin whose triangles face
 * inwards (counter-clockwise seen from inside), one Lambert material of
 * albedo `albedo` emitting `emission`, camera at the centre looking down -z.
 */
#define SPHERE_STACKS 12u
#define SPHERE_SLICES 24u

static void sphere_point(uint32_t stack, uint32_t slice, float out[3])
{
    double theta = PI_D * stack / SPHERE_STACKS;
    double phi = 2.0 * PI_D * slice / SPHERE_SLICES;
    out[0] = (float)(sin(theta) * cos(phi));
    out[1] = (float)cos(theta);
    out[2] = (float)(sin(theta) * sin(phi));
}

static void frame_add_triangle(pf_scene_frame *frame, const float *a, const float *b,
                               const float *c)
{
    uint32_t t = frame->triangle_count++;
    const float *corners[3] = {a, b, c};
    float e1[3], e2[3], n[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = b[k] - a[k];
        e2[k] = c[k] - a[k];
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    float length = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int corner = 0; corner < 3; corner++) {
        for (int k = 0; k < 3; k++) {
            frame->vertices[3 * t + corner][k] = corners[corner][k];
            frame->vertices[3 * t + corner][3] = 0.0f;
            frame->normals[3 * t + corner][k] = n[k] / length;
            frame->normals[3 * t + corner][3] = 0.0f;
        }
    }
    frame->triangle_material[t] = 0;
}

static void sphere_make(test_frame *scene, float albedo, float emission)
{
    memset(scene, 0, sizeof *scene);
    pf_scene_frame *frame = &scene->frame;
    uint32_t capacity = 2 * SPHERE_STACKS * SPHERE_SLICES;
    frame->vertices = calloc(3 * capacity, sizeof *frame->vertices);
    frame->normals = calloc(3 * capacity, sizeof *frame->normals);
    frame->triangle_material = calloc(capacity, sizeof *frame->triangle_material);
    PF_REQUIRE(frame->vertices && frame->normals && frame->triangle_material);
    for (uint32_t stack = 0; stack < SPHERE_STACKS; stack++) {
        for (uint32_t slice = 0; slice < SPHERE_SLICES; slice++) {
            float p00[3], p01[3], p10[3], p11[3];
            sphere_point(stack, slice, p00);
            sphere_point(stack, slice + 1, p01);
            sphere_point(stack + 1, slice, p10);
            sphere_point(stack + 1, slice + 1, p11);
            /* Seen from the centre these run counter-clockwise: normals point inwards. */
            if (stack > 0)
                frame_add_triangle(frame, p00, p10, p01);
            if (stack + 1 < SPHERE_STACKS)
                frame_add_triangle(frame, p01, p10, p11);
        }
    }
    scene->material = (pf_material){{albedo, albedo, albedo}, PF_MATERIAL_LAMBERT,
                                    {emission, emission, emission}, 1.5f};
    frame->materials = &scene->material;
    frame->material_count = 1;
    frame->emissive_triangle_count = frame->triangle_count;
    for (int k = 0; k < 3; k++) {
        frame->bounds_min[k] = -1.0f;
        frame->bounds_max[k] = 1.0f;
    }
    frame->camera = (pf_camera){{0, 0, 0}, {0, 0, -1}, {0, 1, 0}, {1, 0, 0}, 1.2f, 0, 0.01f, 0};
}

static void sphere_free(test_frame *scene)
{
    free(scene->frame.vertices);
    free(scene->frame.normals);
    free(scene->frame.triangle_material);
}

static double counter(const pf_frame_report *report, const char *stage, const char *name)
{
    for (uint32_t s = 0; s < report->stage_count; s++) {
        if (strcmp(report->stages[s].stage, stage))
            continue;
        for (uint32_t c = 0; c < report->stages[s].counter_count; c++) {
            if (!strcmp(report->stages[s].counters[c].name, name))
                return report->stages[s].counters[c].value;
        }
    }
    return -1.0;
}

/* Emission Le = 1 inside a closed sphere: L = Le / (1 − a), every pixel, within 1 %. */
#define FURNACE_WIDTH 4u
#define FURNACE_HEIGHT 4u
#define FURNACE_SPP 1024u
#define FURNACE_TOLERANCE 0.01

static void check_furnace(float albedo)
{
    test_frame scene;
    sphere_make(&scene, albedo, 1.0f);
    pf_render_settings settings = {FURNACE_WIDTH, FURNACE_HEIGHT, PF_QUALITY_REFERENCE,
                                   FURNACE_SPP,   11,             0,
                                   0.0};
    pf_image image = {0};
    pf_frame_report report = {0};
    pf_error err = {0};
    double start = pf_time_ms();
    PF_REQUIRE_OK(pf_render_frame(renderer, &scene.frame, &settings, &image, &report, &err), &err);
    double elapsed = pf_time_ms() - start;
    double expected = 1.0 / (1.0 - albedo);
    double worst = 0.0, mean = 0.0;
    for (size_t p = 0; p < (size_t)FURNACE_WIDTH * FURNACE_HEIGHT; p++) {
        const float *pixel = image.pixels + p * image.channel_count;
        for (int c = 0; c < 3; c++) {
            double error = fabs(pixel[c] / expected - 1.0);
            worst = error > worst ? error : worst;
            mean += pixel[c];
        }
        PF_CHECK(pixel[3] == 1.0f);
    }
    mean /= 3.0 * FURNACE_WIDTH * FURNACE_HEIGHT;
    PF_CHECK_MSG(worst < FURNACE_TOLERANCE,
                 "albedo %.2f: worst pixel off by %.4f (expected %.4f, image mean %.5f)", albedo,
                 worst, expected, mean);
    PF_CHECK(report.discarded_samples == 0);
    PF_CHECK(counter(&report, "shade", "samples_per_pixel") == FURNACE_SPP);
    double paths = counter(&report, "shade", "paths");
    PF_CHECK(paths == (double)FURNACE_SPP * FURNACE_WIDTH * FURNACE_HEIGHT);
    printf("  furnace a=%.2f: expected %.4f, mean %.5f, worst pixel %.3f%%, %.0f rays, "
           "%.0f paths/s\n",
           albedo, expected, mean, 100.0 * worst, counter(&report, "shade", "rays"),
           paths / (elapsed / 1000.0));
    pf_image_free(&image);
    sphere_free(&scene);
}

PF_TEST(white_furnace_converges_to_le_over_one_minus_albedo)
{
    check_furnace(0.5f);
    check_furnace(0.8f);
}

/*
 * Renders the Cornell box shipped with the project (scenes/cornell); with
 * zoom > 1 the field of view is narrowed by that factor.
 */
static pf_status cornell_render_zoomed(const pf_render_settings *settings, float zoom,
                                       pf_image *image, pf_frame_report *report, pf_error *err)
{
    const char *source = getenv("PF_SOURCE_DIR");
    char path[1024];
    snprintf(path, sizeof path, "%s/scenes/cornell/cornell.gltf", source ? source : ".");
    pf_scene *scene = NULL;
    pf_status status = pf_scene_load(path, &scene, err);
    if (status != PF_OK)
        return status;
    pf_scene_frame frame = {0};
    status = pf_scene_eval(scene, 0.0, &frame, err);
    if (status == PF_OK) {
        frame.camera.yfov /= zoom;
        status = pf_render_frame(renderer, &frame, settings, image, report, err);
        pf_scene_frame_free(&frame);
    }
    pf_scene_destroy(scene);
    return status;
}

static pf_status cornell_render(const pf_render_settings *settings, pf_image *image,
                                pf_frame_report *report, pf_error *err)
{
    return cornell_render_zoomed(settings, 1.0f, image, report, err);
}

#define CORNELL_WIDTH 48u
#define CORNELL_HEIGHT 36u

PF_TEST(same_seed_same_image_other_seed_other_image)
{
    pf_render_settings settings = {24, 18, PF_QUALITY_REFERENCE, 4, 5, 1, 0.0};
    pf_image first = {0}, second = {0}, other = {0};
    pf_error err = {0};
    PF_REQUIRE_OK(cornell_render(&settings, &first, NULL, &err), &err);
    PF_REQUIRE_OK(cornell_render(&settings, &second, NULL, &err), &err);
    settings.seed = 6;
    PF_REQUIRE_OK(cornell_render(&settings, &other, NULL, &err), &err);
    PF_REQUIRE(first.channel_count == 20 && other.channel_count == 20);
    size_t bytes = (size_t)first.width * first.height * first.channel_count * sizeof(float);
    PF_CHECK(memcmp(first.pixels, second.pixels, bytes) == 0);
    PF_CHECK(memcmp(first.pixels, other.pixels, bytes) != 0);
    pf_image_free(&first);
    pf_image_free(&second);
    pf_image_free(&other);
}

PF_TEST(channels_follow_the_contract)
{
    static const char *const names[] = {
        "R",          "G",          "B",          "A",         "direct.R",  "direct.G",
        "direct.B",   "indirect.R", "indirect.G", "indirect.B", "caustic.R", "caustic.G",
        "caustic.B",  "albedo.R",   "albedo.G",   "albedo.B",  "normal.X",  "normal.Y",
        "normal.Z",   "depth.Z"};
    pf_render_settings settings = {24, 18, PF_QUALITY_REFERENCE, 8, 3, 1, 0.0};
    pf_image image = {0};
    pf_frame_report report = {0};
    pf_error err = {0};
    PF_REQUIRE_OK(cornell_render(&settings, &image, &report, &err), &err);
    PF_REQUIRE(image.channel_count == sizeof names / sizeof names[0]);
    for (uint32_t c = 0; c < image.channel_count; c++)
        PF_CHECK_MSG(!strcmp(image.channel_names[c], names[c]), "channel %u is %s, expected %s",
                     c, image.channel_names[c], names[c]);
    uint32_t broken = 0;
    double direct = 0.0, indirect = 0.0, caustic = 0.0, covered = 0.0;
    for (size_t p = 0; p < (size_t)image.width * image.height; p++) {
        const float *pixel = image.pixels + p * image.channel_count;
        for (int c = 0; c < 3; c++) {
            /* Exactly the float sum; caustic within indirect; nothing negative. */
            broken += pixel[c] != pixel[4 + c] + pixel[7 + c];
            broken += !(pixel[4 + c] >= 0.0f && pixel[7 + c] >= 0.0f && pixel[10 + c] >= 0.0f);
            broken += pixel[10 + c] > pixel[7 + c];
            direct += pixel[4 + c];
            indirect += pixel[7 + c];
            caustic += pixel[10 + c];
        }
        broken += !(pixel[3] >= 0.0f && pixel[3] <= 1.0f);
        covered += pixel[3];
    }
    PF_CHECK_MSG(broken == 0, "%u channel values break the contract", broken);
    /* The Cornell box is all Lambert: light bounces (indirect) but never focuses (caustic). */
    PF_CHECK(direct > 0.0 && indirect > 0.0);
    PF_CHECK(caustic == 0.0);
    PF_CHECK(covered > 0.0);
    PF_REQUIRE(report.stage_count == 4);
    /* No textures: the textures row is skipped with its reason. */
    PF_CHECK(!strcmp(report.stages[0].stage, "textures") && report.stages[0].skipped &&
             strstr(report.stages[0].reason, "no textures"));
    PF_CHECK(!strcmp(report.stages[1].stage, "bih_build"));
    PF_CHECK(!strcmp(report.stages[2].stage, "shade"));
    /* No mirror or glass: the caustics row is skipped with its reason. */
    PF_CHECK(!strcmp(report.stages[3].stage, "caustics") && report.stages[3].skipped &&
             strstr(report.stages[3].reason, "no specular"));
    PF_CHECK(counter(&report, "shade", "samples_per_pixel") == 8);
    PF_CHECK(counter(&report, "shade", "rays") >= 8.0 * 24 * 18);
    PF_CHECK(counter(&report, "shade", "discarded_samples") == 0);
    pf_image_free(&image);

    settings.aovs = 0;
    PF_REQUIRE_OK(cornell_render(&settings, &image, NULL, &err), &err);
    PF_CHECK(image.channel_count == 13);
    pf_image_free(&image);
}

/* Mean over the image's R, G, B of (a − b)². */
static double image_mse(const pf_image *a, const pf_image *b)
{
    double sum = 0.0;
    size_t pixels = (size_t)a->width * a->height;
    for (size_t p = 0; p < pixels; p++) {
        for (int c = 0; c < 3; c++) {
            double d = (double)a->pixels[p * a->channel_count + c] -
                       b->pixels[p * b->channel_count + c];
            sum += d * d;
        }
    }
    return sum / (3.0 * pixels);
}

static double image_mean_difference(const pf_image *a, const pf_image *b)
{
    double sum = 0.0;
    size_t pixels = (size_t)a->width * a->height;
    for (size_t p = 0; p < pixels; p++) {
        for (int c = 0; c < 3; c++)
            sum += (double)a->pixels[p * a->channel_count + c] - b->pixels[p * b->channel_count + c];
    }
    return sum / (3.0 * pixels);
}

/*
 * Convergence. Renders A (N spp, seed 1), C (N spp, seed 2) and B (2N spp,
 * seed 3): independent estimates of the same image. With σ² a pixel's
 * per-sample variance, E[(A − C)²] = 2σ²/N, and if B's error falls with its
 * sample count, E[(A − B)²] = σ²/N + σ²/(2N) = ¾·E[(A − C)²]; stratified
 * (Sobol) sampling can only make B better, and B cannot be better than
 * exact, so the ratio lies in [½, ¾] up to the noise of the two estimates.
 * A render whose error did not fall with 2N samples gives 1. Also the image
 * means of A and B agree within CORNELL_SIGMAS standard errors of their
 * difference (estimated from A − C): the estimate does not drift with N.
 * The view is narrowed to the walls and boxes below the light: pixels that
 * see the light itself have a heavy-tailed per-sample distribution (17× the
 * radiance of the walls) that would leave a few dozen pixels in charge of
 * the whole statistic; the light still reaches every pixel through NEE and
 * BSDF sampling.
 */
#define CORNELL_ZOOM 2.0f
#define CORNELL_SPP 16u
#define CORNELL_RATIO_LOW 0.4
#define CORNELL_RATIO_HIGH 0.9
#define CORNELL_SIGMAS 4.0

PF_TEST(cornell_longer_render_agrees_within_predicted_noise)
{
    pf_render_settings settings = {CORNELL_WIDTH, CORNELL_HEIGHT, PF_QUALITY_REFERENCE,
                                   CORNELL_SPP,   1,              1,
                                   0.0};
    pf_image a = {0}, b = {0}, c = {0};
    pf_error err = {0};
    double start = pf_time_ms();
    PF_REQUIRE_OK(cornell_render_zoomed(&settings, CORNELL_ZOOM, &a, NULL, &err), &err);
    settings.seed = 2;
    PF_REQUIRE_OK(cornell_render_zoomed(&settings, CORNELL_ZOOM, &c, NULL, &err), &err);
    settings.seed = 3;
    settings.samples_per_pixel = 2 * CORNELL_SPP;
    PF_REQUIRE_OK(cornell_render_zoomed(&settings, CORNELL_ZOOM, &b, NULL, &err), &err);
    /* Precondition: no camera ray met the light (albedo 0) or missed. */
    int albedo = pf_image_channel(&a, "albedo.R");
    uint32_t light_pixels = 0;
    for (size_t p = 0; p < (size_t)CORNELL_WIDTH * CORNELL_HEIGHT; p++)
        light_pixels += !(a.pixels[p * a.channel_count + albedo] > 0.0f) ||
                        a.pixels[p * a.channel_count + 3] != 1.0f;
    PF_CHECK_MSG(light_pixels == 0, "%u pixels see the light or nothing", light_pixels);
    double elapsed = pf_time_ms() - start;
    double mse_ac = image_mse(&a, &c);
    double mse_ab = image_mse(&a, &b);
    double ratio = mse_ab / mse_ac;
    double pixels = 3.0 * CORNELL_WIDTH * CORNELL_HEIGHT;
    double standard_error = sqrt(0.75 * mse_ac / pixels);
    double drift = image_mean_difference(&b, &a);
    PF_CHECK(mse_ac > 0.0);
    PF_CHECK_MSG(ratio >= CORNELL_RATIO_LOW && ratio <= CORNELL_RATIO_HIGH,
                 "MSE(A,B)/MSE(A,C) = %.3f, expected 0.5..0.75 (MSE %.4g / %.4g)", ratio, mse_ab,
                 mse_ac);
    PF_CHECK_MSG(fabs(drift) <= CORNELL_SIGMAS * standard_error,
                 "mean(B) - mean(A) = %.5f, standard error %.5f", drift, standard_error);
    printf("  cornell %ux%u: MSE(A,C) %.4g, MSE(A,B) %.4g, ratio %.3f, drift %.5f (SE %.5f), "
           "%.0f paths/s\n",
           CORNELL_WIDTH, CORNELL_HEIGHT, mse_ac, mse_ab, ratio, drift, standard_error,
           4.0 * CORNELL_SPP * CORNELL_WIDTH * CORNELL_HEIGHT / (elapsed / 1000.0));
    pf_image_free(&a);
    pf_image_free(&b);
    pf_image_free(&c);
}

PF_TEST(time_budget_stops_early_with_at_least_one_sample)
{
    /* A budget every first pass exceeds (a nanosecond), so the outcome does not
     * depend on how fast or loaded the machine is: exactly the one pass that
     * is always rendered. */
    pf_render_settings settings = {CORNELL_WIDTH, CORNELL_HEIGHT, PF_QUALITY_REFERENCE, 4096, 1,
                                   0,             1e-6};
    pf_image image = {0};
    pf_frame_report report = {0};
    pf_error err = {0};
    PF_REQUIRE_OK(cornell_render(&settings, &image, &report, &err), &err);
    double reached = counter(&report, "shade", "samples_per_pixel");
    PF_CHECK_MSG(reached == 1, "%g spp reached", reached);

    /* Same seed, same sample count: the image the budget stopped at is reproducible. */
    pf_render_settings exact = settings;
    exact.samples_per_pixel = (uint32_t)reached;
    exact.time_budget_ms = 0.0;
    pf_image again = {0};
    PF_REQUIRE_OK(cornell_render(&exact, &again, NULL, &err), &err);
    size_t bytes = (size_t)image.width * image.height * image.channel_count * sizeof(float);
    PF_CHECK(again.channel_count == image.channel_count &&
             memcmp(image.pixels, again.pixels, bytes) == 0);
    pf_image_free(&image);
    pf_image_free(&again);
}

PF_TEST(bad_settings_are_refused)
{
    test_frame scene;
    sphere_make(&scene, 0.5f, 1.0f);
    pf_image image = {0};
    pf_error err = {0};
    pf_render_settings negative = {8, 8, PF_QUALITY_REFERENCE, 1, 1, 0, -5.0};
    PF_CHECK(pf_render_frame(renderer, &scene.frame, &negative, &image, NULL, &err) ==
             PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "time budget") != NULL);
    /* A side past 16384 is refused up front, naming the size (a film larger than one device
     * buffer renders in bands: test_render_bands). */
    pf_render_settings huge = {16385, 8, PF_QUALITY_REFERENCE, 1, 1, 0, 0.0};
    PF_CHECK(pf_render_frame(renderer, &scene.frame, &huge, &image, NULL, &err) ==
             PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "16385x8") != NULL);
    PF_CHECK(image.pixels == NULL);
    sphere_free(&scene);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(white_furnace_converges_to_le_over_one_minus_albedo);
    PF_RUN(same_seed_same_image_other_seed_other_image);
    PF_RUN(channels_follow_the_contract);
    PF_RUN(cornell_longer_render_agrees_within_predicted_noise);
    PF_RUN(time_budget_stops_early_with_at_least_one_sample);
    PF_RUN(bad_settings_are_refused);
    return render_test_finish(ctx, renderer);
}
