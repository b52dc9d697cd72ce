/*
 * Shared by the reference path tracer's tests (test_reference_*.c): scenes
 * built by hand (quads, boxes, spheres with a chosen winding, a look-at
 * camera), the camera ray through any point of the film (as
 * shaders/common/camera.glsl computes it), and statistics over pixels.
 *
 * Winding: a triangle's front face is the one its vertices wind
 * counter-clockwise around (pf_scene.h); emissive triangles emit from it only.
 * The stored shading normals are the geometric ones of that winding.
 */
#ifndef REFERENCE_TEST_UTIL_H
#define REFERENCE_TEST_UTIL_H

#include "pf_render.h"

#include <stddef.h>
#include <stdint.h>

#define REF_SCENE_MATERIALS_MAX 16u
#define REF_SCENE_LIGHTS_MAX 8u

/*
 * Widest pixel filter the tests allow for: a sample taken for pixel (x, y)
 * lands within this many pixels of the pixel's centre (box 0.5, tent 1,
 * Gaussian/Mitchell/Blackman-Harris as usually sized ≤ 2). Analytic
 * comparisons take the range of the exact value over this footprint as the
 * bias the filter may add.
 */
#define REF_FILTER_RADIUS_PIXELS 2.0

/* A frame built by hand. Keep it in place once triangles are added (frame points into it). */
typedef struct ref_scene {
    pf_scene_frame frame;
    uint32_t triangle_capacity;
    pf_material materials[REF_SCENE_MATERIALS_MAX];
    pf_light lights[REF_SCENE_LIGHTS_MAX];
} ref_scene;

/* An empty scene (no triangles, materials, lights; camera at the origin looking along -z). */
void ref_scene_init(ref_scene *scene);
void ref_scene_free(ref_scene *scene);

/* Appends a material; returns its index. Aborts the test program beyond REF_SCENE_MATERIALS_MAX. */
uint32_t ref_scene_add_material(ref_scene *scene, pf_material material);
/* Shorthands: a material of that kind with albedo (r, g, b), no emission, ior 1.5. */
pf_material ref_material(pf_material_kind kind, float r, float g, float b);

/* Unpolarized Fresnel reflectance of a smooth dielectric in doubles, an oracle
 * for the shaders' (cos_i on the incident side, eta = η_t/η_i; 1 under total
 * internal reflection). */
double ref_fresnel_dielectric(double cos_i, double eta);
/* KHR_materials_sheen's oracle in doubles, from the spec's formulas (materials.glsl's header):
 * table 0 (E) or 1 (B) of the sheen's albedo tables at (mu, roughness), bilinear as the
 * shader reads them; and f·cos_i of one channel of a sheen (that channel sheen_c, its
 * largest sheen_max, sheen roughness) over a Lambert base of albedo base_c, the cosines
 * about the normal (cos_h: of the half vector). */
double ref_sheen_table(int table, double mu, double roughness);
double ref_sheen_f_cos(double sheen_c, double sheen_max, double roughness, double base_c,
                       double cos_o, double cos_i, double cos_h);
/* A black Lambert emitter of radiance (r, g, b) W/(sr·m²). */
pf_material ref_material_emitter(float r, float g, float b);
/* Appends a light. Aborts beyond REF_SCENE_LIGHTS_MAX. */
void ref_scene_add_light(ref_scene *scene, pf_light light);

/*
 * Appends triangle (a, b, c): front face where a→b→c winds counter-clockwise,
 * the three vertex normals set to that face's unit normal (zero for a
 * zero-area triangle). Grows the bounds and the emissive count.
 */
void ref_scene_add_triangle(ref_scene *scene, const float a[3], const float b[3],
                            const float c[3], uint32_t material);
/*
 * Appends the parallelogram centre ± half_u ± half_v as two triangles whose
 * front face points along half_u × half_v.
 */
void ref_scene_add_quad(ref_scene *scene, const float centre[3], const float half_u[3],
                        const float half_v[3], uint32_t material);
/* Appends a closed axis-aligned box (12 triangles sharing exact corners), front faces out or in. */
void ref_scene_add_box(ref_scene *scene, const float min[3], const float max[3], int inward,
                       uint32_t material);
/*
 * Appends a closed UV sphere (vertices on the sphere, exactly shared between
 * neighbouring triangles, so the polyhedron is watertight and convex): front
 * faces out, or in. segments ≥ 3 around, rings ≥ 2 from pole to pole.
 */
void ref_scene_add_sphere(ref_scene *scene, const float centre[3], float radius,
                          uint32_t segments, uint32_t rings, int inward, uint32_t material);

/* Pinhole camera at eye looking at target; up_hint must not be parallel to the view. */
void ref_scene_look_at(ref_scene *scene, const float eye[3], const float target[3],
                       const float up_hint[3], float yfov);

/*
 * Unit direction of the camera ray through film position (film_x, film_y) in
 * pixels (pixel (x, y) covers [x, x+1) × [y, y+1), row 0 at the top) of a
 * width × height image: camera.glsl's formula, in double.
 */
void ref_camera_ray(const pf_camera *camera, uint32_t width, uint32_t height, double film_x,
                    double film_y, double direction[3]);

/*
 * Loads the bundled Cornell box ($PF_SOURCE_DIR/scenes/cornell/cornell.gltf)
 * evaluated at time 0; 1 on success, else 0 after printing why.
 */
int ref_load_cornell(pf_scene **scene, pf_scene_frame *frame);

/* Loads the project's scene at relative ($PF_SOURCE_DIR/relative), its path left in path. */
pf_status ref_load_project_scene(const char *relative, char *path, size_t size,
                                 pf_scene **scene, pf_error *err);

/* Settings for a reference render: width × height, spp samples per pixel, seed. */
pf_render_settings ref_settings(uint32_t width, uint32_t height, uint32_t spp, uint64_t seed,
                                int aovs);

/* Value of counter `counter` in the report's row `stage`; NaN when either is missing. */
double ref_stage_counter(const pf_frame_report *report, const char *stage, const char *counter);

/* First channel of each layer of the split integrators' images (pf_render.h's order). */
#define REF_CH_RGB 0u
#define REF_CH_DIRECT 4u
#define REF_CH_INDIRECT 7u
#define REF_CH_CAUSTIC 10u

/* The stage row named stage, or NULL. */
const pf_stage_timing *ref_row(const pf_frame_report *report, const char *stage);

/*
 * relMSE (pf_image_compare's formula) of a's channels first..first+2 against
 * b's (the same channel layout), and the mean of those three channels.
 */
double ref_layer_relmse(const pf_image *a, const pf_image *b, uint32_t first_channel);
double ref_layer_mean(const pf_image *image, uint32_t first_channel);

/* Number of NaN or infinite values over every channel of every pixel. */
size_t ref_image_non_finite(const pf_image *image);

/* Value of channel `channel` (an index) at pixel (x, y). */
static inline double ref_pixel(const pf_image *image, int channel, uint32_t x, uint32_t y)
{
    return image->pixels[((size_t)y * image->width + x) * image->channel_count + (size_t)channel];
}

/*
 * Pixels breaking what every reference image must satisfy, over all pixels:
 * every channel finite; R, G, B and every direct/indirect/caustic value ≥ 0;
 * R = direct + indirect (to float rounding); caustic ≤ indirect (caustic light
 * is part of the indirect light); 0 ≤ A ≤ 1. Prints the first few offenders
 * prefixed by `what`. A missing layer counts every pixel.
 */
size_t ref_layer_violations(const pf_image *image, const char *what);

/* Pixels [x0, x1) × [y0, y1). */
typedef struct ref_region {
    uint32_t x0, y0, x1, y1;
} ref_region;

/* Mean, sample standard deviation and standard error of the mean of count values. */
typedef struct ref_stats {
    double mean;
    double deviation;
    double standard_error;
    size_t count;
} ref_stats;

ref_stats ref_stats_of(const double *values, size_t count);

/* Statistics of one channel's pixel values over a region (each pixel one value). */
ref_stats ref_region_stats(const pf_image *image, int channel, ref_region region);

/*
 * Statistics of the means of block × block tiles of the region (tiles that do
 * not fit are left out). A pixel filter wider than a pixel correlates
 * neighbouring pixels; tiles at least twice the filter radius wide are nearly
 * independent, so their standard error is an honest one.
 */
ref_stats ref_region_block_stats(const pf_image *image, int channel, ref_region region,
                                 uint32_t block);

/*
 * Mean of `layer`'s R, G, B over a region: layer "" is the beauty R/G/B,
 * otherwise "<layer>.R" etc. Channels missing from the image give NaN.
 */
void ref_region_means(const pf_image *image, const char *layer, ref_region region,
                      double means[3]);

/*
 * Per-pixel noise of one channel from two renders that differ only in their
 * seed: sqrt(mean over the region of (a − b)² / 2), the standard deviation of
 * one render's pixel.
 */
double ref_pair_noise(const pf_image *a, const pf_image *b, int channel, ref_region region);

#endif
