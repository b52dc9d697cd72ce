/*
 * Textures in the kernels (scene_textures.glsl, surface_at, the traversal's
 * alpha test), on frames built here:
 * - a plane with an sRGB checker baseColorTexture under a directional light:
 *   the image's mean is mean(linear albedo)·E·cosθ/π, in preview and in the
 *   reference (the view covers one whole period, so bilinear filtering keeps
 *   the texels' mean);
 * - the mip level a camera ray's cone picks: a 256² single-texel checker
 *   whose coarser levels are uniform grey, seen at 2 texels a pixel (level
 *   1): every pixel is grey (relative spread under 2 %), where sampling level 0
 *   would leave each pixel 16 samples of black and white (25 %); through a pinhole
 *   and through an orthographic camera of the same view;
 * - a constant normal map on a flat plane shades as the plane turned to the
 *   map's normal: E·cos(light, mapped normal)/π;
 * - every preset on a textured room (checker walls, a half-metal
 *   metallicRoughness box, a normal-mapped wall and an area light): no NaN,
 *   Inf or negative pixel, and each preset's mean within its stated bound of
 *   the reference's (preview: direct only, below it);
 * - an alpha-masked card (left half opaque, right half cut away) 0.5 m over
 *   a white plane, lit straight down: the dark pixels are the opaque half
 *   (its shadow lies hidden under it), 0.5 m² seen from 1.5 m, i.e.
 *   0.5·(2/1.5)²/4 = 2/9 of the view, in every preset: camera rays see
 *   through the cut-away half and shadow rays pass it (a card without its
 *   mask would darken 4/9; shadow rays that ignored it, 2/9 + 1/8);
 * - an unlit card (KHR_materials_unlit) of the same shape, its texture coloured, under a
 *   light at 45°: in every preset the camera sees its base colour (factor × texel) exactly,
 *   and the plane around it is lit as if it were not there (shadow rays, photons and
 *   bounce rays pass it, as Cycles renders Blender's import), where a lit card's shadow
 *   would darken the plane beside it.
 */
#include "pf_test.h"
#include "reference_test_util.h"
#include "render_test_env.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static pf_vk_context *ctx;
static pf_renderer *renderer;

#define EDGE 64u
#define CHECKER 8u

/* sRGB bytes of the checker's two squares. */
#define DARK_SRGB 50u
#define LIGHT_SRGB 200u

static double srgb_to_linear(double c)
{
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

/* The camera 2 m above the origin looking down, its view exactly [-1, 1]². */
static void look_down(ref_scene *scene)
{
    const float eye[3] = {0, 0, 2}, target[3] = {0, 0, 0}, up[3] = {0, 1, 0};
    ref_scene_look_at(scene, eye, target, up, (float)(2.0 * atan(0.5)));
}

/* Corners for every triangle: uv from the vertex's x, y (u = (x - x0)·su, v = (y0 - y)·sv per
 * triangle range), white, no tangent. */
static void set_corners(pf_scene_frame *frame, uint32_t first, uint32_t count, float x0,
                        float y0, float su, float sv)
{
    for (uint32_t t = first; t < first + count; t++)
        for (uint32_t c = 0; c < 3; c++) {
            const float *p = frame->vertices[3 * t + c];
            float(*texel)[4] = frame->corners + PF_CORNER_TEXELS * (3 * t + c);
            texel[0][0] = (p[0] - x0) * su;
            texel[0][1] = (y0 - p[1]) * sv;
            texel[0][2] = texel[0][3] = 0.0f;
            texel[1][0] = texel[1][1] = texel[1][2] = texel[1][3] = 1.0f;
            memset(texel[2], 0, sizeof texel[2]);
        }
}

/* Zeroed corners for every triangle of frame (owned by the test: scene_free_textured). */
static int corners_alloc(pf_scene_frame *frame)
{
    frame->corners = calloc(3 * PF_CORNER_TEXELS * frame->triangle_count, sizeof *frame->corners);
    return frame->corners != NULL;
}

/* Frees the test's corners, forgets the textures it pointed the frame at (its own arrays),
 * then the scene. */
static void scene_free_textured(ref_scene *scene)
{
    free(scene->frame.corners);
    scene->frame.corners = NULL;
    scene->frame.textures = NULL;
    scene->frame.texels = NULL;
    ref_scene_free(scene);
}

static pf_frame_report report;

static pf_status render(const pf_scene_frame *frame, pf_quality quality, pf_image *image)
{
    pf_render_settings settings = ref_settings(EDGE, EDGE, 16, 7, 0);
    settings.quality = quality;
    pf_error err = {0};
    memset(&report, 0, sizeof report);
    pf_status status = pf_render_frame(renderer, frame, &settings, image, &report, &err);
    if (status != PF_OK)
        PF_CHECK_MSG(0, "%s: %s", pf_quality_name(quality), err.message);
    return status;
}

static double red_mean(const pf_image *image)
{
    double sum = 0.0;
    for (uint32_t i = 0; i < image->width * image->height; i++)
        sum += image->pixels[(size_t)i * image->channel_count];
    return sum / (image->width * image->height);
}

PF_TEST(textured_plane_mean_is_mean_albedo_times_irradiance)
{
    ref_scene scene;
    ref_scene_init(&scene);
    pf_material white = pf_material_lambert(1, 1, 1);
    white.base_color_texture = 1;
    uint32_t plane = ref_scene_add_material(&scene, white);
    const float centre[3] = {0, 0, 0}, half_u[3] = {2, 0, 0}, half_v[3] = {0, 2, 0};
    ref_scene_add_quad(&scene, centre, half_u, half_v, plane);
    const float e = 3.0f, cos_theta = 0.8f;
    ref_scene_add_light(&scene, (pf_light){{0, 0, 0}, PF_LIGHT_DIRECTIONAL, {0.6f, 0, -0.8f}, 0,
                                           {e, e, e}, 1, 1});
    look_down(&scene);
    pf_scene_frame *frame = &scene.frame;
    /* uv over the plane [-2, 2]²: [0, 2]², two periods; the view [-1, 1]² is one. */
    PF_REQUIRE(corners_alloc(frame));
    set_corners(frame, 0, frame->triangle_count, -2.0f, 2.0f, 0.5f, 0.5f);
    uint32_t texels[CHECKER * CHECKER];
    for (uint32_t y = 0; y < CHECKER; y++)
        for (uint32_t x = 0; x < CHECKER; x++) {
            uint32_t v = (x + y) % 2 ? LIGHT_SRGB : DARK_SRGB;
            texels[y * CHECKER + x] = v | v << 8 | v << 16 | 255u << 24;
        }
    /* Level 0 only (NO_MIPS): the kernels here sample the finest level anyway. */
    pf_texture_ref ref = {0, CHECKER, CHECKER, PF_TEXTURE_SRGB | PF_TEXTURE_NO_MIPS,
                          {1, 0, 0, 0, 1, 0}, {0, 0}};
    frame->texture_count = 1;
    frame->textures = &ref;
    frame->texel_count = CHECKER * CHECKER;
    frame->texels = texels;
    /* As pf_scene_eval names a loaded scene's textures: uploaded by the first frame only. */
    frame->texture_set = 0x7E57u;
    double albedo = 0.5 * (srgb_to_linear(DARK_SRGB / 255.0) + srgb_to_linear(LIGHT_SRGB / 255.0));
    double expected = albedo * e * cos_theta / M_PI;
    const pf_quality qualities[] = {PF_QUALITY_PREVIEW, PF_QUALITY_REFERENCE};
    for (size_t q = 0; q < 2; q++) {
        pf_image image = {0};
        if (render(frame, qualities[q], &image) != PF_OK)
            continue;
        double mean = red_mean(&image);
        printf("  %s: textured plane mean %.5f, expected %.5f (%+.2f%%)\n",
               pf_quality_name(qualities[q]), mean, expected, 100.0 * (mean / expected - 1.0));
        PF_CHECK_MSG(fabs(mean / expected - 1.0) < 0.01, "%s: mean %g, expected %g",
                     pf_quality_name(qualities[q]), mean, expected);
        PF_CHECK(ref_image_non_finite(&image) == 0);
        /* The textures row: uploaded by the first frame, reused by the second (another
         * preset: the cache lives as long as the scene's textures). */
        PF_CHECK(ref_stage_counter(&report, "textures", "uploaded") == (q == 0 ? 1.0 : 0.0));
        PF_CHECK(ref_stage_counter(&report, "textures", "textures") == 1.0);
        pf_image_free(&image);
    }
    scene_free_textured(&scene);
}

/*
 * The layers' textures scale their factors: a black dielectric plane (specular 1, roughness
 * 0.4) under a directional light reflects only its specular lobe, nothing where
 * specularTexture's A or specularColorTexture's RGB is 0, as much as without them where
 * they are 1; a coat (clearcoat 1, roughness 0.4) over a black base without specular
 * reflects nothing where clearcoatTexture's R is 0, and a white sheen (roughness 0.5)
 * nothing where sheenColorTexture's RGB is 0. preview: the direct light alone.
 */
PF_TEST(specular_clearcoat_and_sheen_textures_scale_their_factors)
{
    ref_scene scene;
    ref_scene_init(&scene);
    pf_material black = pf_material_lambert(0, 0, 0);
    black.specular = 1.0f;
    black.roughness = 0.4f;
    pf_material_classify(&black);
    uint32_t plane = ref_scene_add_material(&scene, black);
    const float centre[3] = {0, 0, 0}, half_u[3] = {2, 0, 0}, half_v[3] = {0, 2, 0};
    ref_scene_add_quad(&scene, centre, half_u, half_v, plane);
    ref_scene_add_light(&scene, (pf_light){{0, 0, 0}, PF_LIGHT_DIRECTIONAL, {0.3f, 0, -0.95f},
                                           0, {3, 3, 3}, 1, 1});
    look_down(&scene);
    pf_scene_frame *frame = &scene.frame;
    PF_REQUIRE(corners_alloc(frame));
    set_corners(frame, 0, frame->triangle_count, -2.0f, 2.0f, 0.25f, 0.25f);
    /* Texture 1: every channel 0; texture 2: every channel 255 (one texel each). */
    uint32_t texels[2] = {0u, 0xFFFFFFFFu};
    pf_texture_ref refs[2] = {{0, 1, 1, PF_TEXTURE_NO_MIPS, {1, 0, 0, 0, 1, 0}, {0, 0}},
                              {1, 1, 1, PF_TEXTURE_NO_MIPS, {1, 0, 0, 0, 1, 0}, {0, 0}}};
    frame->texture_count = 2;
    frame->textures = refs;
    frame->texel_count = 2;
    frame->texels = texels;
    frame->texture_set = 0x5BEC;
    pf_material *m = &scene.materials[plane];
    struct {
        const char *name;
        uint32_t specular, specular_color, coat, coat_texture; /* slots; coat: clearcoat on */
        uint32_t sheen, sheen_texture; /* sheen: a white sheen on (and the other layers off) */
        int lit;                       /* -1 dark, 1 as untextured */
    } cases[] = {{"specular, untextured", 0, 0, 0, 0, 0, 0, 1},
                 {"specularTexture A 0", 1, 0, 0, 0, 0, 0, -1},
                 {"specularTexture A 1", 2, 0, 0, 0, 0, 0, 1},
                 {"specularColorTexture 0", 0, 1, 0, 0, 0, 0, -1},
                 {"clearcoat, untextured", 0, 0, 1, 0, 0, 0, 1},
                 {"clearcoatTexture R 0", 0, 0, 1, 1, 0, 0, -1},
                 {"sheen, untextured", 0, 0, 0, 0, 1, 0, 1},
                 {"sheenColorTexture 0", 0, 0, 0, 0, 1, 1, -1}};
    double untextured[3] = {0.0, 0.0, 0.0};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        int coat = cases[c].coat != 0, sheen = cases[c].sheen != 0;
        int layer = sheen ? 2 : coat;
        m->specular = coat || sheen ? 0.0f : 1.0f;
        m->specular_texture = cases[c].specular;
        m->specular_color_texture = cases[c].specular_color;
        m->clearcoat = coat ? 1.0f : 0.0f;
        m->clearcoat_roughness = 0.4f;
        m->clearcoat_texture = cases[c].coat_texture;
        m->sheen_color[0] = m->sheen_color[1] = m->sheen_color[2] = sheen ? 1.0f : 0.0f;
        m->sheen_roughness = 0.5f;
        m->sheen_color_texture = cases[c].sheen_texture;
        pf_image image = {0};
        if (render(frame, PF_QUALITY_PREVIEW, &image) != PF_OK)
            continue;
        double mean = red_mean(&image);
        printf("  %s: mean %.6f\n", cases[c].name, mean);
        if (c == 0 || c == 4 || c == 6)
            untextured[layer] = mean;
        if (cases[c].lit < 0)
            PF_CHECK_MSG(mean == 0.0, "%s: mean %g", cases[c].name, mean);
        else
            PF_CHECK_MSG(mean > 0.0 && fabs(mean - untextured[layer]) <= 1e-6 * mean,
                         "%s: mean %g, untextured %g", cases[c].name, mean, untextured[layer]);
        pf_image_free(&image);
    }
    scene_free_textured(&scene);
}

PF_TEST(constant_normal_map_shades_as_the_turned_plane)
{
    ref_scene scene;
    ref_scene_init(&scene);
    pf_material white = pf_material_lambert(1, 1, 1);
    white.normal_texture = 1;
    white.normal_scale = 1.0f;
    uint32_t plane = ref_scene_add_material(&scene, white);
    const float centre[3] = {0, 0, 0}, half_u[3] = {2, 0, 0}, half_v[3] = {0, 2, 0};
    ref_scene_add_quad(&scene, centre, half_u, half_v, plane);
    const float e = 3.0f;
    const double light[3] = {0.6, 0.0, -0.8};
    ref_scene_add_light(&scene, (pf_light){{0, 0, 0}, PF_LIGHT_DIRECTIONAL,
                                           {(float)light[0], 0, (float)light[2]}, 0, {e, e, e}, 1,
                                           1});
    look_down(&scene);
    pf_scene_frame *frame = &scene.frame;
    PF_REQUIRE(corners_alloc(frame));
    set_corners(frame, 0, frame->triangle_count, -2.0f, 2.0f, 0.25f, 0.25f);
    for (uint32_t k = 0; k < 3 * frame->triangle_count; k++) { /* tangent +x, handedness +1 */
        float *tangent = frame->corners[PF_CORNER_TEXELS * k + 2];
        tangent[0] = 1.0f;
        tangent[3] = 1.0f;
    }
    /* The map's normal: turned 30° towards the light (x −0.5, z 0.866), as 8-bit texels. */
    uint32_t rgb[3] = {64u, 128u, 238u};
    uint32_t texel = rgb[0] | rgb[1] << 8 | rgb[2] << 16 | 255u << 24;
    pf_texture_ref ref = {0, 1, 1, PF_TEXTURE_NO_MIPS, {1, 0, 0, 0, 1, 0}, {0, 0}};
    frame->texture_count = 1;
    frame->textures = &ref;
    frame->texel_count = 1;
    frame->texels = &texel;
    double n[3], length = 0.0;
    for (int k = 0; k < 3; k++) {
        n[k] = 2.0 * rgb[k] / 255.0 - 1.0;
        length += n[k] * n[k];
    }
    double cosine = -(n[0] * light[0] + n[1] * light[1] + n[2] * light[2]) / sqrt(length);
    double expected = e * cosine / M_PI, flat = e * 0.8 / M_PI;
    const pf_quality qualities[] = {PF_QUALITY_PREVIEW, PF_QUALITY_REFERENCE};
    for (size_t q = 0; q < 2; q++) {
        pf_image image = {0};
        if (render(frame, qualities[q], &image) != PF_OK)
            continue;
        double mean = red_mean(&image);
        printf("  %s: normal-mapped plane %.5f, turned plane %.5f, flat plane %.5f\n",
               pf_quality_name(qualities[q]), mean, expected, flat);
        PF_CHECK_MSG(fabs(mean / expected - 1.0) < 0.005, "%s: %g, expected %g",
                     pf_quality_name(qualities[q]), mean, expected);
        pf_image_free(&image);
    }
    /* A black base under a clear coat: the map tilts the base, not the coat, which keeps the
     * mesh's normal (KHR_materials_clearcoat), so the plane's coat reflects as without the
     * map, in preview bit for bit (a map-tilted coat moves its highlight). */
    pf_material *m = &scene.materials[plane];
    m->albedo[0] = m->albedo[1] = m->albedo[2] = 0.0f;
    m->clearcoat = 1.0f;
    m->clearcoat_roughness = 0.3f;
    double coat_mean[2] = {0.0, 0.0};
    for (int mapped = 0; mapped < 2; mapped++) {
        m->normal_texture = mapped ? 1u : PF_NO_TEXTURE;
        pf_image image = {0};
        if (render(frame, PF_QUALITY_PREVIEW, &image) != PF_OK)
            continue;
        coat_mean[mapped] = red_mean(&image);
        pf_image_free(&image);
    }
    printf("  preview: coat over black, flat %.6f, under the map %.6f\n", coat_mean[0],
           coat_mean[1]);
    PF_CHECK_MSG(coat_mean[0] > 0.0 && coat_mean[1] == coat_mean[0],
                 "the coat under the map %g, flat %g", coat_mean[1], coat_mean[0]);
    /* The same map as the coat's own (clearcoatNormalTexture) tilts the coat: seen straight
     * down through an orthographic camera (wo = +z at every pixel), each pixel is the coat's
     * closed form E·F·D·V·cos_i about the map's normal (GGX α 0.09, F of index 1.5). */
    m->normal_texture = PF_NO_TEXTURE;
    m->clearcoat_normal_texture = 1;
    m->clearcoat_normal_scale = 1.0f;
    frame->camera.orthographic = 1;
    frame->camera.ymag = 1.0f;
    double wo[3] = {0, 0, 1}, wi[3] = {-light[0], -light[1], -light[2]}, h[3], hl = 0.0;
    for (int k = 0; k < 3; k++) {
        h[k] = wo[k] + wi[k];
        hl += h[k] * h[k];
    }
    double cos_o = 0, cos_i = 0, cos_h = 0, cos_oh = 0;
    for (int k = 0; k < 3; k++) {
        h[k] /= sqrt(hl);
        cos_o += n[k] * wo[k] / sqrt(length);
        cos_i += n[k] * wi[k] / sqrt(length);
        cos_h += n[k] * h[k] / sqrt(length);
        cos_oh += wo[k] * h[k];
    }
    double a2 = 0.09 * 0.09, t = cos_h * cos_h * (a2 - 1) + 1;
    double d = a2 / (M_PI * t * t);
    double v = 0.5 / (cos_i * sqrt(cos_o * cos_o * (1 - a2) + a2) +
                      cos_o * sqrt(cos_i * cos_i * (1 - a2) + a2));
    double coat_expected = e * ref_fresnel_dielectric(cos_oh, 1.5) * d * v * cos_i;
    pf_image image = {0};
    if (render(frame, PF_QUALITY_PREVIEW, &image) == PF_OK) {
        double mean = red_mean(&image);
        printf("  preview: coat over black under its own map %.6f, closed form %.6f\n", mean,
               coat_expected);
        PF_CHECK_MSG(fabs(mean / coat_expected - 1.0) < 1e-3, "the coat's own map: %g, "
                     "expected %g", mean, coat_expected);
        pf_image_free(&image);
    }
    scene_free_textured(&scene);
}

#define MIP_EDGE 256u

PF_TEST(camera_ray_cones_pick_the_mip_level)
{
    ref_scene scene;
    ref_scene_init(&scene);
    pf_material white = pf_material_lambert(1, 1, 1);
    white.base_color_texture = 1;
    uint32_t plane = ref_scene_add_material(&scene, white);
    const float centre[3] = {0, 0, 0}, half_u[3] = {2, 0, 0}, half_v[3] = {0, 2, 0};
    ref_scene_add_quad(&scene, centre, half_u, half_v, plane);
    const float e = 2.0f;
    ref_scene_add_light(&scene, (pf_light){{0, 0, 0}, PF_LIGHT_DIRECTIONAL, {0, 0, -1}, 0,
                                           {e, e, e}, 1, 1});
    look_down(&scene);
    pf_scene_frame *frame = &scene.frame;
    PF_REQUIRE(corners_alloc(frame));
    /* uv [0, 1] over the plane's 4 m: 64 texels a metre; the view has 32 pixels a metre. */
    set_corners(frame, 0, frame->triangle_count, -2.0f, 2.0f, 0.25f, 0.25f);
    uint32_t levels = 9, total = 0;
    for (uint32_t k = 0; k < levels; k++)
        total += (MIP_EDGE >> k) * (MIP_EDGE >> k);
    uint32_t *texels = malloc(total * sizeof *texels);
    PF_REQUIRE(texels != NULL);
    for (uint32_t i = 0; i < total; i++) {
        uint32_t v = 128u;
        if (i < MIP_EDGE * MIP_EDGE)
            v = (i % MIP_EDGE + i / MIP_EDGE) % 2 ? 255u : 0u;
        texels[i] = v | v << 8 | v << 16 | 255u << 24;
    }
    pf_texture_ref ref = {0, MIP_EDGE, MIP_EDGE, levels - 1, {1, 0, 0, 0, 1, 0}, {0, 0}};
    frame->texture_count = 1;
    frame->textures = &ref;
    frame->texel_count = total;
    frame->texels = texels;
    double expected = 128.0 / 255.0 * e / M_PI;
    const pf_quality qualities[] = {PF_QUALITY_PREVIEW, PF_QUALITY_REFERENCE};
    /* The pinhole, then an orthographic camera of the same view (ymag 1): its rays' cones
     * keep a pixel's width from the start. */
    for (size_t q = 0; q < 4; q++) {
        frame->camera.orthographic = q >= 2;
        frame->camera.ymag = 1.0f;
        pf_image image = {0};
        if (render(frame, qualities[q % 2], &image) != PF_OK)
            continue;
        double sum = 0.0, sum2 = 0.0;
        for (uint32_t i = 0; i < EDGE * EDGE; i++) {
            double v = image.pixels[(size_t)i * image.channel_count];
            sum += v;
            sum2 += v * v;
        }
        double mean = sum / (EDGE * EDGE);
        double spread = sqrt(fmax(sum2 / (EDGE * EDGE) - mean * mean, 0.0)) / mean;
        printf("  %s%s: mean %.5f (level 1: %.5f), pixels' relative spread %.4f\n",
               pf_quality_name(qualities[q % 2]), q >= 2 ? ", orthographic" : "", mean,
               expected, spread);
        PF_CHECK_MSG(spread < 0.02, "%s%s: relative spread %g: level 0 was read",
                     pf_quality_name(qualities[q % 2]), q >= 2 ? ", orthographic" : "", spread);
        PF_CHECK(fabs(mean / expected - 1.0) < 0.01);
        pf_image_free(&image);
    }
    free(texels);
    scene_free_textured(&scene);
}

/*
 * A white plane (4 m square at z = 0) and a 1 m card of material `card` 0.5 m over its
 * centre, its texture (slot 1: the 4×1 texels, nearest, clamped, the card's u across it,
 * plus `sampling`'s flags, such as PF_TEXTURE_SRGB) in ref, an alpha MASK at 0.5 on it,
 * lit by light, seen by look_down. The frame points at texels and ref (the test's own:
 * scene_free_textured forgets them); 0 when its corners could not be allocated.
 */
static int card_scene(ref_scene *scene, pf_material card, pf_light light, uint32_t *texels,
                      uint32_t sampling, pf_texture_ref *ref)
{
    ref_scene_init(scene);
    uint32_t plane = ref_scene_add_material(scene, pf_material_lambert(1, 1, 1));
    card.base_color_texture = 1;
    card.alpha = 1.0f;
    card.alpha_mode = PF_ALPHA_MASK;
    card.alpha_cutoff = 0.5f;
    uint32_t card_material = ref_scene_add_material(scene, card);
    const float centre[3] = {0, 0, 0}, half_u[3] = {2, 0, 0}, half_v[3] = {0, 2, 0};
    ref_scene_add_quad(scene, centre, half_u, half_v, plane);
    uint32_t card_first = scene->frame.triangle_count;
    const float card_centre[3] = {0, 0, 0.5f}, card_u[3] = {0.5f, 0, 0},
                card_v[3] = {0, 0.5f, 0};
    ref_scene_add_quad(scene, card_centre, card_u, card_v, card_material);
    ref_scene_add_light(scene, light);
    look_down(scene);
    pf_scene_frame *frame = &scene->frame;
    if (!corners_alloc(frame))
        return 0;
    set_corners(frame, 0, card_first, -2.0f, 2.0f, 0.25f, 0.25f);
    set_corners(frame, card_first, frame->triangle_count - card_first, -0.5f, 0.5f, 1.0f, 1.0f);
    *ref = (pf_texture_ref){0, 4, 1,
                            PF_TEXTURE_NO_MIPS | PF_TEXTURE_MAG_NEAREST | PF_TEXTURE_MIN_NEAREST |
                                PF_TEXTURE_WRAP_CLAMP << PF_TEXTURE_WRAP_S_SHIFT |
                                PF_TEXTURE_WRAP_CLAMP << PF_TEXTURE_WRAP_T_SHIFT | sampling,
                            {1, 0, 0, 0, 1, 0}, {0, 0}};
    frame->texture_count = 1;
    frame->textures = ref;
    frame->texel_count = 4;
    frame->texels = texels;
    return 1;
}

PF_TEST(alpha_masked_card_hides_and_shadows_only_its_opaque_half)
{
    pf_material card = pf_material_lambert(0, 0, 0);
    const float e = 3.0f;
    /* 4×1: alpha 1, 1, 0, 0 from left to right. */
    uint32_t texels[4] = {0xFF000000u, 0xFF000000u, 0x00000000u, 0x00000000u};
    pf_texture_ref ref;
    ref_scene scene;
    PF_REQUIRE(card_scene(&scene, card,
                          (pf_light){{0, 0, 0}, PF_LIGHT_DIRECTIONAL, {0, 0, -1}, 0, {e, e, e},
                                     1, 1},
                          texels, 0, &ref));
    pf_scene_frame *frame = &scene.frame;
    double lit = e / M_PI; /* a white plane under E straight down */
    const pf_quality qualities[] = {PF_QUALITY_PREVIEW, PF_QUALITY_REFERENCE, PF_QUALITY_FAST,
                                    PF_QUALITY_FINAL};
    for (size_t q = 0; q < sizeof qualities / sizeof *qualities; q++) {
        pf_image image = {0};
        if (render(frame, qualities[q], &image) != PF_OK)
            continue;
        uint32_t dark = 0;
        for (uint32_t i = 0; i < EDGE * EDGE; i++)
            dark += image.pixels[(size_t)i * image.channel_count] < 0.5 * lit;
        double fraction = (double)dark / (EDGE * EDGE);
        printf("  %s: %.4f of the view dark (the opaque half: 2/9 = 0.2222)\n",
               pf_quality_name(qualities[q]), fraction);
        /* The half's edges cross ~3 × 21 pixels of 64²: 0.015 at most. */
        PF_CHECK_MSG(fabs(fraction - 2.0 / 9.0) < 0.015, "%s: dark fraction %g",
                     pf_quality_name(qualities[q]), fraction);
        PF_CHECK(ref_image_non_finite(&image) == 0);
        pf_image_free(&image);
    }
    scene_free_textured(&scene);
}

PF_TEST(unlit_card_is_its_colour_to_the_camera_and_invisible_to_the_rest)
{
    pf_material card = pf_material_lambert(0.5f, 0.5f, 0.5f);
    card.flags |= PF_MATERIAL_UNLIT;
    /* Travelling along +x and down at 45°: a lit card's left half would shadow the plane
     * at x in [0, 0.5], seen through the card's cut-away right half. */
    const float e = 3.0f, s = (float)M_SQRT1_2;
    /* 4×1: sRGB (255, 200, 50) opaque twice, then cut away. */
    uint32_t texels[4] = {0xFF32C8FFu, 0xFF32C8FFu, 0x00000000u, 0x00000000u};
    pf_texture_ref ref;
    ref_scene scene;
    PF_REQUIRE(card_scene(&scene, card,
                          (pf_light){{0, 0, 0}, PF_LIGHT_DIRECTIONAL, {s, 0, -s}, 0, {e, e, e},
                                     1, 1},
                          texels, PF_TEXTURE_SRGB, &ref));
    pf_scene_frame *frame = &scene.frame;
    const double colour[3] = {0.5, 0.5 * srgb_to_linear(200.0 / 255.0),
                              0.5 * srgb_to_linear(50.0 / 255.0)};
    double lit = e * M_SQRT1_2 / M_PI; /* the white plane, the card or not */
    const pf_quality qualities[] = {PF_QUALITY_PREVIEW, PF_QUALITY_REFERENCE, PF_QUALITY_FAST,
                                    PF_QUALITY_FINAL};
    for (size_t q = 0; q < sizeof qualities / sizeof *qualities; q++) {
        pf_image image = {0};
        if (render(frame, qualities[q], &image) != PF_OK)
            continue;
        double card_error = 0.0, plane_error = 0.0, plane_min = INFINITY;
        uint32_t card_pixels = 0, plane_pixels = 0;
        for (uint32_t j = 0; j < EDGE; j++)
            for (uint32_t i = 0; i < EDGE; i++) {
                /* Where the pixel's centre ray crosses the card's plane (0.75 of the way). */
                double x = 0.75 * (-1.0 + (i + 0.5) * 2.0 / EDGE);
                double y = 0.75 * (1.0 - (j + 0.5) * 2.0 / EDGE);
                const float *px = image.pixels + ((size_t)j * EDGE + i) * image.channel_count;
                const double margin = 0.08; /* the pixel filter's reach, ~2 pixels */
                if (x > -0.5 + margin && x < -margin && fabs(y) < 0.5 - margin) {
                    for (int c = 0; c < 3; c++)
                        card_error = fmax(card_error, fabs(px[c] / colour[c] - 1.0));
                    card_pixels++;
                } else if (!(x > -0.5 - margin && x < margin && fabs(y) < 0.5 + margin)) {
                    for (int c = 0; c < 3; c++) {
                        plane_error = fmax(plane_error, fabs(px[c] / lit - 1.0));
                        plane_min = fmin(plane_min, px[c] / lit);
                    }
                    plane_pixels++;
                }
            }
        printf("  %s: card %u pixels within %.2e of its colour; plane %u pixels within %.2e of "
               "lit (least %.4f)\n",
               pf_quality_name(qualities[q]), card_pixels, card_error, plane_pixels,
               plane_error, plane_min);
        PF_CHECK(card_pixels > 100 && plane_pixels > 1000);
        PF_CHECK_MSG(card_error < 1e-3, "%s: the card's colour off by %g",
                     pf_quality_name(qualities[q]), card_error);
        /* A shadow would leave its pixels at 0; light from the card would add to them. */
        PF_CHECK_MSG(plane_error < 0.02, "%s: the plane off by %g", pf_quality_name(qualities[q]),
                     plane_error);
        PF_CHECK(ref_image_non_finite(&image) == 0);
        pf_image_free(&image);
    }
    scene_free_textured(&scene);
}

/* An sRGB checker of two colours, 8×8 single-texel squares, level 0 only. */
static void checker_texels(uint32_t *texels, uint32_t a, uint32_t b)
{
    for (uint32_t y = 0; y < CHECKER; y++)
        for (uint32_t x = 0; x < CHECKER; x++)
            texels[y * CHECKER + x] = (x + y) % 2 ? a : b;
}

PF_TEST(every_preset_on_a_textured_room_stays_within_bounds_of_the_reference)
{
    ref_scene room;
    ref_scene_init(&room);
    pf_material walls = pf_material_lambert(1, 1, 1);
    walls.base_color_texture = 1;
    walls.normal_texture = 3;
    walls.normal_scale = 1.0f;
    pf_material box = pf_material_lambert(0.9f, 0.8f, 0.6f);
    box.specular = 1.0f;
    box.roughness = 1.0f;
    box.metallic = 1.0f;
    box.metallic_roughness_texture = 2;
    pf_material_classify(&box);
    uint32_t wall_material = ref_scene_add_material(&room, walls);
    uint32_t box_material = ref_scene_add_material(&room, box);
    uint32_t light = ref_scene_add_material(&room, ref_material_emitter(6, 6, 6));
    const float min[3] = {-2.0f, -1.0f, -2.0f}, max[3] = {2.0f, 1.0f, 2.0f};
    ref_scene_add_box(&room, min, max, 1, wall_material);
    uint32_t box_first = room.frame.triangle_count;
    const float box_min[3] = {-0.6f, -1.0f, -1.2f}, box_max[3] = {0.2f, -0.2f, -0.4f};
    ref_scene_add_box(&room, box_min, box_max, 0, box_material);
    uint32_t light_first = room.frame.triangle_count;
    const float centre[3] = {0.0f, 0.99f, -0.5f}, u[3] = {0.4f, 0.0f, 0.0f},
                v[3] = {0.0f, 0.0f, 0.4f}; /* u × v: down */
    ref_scene_add_quad(&room, centre, u, v, light);
    const float eye[3] = {0.0f, 0.0f, 1.8f}, target[3] = {0.0f, -0.3f, -1.0f},
                up[3] = {0.0f, 1.0f, 0.0f};
    ref_scene_look_at(&room, eye, target, up, 1.1f);
    pf_scene_frame *frame = &room.frame;
    PF_REQUIRE(corners_alloc(frame));
    set_corners(frame, 0, box_first, -2.0f, 1.0f, 0.5f, 0.5f);
    set_corners(frame, box_first, light_first - box_first, -0.6f, -0.2f, 1.25f, 1.25f);
    set_corners(frame, light_first, frame->triangle_count - light_first, 0.0f, 0.0f, 1.0f, 1.0f);
    for (uint32_t k = 0; k < 3 * box_first; k++) { /* the walls' tangent: +x, or +z on x walls */
        float *tangent = frame->corners[PF_CORNER_TEXELS * k + 2];
        float nx = fabsf(frame->normals[k][0]);
        tangent[0] = nx > 0.5f ? 0.0f : 1.0f;
        tangent[2] = nx > 0.5f ? 1.0f : 0.0f;
        tangent[3] = 1.0f;
    }
    /* Texture 1: an orange and blue sRGB checker; 2: metal (B 1, G roughness 0.3) and rough
     * plastic (G 0.8) squares; 3: normals tilted ±20° along the tangent, in stripes. */
    uint32_t texels[3 * CHECKER * CHECKER];
    checker_texels(texels, 0xFF2060E0u, 0xFF3090F0u);
    checker_texels(texels + CHECKER * CHECKER, 0xFFFF4D00u, 0xFF00CC00u);
    checker_texels(texels + 2 * CHECKER * CHECKER, 0xFFF08050u, 0xFFF080AFu);
    pf_texture_ref refs[3] = {
        {0, CHECKER, CHECKER, PF_TEXTURE_SRGB | PF_TEXTURE_NO_MIPS, {1, 0, 0, 0, 1, 0}, {0, 0}},
        {CHECKER * CHECKER, CHECKER, CHECKER, PF_TEXTURE_NO_MIPS, {1, 0, 0, 0, 1, 0}, {0, 0}},
        {2 * CHECKER * CHECKER, CHECKER, CHECKER, PF_TEXTURE_NO_MIPS, {1, 0, 0, 0, 1, 0},
         {0, 0}}};
    frame->texture_count = 3;
    frame->textures = refs;
    frame->texel_count = 3 * CHECKER * CHECKER;
    frame->texels = texels;
    const struct {
        pf_quality quality;
        uint32_t spp;
        double low, high; /* bounds on mean / reference mean */
    } presets[] = {{PF_QUALITY_REFERENCE, 64, 1.0, 1.0},
                   {PF_QUALITY_PREVIEW, 4, 0.2, 1.0},
                   {PF_QUALITY_FINAL, 4, 0.85, 1.15},
                   {PF_QUALITY_FAST, 4, 0.7, 1.3}};
    double reference = 0.0;
    for (size_t i = 0; i < sizeof presets / sizeof *presets; i++) {
        pf_render_settings settings = ref_settings(48, 36, presets[i].spp, 5, 0);
        settings.quality = presets[i].quality;
        pf_image image = {0};
        pf_error err = {0};
        memset(&report, 0, sizeof report);
        pf_status status = pf_render_frame(renderer, frame, &settings, &image, &report, &err);
        PF_CHECK_MSG(status == PF_OK, "%s: %s", pf_quality_name(presets[i].quality),
                     err.message);
        if (status != PF_OK)
            continue;
        double sum = 0.0;
        uint32_t negative = 0;
        for (uint32_t p = 0; p < image.width * image.height; p++)
            for (int c = 0; c < 3; c++) {
                float value = image.pixels[(size_t)p * image.channel_count + c];
                sum += value;
                negative += value < 0.0f;
            }
        double mean = sum / (3.0 * image.width * image.height);
        if (presets[i].quality == PF_QUALITY_REFERENCE)
            reference = mean;
        double ratio = reference > 0.0 ? mean / reference : 0.0;
        printf("  %s: mean %.5f, %.3f of the reference's\n", pf_quality_name(presets[i].quality),
               mean, ratio);
        PF_CHECK(ref_image_non_finite(&image) == 0 && negative == 0);
        PF_CHECK(reference > 0.0);
        PF_CHECK_MSG(ratio >= presets[i].low - 1e-9 && ratio <= presets[i].high + 1e-9,
                     "%s: %.3f of the reference's mean, outside [%.2f, %.2f]",
                     pf_quality_name(presets[i].quality), ratio, presets[i].low,
                     presets[i].high);
        pf_image_free(&image);
    }
    scene_free_textured(&room);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(textured_plane_mean_is_mean_albedo_times_irradiance);
    PF_RUN(specular_clearcoat_and_sheen_textures_scale_their_factors);
    PF_RUN(constant_normal_map_shades_as_the_turned_plane);
    PF_RUN(camera_ray_cones_pick_the_mip_level);
    PF_RUN(alpha_masked_card_hides_and_shadows_only_its_opaque_half);
    PF_RUN(unlit_card_is_its_colour_to_the_camera_and_invisible_to_the_rest);
    PF_RUN(every_preset_on_a_textured_room_stays_within_bounds_of_the_reference);
    return render_test_finish(ctx, renderer);
}
