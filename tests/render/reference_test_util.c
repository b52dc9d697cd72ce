/* Scene builders and pixel statistics for the reference path tracer's tests. */
#include "reference_test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Test scaffolding: running out of memory or table space is a broken test, not a result. */
static void ref_fail(const char *what)
{
    fprintf(stderr, "reference_test_util: %s\n", what);
    abort();
}

void ref_scene_init(ref_scene *scene)
{
    memset(scene, 0, sizeof *scene);
    scene->frame.materials = scene->materials;
    scene->frame.lights = scene->lights;
    scene->frame.camera = (pf_camera){{0, 0, 0}, {0, 0, -1}, {0, 1, 0}, {1, 0, 0}, 0.8f, 0,
                                      0.01f, 0};
}

void ref_scene_free(ref_scene *scene)
{
    free(scene->frame.vertices);
    free(scene->frame.normals);
    free(scene->frame.triangle_material);
    free(scene->frame.triangle_node);
    memset(scene, 0, sizeof *scene);
}

uint32_t ref_scene_add_material(ref_scene *scene, pf_material material)
{
    if (scene->frame.material_count >= REF_SCENE_MATERIALS_MAX)
        ref_fail("too many materials");
    scene->materials[scene->frame.material_count] = material;
    return scene->frame.material_count++;
}

pf_material ref_material(pf_material_kind kind, float r, float g, float b)
{
    switch (kind) {
    case PF_MATERIAL_MIRROR:
        return pf_material_mirror(r, g, b);
    case PF_MATERIAL_GLASS:
        return pf_material_glass(1.5f, r, g, b);
    case PF_MATERIAL_LAMBERT:
        break;
    }
    return pf_material_lambert(r, g, b);
}

double ref_fresnel_dielectric(double cos_i, double eta)
{
    double sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0)
        return 1.0;
    double cos_t = sqrt(1.0 - sin2_t);
    double rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    double rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return 0.5 * (rp * rp + rs * rs);
}

double ref_sheen_table(int table, double mu, double roughness)
{
    double x = fmin(fmax(mu, 0.0), 1.0) * 31, y = fmin(fmax(roughness, 0.0), 1.0) * 31;
    int i = x >= 30 ? 30 : (int)x, j = y >= 30 ? 30 : (int)y;
    double fx = x - i, fy = y - j;
    const float *e = pf_sheen_albedo + PF_SHEEN_ALBEDO_ENTRIES * table + 32 * i + j;
    return (1 - fx) * ((1 - fy) * e[0] + fy * e[1]) + fx * ((1 - fy) * e[32] + fy * e[33]);
}

/* The Charlie visibility's Λ (Conty Estevez and Kulla 2017, as the spec writes it). */
static double sheen_lambda(double c, double alpha)
{
    double t = (1 - alpha) * (1 - alpha);
    double a = 21.5473 + (25.3245 - 21.5473) * t, b = 3.82987 + (3.32435 - 3.82987) * t;
    double p = 0.19823 + (0.16801 - 0.19823) * t, d = -1.97760 + (-1.27393 + 1.97760) * t;
    double e = -4.32054 + (-4.85967 + 4.32054) * t;
    double at_c = a / (1 + b * pow(c, p)) + d * c + e;
    double at_half = a / (1 + b * pow(0.5, p)) + d * 0.5 + e;
    double at_rest = a / (1 + b * pow(1 - c, p)) + d * (1 - c) + e;
    return c < 0.5 ? exp(at_c) : exp(2 * at_half - at_rest);
}

double ref_sheen_f_cos(double sheen_c, double sheen_max, double roughness, double base_c,
                       double cos_o, double cos_i, double cos_h)
{
    if (!(cos_o > 0) || !(cos_i > 0))
        return 0.0;
    double r = fmax(roughness, 0.07), alpha = r * r; /* materials.glsl SHEEN_ROUGHNESS_MIN */
    double sin2_h = fmax(1 - cos_h * cos_h, 0.0);
    double d = (2 + 1 / alpha) * pow(sin2_h, 0.5 / alpha) / (2 * M_PI);
    double lobe = d / ((1 + sheen_lambda(cos_o, alpha) + sheen_lambda(cos_i, alpha)) * 4 * cos_o);
    double scale = fmax(fmin(1 - sheen_max * ref_sheen_table(0, cos_o, roughness),
                             1 - sheen_max * ref_sheen_table(0, cos_i, roughness)),
                        0.0);
    return sheen_c * lobe + base_c / M_PI * cos_i * scale;
}

pf_material ref_material_emitter(float r, float g, float b)
{
    pf_material emitter = pf_material_lambert(0, 0, 0);
    emitter.emission[0] = r;
    emitter.emission[1] = g;
    emitter.emission[2] = b;
    return emitter;
}

void ref_scene_add_light(ref_scene *scene, pf_light light)
{
    if (scene->frame.light_count >= REF_SCENE_LIGHTS_MAX)
        ref_fail("too many lights");
    scene->lights[scene->frame.light_count++] = light;
}

static void ref_scene_reserve(ref_scene *scene, uint32_t triangles)
{
    pf_scene_frame *frame = &scene->frame;
    if (frame->triangle_count + triangles <= scene->triangle_capacity)
        return;
    uint32_t capacity = scene->triangle_capacity ? scene->triangle_capacity : 64u;
    while (capacity < frame->triangle_count + triangles)
        capacity *= 2u;
    float(*vertices)[4] = realloc(frame->vertices, (size_t)capacity * 3 * sizeof *vertices);
    if (vertices)
        frame->vertices = vertices;
    float(*normals)[4] = realloc(frame->normals, (size_t)capacity * 3 * sizeof *normals);
    if (normals)
        frame->normals = normals;
    uint32_t *material = realloc(frame->triangle_material, capacity * sizeof *material);
    if (material)
        frame->triangle_material = material;
    uint32_t *node = realloc(frame->triangle_node, capacity * sizeof *node);
    if (node)
        frame->triangle_node = node;
    if (!vertices || !normals || !material || !node)
        ref_fail("out of memory");
    scene->triangle_capacity = capacity;
}

void ref_scene_add_triangle(ref_scene *scene, const float a[3], const float b[3],
                            const float c[3], uint32_t material)
{
    ref_scene_reserve(scene, 1);
    pf_scene_frame *frame = &scene->frame;
    uint32_t t = frame->triangle_count;
    const float *corners[3] = {a, b, c};
    double e1[3], e2[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = (double)b[k] - a[k];
        e2[k] = (double)c[k] - a[k];
    }
    double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                   e1[0] * e2[1] - e1[1] * e2[0]};
    double length = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    double scale = length > 0.0 ? 1.0 / length : 0.0;
    for (int corner = 0; corner < 3; corner++) {
        for (int k = 0; k < 3; k++) {
            float value = corners[corner][k];
            frame->vertices[3 * t + corner][k] = value;
            frame->normals[3 * t + corner][k] = (float)(n[k] * scale);
            if (t == 0 && corner == 0) {
                frame->bounds_min[k] = frame->bounds_max[k] = value;
            } else {
                frame->bounds_min[k] = fminf(frame->bounds_min[k], value);
                frame->bounds_max[k] = fmaxf(frame->bounds_max[k], value);
            }
        }
        frame->vertices[3 * t + corner][3] = 0.0f;
        frame->normals[3 * t + corner][3] = 0.0f;
    }
    frame->triangle_material[t] = material;
    frame->triangle_node[t] = 0;
    const float *emission = scene->materials[material].emission;
    if (emission[0] > 0 || emission[1] > 0 || emission[2] > 0)
        frame->emissive_triangle_count++;
    frame->triangle_count++;
}

void ref_scene_add_quad(ref_scene *scene, const float centre[3], const float half_u[3],
                        const float half_v[3], uint32_t material)
{
    float corners[4][3];
    const float signs[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 3; k++)
            corners[i][k] = centre[k] + signs[i][0] * half_u[k] + signs[i][1] * half_v[k];
    /* Counter-clockwise seen from half_u × half_v: -u-v, +u-v, +u+v, -u+v. */
    ref_scene_add_triangle(scene, corners[0], corners[1], corners[2], material);
    ref_scene_add_triangle(scene, corners[0], corners[2], corners[3], material);
}

void ref_scene_add_box(ref_scene *scene, const float min[3], const float max[3], int inward,
                       uint32_t material)
{
    float corner[8][3];
    for (int i = 0; i < 8; i++) {
        corner[i][0] = (i & 1) ? max[0] : min[0];
        corner[i][1] = (i & 2) ? max[1] : min[1];
        corner[i][2] = (i & 4) ? max[2] : min[2];
    }
    /* Each face's corners, counter-clockwise seen from outside (bit i of a corner's
     * index set: axis i at max). */
    static const int faces[6][4] = {
        {0, 4, 6, 2}, /* -x */
        {1, 3, 7, 5}, /* +x */
        {0, 1, 5, 4}, /* -y */
        {2, 6, 7, 3}, /* +y */
        {0, 2, 3, 1}, /* -z */
        {4, 5, 7, 6}, /* +z */
    };
    for (int f = 0; f < 6; f++) {
        const float *q0 = corner[faces[f][0]], *q1 = corner[faces[f][1]];
        const float *q2 = corner[faces[f][2]], *q3 = corner[faces[f][3]];
        if (inward) {
            ref_scene_add_triangle(scene, q0, q2, q1, material);
            ref_scene_add_triangle(scene, q0, q3, q2, material);
        } else {
            ref_scene_add_triangle(scene, q0, q1, q2, material);
            ref_scene_add_triangle(scene, q0, q2, q3, material);
        }
    }
}

void ref_scene_add_sphere(ref_scene *scene, const float centre[3], float radius,
                          uint32_t segments, uint32_t rings, int inward, uint32_t material)
{
    if (segments < 3 || rings < 2)
        ref_fail("sphere needs at least 3 segments and 2 rings");
    const double pi = acos(-1.0);
    /* Vertex (ring r, segment s): r = 0 is the +z pole, r = rings the -z pole. */
    float(*grid)[3] = malloc((size_t)(rings + 1) * (segments + 1) * sizeof *grid);
    if (!grid)
        ref_fail("out of memory");
    for (uint32_t r = 0; r <= rings; r++) {
        double theta = pi * r / rings;
        for (uint32_t s = 0; s <= segments; s++) {
            /* The seam column repeats column 0 bit for bit: no crack. */
            double phi = 2.0 * pi * (s % segments) / segments;
            float *v = grid[r * (segments + 1) + s];
            double sin_theta = (r == 0 || r == rings) ? 0.0 : sin(theta);
            double cos_theta = r == 0 ? 1.0 : (r == rings ? -1.0 : cos(theta));
            v[0] = centre[0] + (float)(radius * sin_theta * cos(phi));
            v[1] = centre[1] + (float)(radius * sin_theta * sin(phi));
            v[2] = centre[2] + (float)(radius * cos_theta);
        }
    }
    for (uint32_t r = 0; r < rings; r++) {
        for (uint32_t s = 0; s < segments; s++) {
            const float *top0 = grid[r * (segments + 1) + s];
            const float *top1 = grid[r * (segments + 1) + s + 1];
            const float *bottom0 = grid[(r + 1) * (segments + 1) + s];
            const float *bottom1 = grid[(r + 1) * (segments + 1) + s + 1];
            /* Seen from outside, top0 → bottom0 → bottom1 winds counter-clockwise
             * (theta grows downwards, phi to the right). Pole rows lose one triangle. */
            if (r != rings - 1) {
                if (inward)
                    ref_scene_add_triangle(scene, top0, bottom1, bottom0, material);
                else
                    ref_scene_add_triangle(scene, top0, bottom0, bottom1, material);
            }
            if (r != 0) {
                if (inward)
                    ref_scene_add_triangle(scene, top0, top1, bottom1, material);
                else
                    ref_scene_add_triangle(scene, top0, bottom1, top1, material);
            }
        }
    }
    free(grid);
}

static void normalize3(double v[3])
{
    double length = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int k = 0; k < 3; k++)
        v[k] /= length;
}

void ref_scene_look_at(ref_scene *scene, const float eye[3], const float target[3],
                       const float up_hint[3], float yfov)
{
    double forward[3], right[3], up[3];
    for (int k = 0; k < 3; k++)
        forward[k] = (double)target[k] - eye[k];
    normalize3(forward);
    /* right = forward × up_hint, up = right × forward (pf_camera: right = forward × up). */
    right[0] = forward[1] * up_hint[2] - forward[2] * up_hint[1];
    right[1] = forward[2] * up_hint[0] - forward[0] * up_hint[2];
    right[2] = forward[0] * up_hint[1] - forward[1] * up_hint[0];
    normalize3(right);
    up[0] = right[1] * forward[2] - right[2] * forward[1];
    up[1] = right[2] * forward[0] - right[0] * forward[2];
    up[2] = right[0] * forward[1] - right[1] * forward[0];
    pf_camera *camera = &scene->frame.camera;
    for (int k = 0; k < 3; k++) {
        camera->position[k] = eye[k];
        camera->forward[k] = (float)forward[k];
        camera->right[k] = (float)right[k];
        camera->up[k] = (float)up[k];
    }
    camera->yfov = yfov;
    camera->aspect = 0.0f;
    camera->znear = 0.01f;
    camera->zfar = 0.0f;
}

void ref_camera_ray(const pf_camera *camera, uint32_t width, uint32_t height, double film_x,
                    double film_y, double direction[3])
{
    float tan_half_x, tan_half_y;
    pf_camera_image_plane(camera, width, height, &tan_half_x, &tan_half_y);
    double ndc_x = 2.0 * film_x / width - 1.0;
    double ndc_y = 1.0 - 2.0 * film_y / height;
    for (int k = 0; k < 3; k++)
        direction[k] = camera->forward[k] + ndc_x * tan_half_x * camera->right[k] +
                       ndc_y * tan_half_y * camera->up[k];
    normalize3(direction);
}

pf_status ref_load_project_scene(const char *relative, char *path, size_t size,
                                 pf_scene **scene, pf_error *err)
{
    const char *root = getenv("PF_SOURCE_DIR");
    snprintf(path, size, "%s/%s", root ? root : ".", relative);
    return pf_scene_load(path, scene, err);
}

int ref_load_cornell(pf_scene **scene, pf_scene_frame *frame)
{
    pf_error err = {0};
    char path[1024];
    memset(frame, 0, sizeof *frame);
    if (ref_load_project_scene("scenes/cornell/cornell.gltf", path, sizeof path, scene, &err) !=
            PF_OK ||
        pf_scene_eval(*scene, 0.0, frame, &err) != PF_OK) {
        fprintf(stderr, "cornell: %s\n", err.message);
        return 0;
    }
    return 1;
}

pf_render_settings ref_settings(uint32_t width, uint32_t height, uint32_t spp, uint64_t seed,
                                int aovs)
{
    return (pf_render_settings){.width = width,
                                .height = height,
                                .quality = PF_QUALITY_REFERENCE,
                                .samples_per_pixel = spp,
                                .seed = seed,
                                .aovs = aovs};
}

double ref_stage_counter(const pf_frame_report *report, const char *stage, const char *counter)
{
    for (uint32_t s = 0; s < report->stage_count; s++) {
        const pf_stage_timing *row = &report->stages[s];
        if (strcmp(row->stage, stage) != 0)
            continue;
        for (uint32_t c = 0; c < row->counter_count; c++)
            if (!strcmp(row->counters[c].name, counter))
                return row->counters[c].value;
    }
    return NAN;
}

size_t ref_image_non_finite(const pf_image *image)
{
    size_t count = 0;
    size_t values = (size_t)image->width * image->height * image->channel_count;
    for (size_t i = 0; i < values; i++)
        count += !isfinite(image->pixels[i]);
    return count;
}

/* Float rounding allowed between R and direct + indirect (sums of many samples). */
#define REF_LAYER_RELATIVE_SLACK 1e-4

size_t ref_layer_violations(const pf_image *image, const char *what)
{
    static const char *const names[4][3] = {{"R", "G", "B"},
                                            {"direct.R", "direct.G", "direct.B"},
                                            {"indirect.R", "indirect.G", "indirect.B"},
                                            {"caustic.R", "caustic.G", "caustic.B"}};
    int channel[4][3];
    int alpha = pf_image_channel(image, "A");
    int missing = alpha < 0;
    for (int layer = 0; layer < 4; layer++)
        for (int c = 0; c < 3; c++) {
            channel[layer][c] = pf_image_channel(image, names[layer][c]);
            missing |= channel[layer][c] < 0;
        }
    size_t pixels = (size_t)image->width * image->height;
    if (missing) {
        fprintf(stderr, "%s: the image lacks A or a direct/indirect/caustic channel\n", what);
        return pixels;
    }
    size_t violations = 0;
    for (size_t p = 0; p < pixels; p++) {
        const float *pixel = image->pixels + p * image->channel_count;
        int bad = !(pixel[alpha] >= 0.0f && pixel[alpha] <= 1.0f);
        for (uint32_t c = 0; c < image->channel_count; c++)
            bad |= !isfinite(pixel[c]);
        for (int c = 0; c < 3; c++) {
            double beauty = pixel[channel[0][c]], direct = pixel[channel[1][c]];
            double indirect = pixel[channel[2][c]], caustic = pixel[channel[3][c]];
            double slack = REF_LAYER_RELATIVE_SLACK * fabs(beauty) + 1e-9;
            bad |= !(beauty >= 0.0 && direct >= 0.0 && indirect >= 0.0 && caustic >= 0.0);
            bad |= !(fabs(beauty - (direct + indirect)) <= slack);
            bad |= !(caustic <= indirect + slack);
        }
        if (bad && violations++ < 3)
            fprintf(stderr,
                    "%s: pixel (%zu, %zu): R %g direct.R %g indirect.R %g caustic.R %g A %g\n",
                    what, p % image->width, p / image->width, pixel[channel[0][0]],
                    pixel[channel[1][0]], pixel[channel[2][0]], pixel[channel[3][0]],
                    pixel[alpha]);
    }
    return violations;
}

ref_stats ref_stats_of(const double *values, size_t count)
{
    ref_stats stats = {0.0, 0.0, 0.0, count};
    if (count == 0)
        return stats;
    double sum = 0.0;
    for (size_t i = 0; i < count; i++)
        sum += values[i];
    stats.mean = sum / (double)count;
    if (count < 2)
        return stats;
    double squares = 0.0;
    for (size_t i = 0; i < count; i++)
        squares += (values[i] - stats.mean) * (values[i] - stats.mean);
    stats.deviation = sqrt(squares / (double)(count - 1));
    stats.standard_error = stats.deviation / sqrt((double)count);
    return stats;
}

ref_stats ref_region_stats(const pf_image *image, int channel, ref_region region)
{
    return ref_region_block_stats(image, channel, region, 1);
}

ref_stats ref_region_block_stats(const pf_image *image, int channel, ref_region region,
                                 uint32_t block)
{
    uint32_t blocks_x = (region.x1 - region.x0) / block;
    uint32_t blocks_y = (region.y1 - region.y0) / block;
    size_t count = (size_t)blocks_x * blocks_y;
    double *means = malloc((count ? count : 1) * sizeof *means);
    if (!means)
        ref_fail("out of memory");
    for (uint32_t by = 0; by < blocks_y; by++) {
        for (uint32_t bx = 0; bx < blocks_x; bx++) {
            double sum = 0.0;
            for (uint32_t y = 0; y < block; y++)
                for (uint32_t x = 0; x < block; x++)
                    sum += ref_pixel(image, channel, region.x0 + bx * block + x,
                                     region.y0 + by * block + y);
            means[(size_t)by * blocks_x + bx] = sum / ((double)block * block);
        }
    }
    ref_stats stats = ref_stats_of(means, count);
    free(means);
    return stats;
}

void ref_region_means(const pf_image *image, const char *layer, ref_region region,
                      double means[3])
{
    static const char *const components[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; c++) {
        char name[PF_IMAGE_CHANNEL_NAME_MAX];
        snprintf(name, sizeof name, "%s%s%s", layer, layer[0] ? "." : "", components[c]);
        int channel = pf_image_channel(image, name);
        means[c] = channel < 0 ? NAN : ref_region_stats(image, channel, region).mean;
    }
}

double ref_pair_noise(const pf_image *a, const pf_image *b, int channel, ref_region region)
{
    double squares = 0.0;
    size_t count = 0;
    for (uint32_t y = region.y0; y < region.y1; y++) {
        for (uint32_t x = region.x0; x < region.x1; x++) {
            double difference = ref_pixel(a, channel, x, y) - ref_pixel(b, channel, x, y);
            squares += difference * difference;
            count++;
        }
    }
    return count ? sqrt(squares / (2.0 * (double)count)) : 0.0;
}

const pf_stage_timing *ref_row(const pf_frame_report *report, const char *stage)
{
    for (uint32_t i = 0; i < report->stage_count; i++) {
        if (strcmp(report->stages[i].stage, stage) == 0)
            return &report->stages[i];
    }
    return NULL;
}

double ref_layer_relmse(const pf_image *a, const pf_image *b, uint32_t first_channel)
{
    double sum = 0.0;
    size_t pixels = (size_t)a->width * a->height;
    for (size_t p = 0; p < pixels; p++) {
        for (uint32_t c = 0; c < 3; c++) {
            double x = a->pixels[p * a->channel_count + first_channel + c];
            double r = b->pixels[p * b->channel_count + first_channel + c];
            sum += (x - r) * (x - r) / (r * r + PF_RELMSE_EPSILON);
        }
    }
    return sum / (3.0 * pixels);
}

double ref_layer_mean(const pf_image *image, uint32_t first_channel)
{
    double sum = 0.0;
    size_t pixels = (size_t)image->width * image->height;
    for (size_t p = 0; p < pixels; p++)
        for (uint32_t c = 0; c < 3; c++)
            sum += image->pixels[p * image->channel_count + first_channel + c];
    return sum / (3.0 * pixels);
}
