/*
 * Who traces the rays (issue 43, pf_renderer_set_trace_site).
 *
 * reference's two drivers: the megakernel, whose rays the device traces
 * inside its one dispatch a pass, and the wavefront, whose rays the host
 * traces between dispatches (but for each slice's last paths of a pass, which
 * its tail runs to their ends on the device, unless the host is forced).
 * Both run shaders/common/reference_path.glsl's
 * paths from the same random numbers, so the images must agree but for ties
 * between equally distant triangles; the shade row must say which ran and
 * why; an image larger than the wavefront's slice is rendered slice by slice,
 * every pixel once.
 *
 * final's camera rays and gather rays' first segments: traced by the device
 * inside the primary and the gather, or written out, traced by the host and
 * read back as hits (host_rays.glsl's TRACE_STEP). The same rays
 * either way, so the images agree but for the photon maps' atomic order and
 * ties; with precomputed irradiance and without; an image larger than a band
 * of rows is shaded band by band.
 *
 * final's and fast's photons: traced by the device in one flat loop, or in
 * waves whose rays the host traces (photon_path.glsl's PHOTON_STEP). The
 * same photons either way: the same counts stored, the same image but for
 * the maps' order.
 *
 * Alpha-tested materials, in reference and final: the host's traversal has no
 * textures, so the kernels test the hits it finds and go on past those that do
 * not count on the device; the images are the device's all the same.
 */
#include "pf_test.h"
#include "reference_test_util.h"
#include "render_internal.h"
#include "render_test_env.h"

#include <math.h>
#include <string.h>

static pf_vk_context *ctx;
static pf_renderer *renderer;

static int render_with(const pf_scene_frame *frame, const pf_render_settings *settings,
                       pf_trace_site site, pf_image *image, pf_frame_report *report)
{
    pf_renderer_set_trace_site(renderer, site);
    memset(report, 0, sizeof *report);
    pf_error err = {0};
    pf_status status = pf_render_frame(renderer, frame, settings, image, report, &err);
    pf_renderer_set_trace_site(renderer, PF_TRACE_AUTO);
    PF_CHECK_MSG(status == PF_OK, "render: %s", err.message);
    return status == PF_OK;
}

/* Largest difference over every channel (RGB, layers, AOVs) and the pixels that differ. */
static double largest_difference(const pf_image *a, const pf_image *b, size_t *differing)
{
    double largest = 0.0;
    *differing = 0;
    for (size_t p = 0; p < (size_t)a->width * a->height; p++) {
        int differs = 0;
        for (uint32_t c = 0; c < a->channel_count; c++) {
            size_t i = p * a->channel_count + c;
            double d = fabs((double)a->pixels[i] - b->pixels[i]);
            if (d > largest)
                largest = d;
            differs |= d > 1e-5 * (fabs((double)b->pixels[i]) + 1e-3);
        }
        *differing += differs;
    }
    return largest;
}

/* Whether AUTO puts reference's rays on the host here (lavapipe with AVX2). */
static int host_traces_by_default(void)
{
    return strcmp(pf_vk_info(ctx)->type, "cpu") == 0 && pf_bih_wide_available();
}

/* Checks a wavefront's render (host, site HOST or AUTO) against the megakernel's (device);
 * returns whether it had tails (AUTO where the plan says so). */
static int check_wavefront(const pf_image *device, const pf_frame_report *device_report,
                            const pf_image *host, const pf_frame_report *host_report,
                            pf_trace_site site, const pf_render_settings *settings,
                            const char *what, double allowed_differing_share)
{
    PF_CHECK(device->channel_count == host->channel_count);
    size_t differing = 0;
    double largest = largest_difference(host, device, &differing);
    double relmse = ref_layer_relmse(host, device, REF_CH_RGB);
    size_t pixels = (size_t)device->width * device->height;
    double tail_paths = ref_stage_counter(host_report, "shade", "tail_paths");
    printf("  %s%s: %zu of %zu pixels differ (largest %.3g, RGB relMSE %.3g), %g paths in "
           "tails\n",
           what, site == PF_TRACE_HOST ? "" : " (auto)", differing, pixels, largest, relmse,
           tail_paths);
    PF_CHECK_MSG((double)differing <= allowed_differing_share * (double)pixels,
                 "%s: %zu of %zu pixels differ", what, differing, pixels);
    PF_CHECK_MSG(relmse <= 1e-4, "%s: RGB relMSE %g between the drivers", what, relmse);

    /* The tail's rays are counted on the device, the waves' on the host: together, the
     * megakernel's. */
    double device_rays = ref_stage_counter(device_report, "shade", "rays");
    double host_rays = ref_stage_counter(host_report, "shade", "rays");
    PF_CHECK_MSG(fabs(device_rays - host_rays) <= 0.001 * device_rays,
                 "%s: %g rays on the device, %g on the host", what, device_rays, host_rays);
    PF_CHECK(ref_stage_counter(device_report, "shade", "discarded_samples") ==
             ref_stage_counter(host_report, "shade", "discarded_samples"));
    const pf_stage_timing *host_row = ref_row(host_report, "shade");
    if (site == PF_TRACE_HOST) {
        /* Forced onto the host, the host traces every ray: no tail. */
        PF_CHECK(host_row && strstr(host_row->reason, "rays traced on the host (forced)") &&
                 !strstr(host_row->reason, "on the device"));
        PF_CHECK(tail_paths == 0.0);
        /* At least the camera rays' wave and one more per vertex of the longest path. */
        PF_CHECK(ref_stage_counter(host_report, "shade", "waves") >=
                 2.0 * settings->samples_per_pixel);
        PF_CHECK(ref_stage_counter(host_report, "shade", "trace_threads") >= 1.0);
        return 0;
    }
    /* Where the plan gives the frame a tail, each slice's last paths of each pass run to their
     * ends on the device (a frame of few passes goes without, until the kernel is compiled). */
    PF_CHECK(host_row && strstr(host_row->reason, "rays traced on the host (the device is the "
                                                  "CPU)"));
    int tail = host_row && strstr(host_row->reason, "; a slice's last ≤ 512 paths traced on the "
                                                    "device") != NULL;
    PF_CHECK_MSG(tail == (tail_paths > 0.0), "%s: %g paths in tails, the reason says %d", what,
                 tail_paths, tail);
    /* generate, finish, and the tail or at least one more wave */
    PF_CHECK(ref_stage_counter(host_report, "shade", "waves") >= 3.0 * settings->samples_per_pixel);
    PF_CHECK(ref_stage_counter(host_report, "shade", "trace_threads") >= 1.0);
    return tail;
}

/* Renders frame with the megakernel and the wavefront (forced onto the host, and as AUTO
 * has it where that is the host) and checks the images, the counters and the rows' reasons;
 * returns whether AUTO's had tails. */
static int check_drivers_agree(const pf_scene_frame *frame, const pf_render_settings *settings,
                               const char *what, double allowed_differing_share)
{
    int tails = 0;
    pf_image device = {0}, host = {0}, automatic = {0};
    pf_frame_report device_report, host_report, auto_report;
    if (render_with(frame, settings, PF_TRACE_DEVICE, &device, &device_report)) {
        const pf_stage_timing *device_row = ref_row(&device_report, "shade");
        PF_CHECK(device_row && strstr(device_row->reason, "rays traced on the device (forced)"));
        PF_CHECK(isnan(ref_stage_counter(&device_report, "shade", "waves")));
        if (render_with(frame, settings, PF_TRACE_HOST, &host, &host_report))
            check_wavefront(&device, &device_report, &host, &host_report, PF_TRACE_HOST,
                            settings, what, allowed_differing_share);
        if (host_traces_by_default() &&
            render_with(frame, settings, PF_TRACE_AUTO, &automatic, &auto_report)) {
            tails = check_wavefront(&device, &device_report, &automatic, &auto_report,
                                    PF_TRACE_AUTO, settings, what, allowed_differing_share);
            /* The tail runs the wavefront's paths, the same vertex code, the device's
             * traversal finding the host's hits: the wavefront's image bit for bit. */
            size_t differing = 0;
            if (host.pixels && automatic.pixels)
                largest_difference(&automatic, &host, &differing);
            PF_CHECK_MSG(host.pixels && memcmp(host.pixels, automatic.pixels,
                                               (size_t)host.width * host.height *
                                                   host.channel_count * sizeof *host.pixels) == 0,
                         "%s: the wavefront with tails differs in %zu pixels", what, differing);
        }
    }
    pf_image_free(&device);
    pf_image_free(&host);
    pf_image_free(&automatic);
    return tails;
}

PF_TEST(the_cornell_box_is_the_same_image_from_both_drivers)
{
    pf_scene *scene = NULL;
    pf_scene_frame frame = {0};
    if (!ref_load_cornell(&scene, &frame)) {
        PF_CHECK_MSG(0, "the bundled Cornell box did not load");
        return;
    }
    pf_render_settings settings = ref_settings(48, 36, 4, 3, 1);
    check_drivers_agree(&frame, &settings, "Cornell box", 0.0);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

/*
 * A box with punctual lights (several shadow rays a vertex), an emitter (MIS), glass (a
 * medium, refraction), a mirror and a rough metal: every branch of the path's vertex.
 */
static void lit_box(ref_scene *scene)
{
    ref_scene_init(scene);
    uint32_t wall = ref_scene_add_material(scene, ref_material(PF_MATERIAL_LAMBERT, 0.7f, 0.6f,
                                                               0.5f));
    pf_material glass_material = ref_material(PF_MATERIAL_GLASS, 1.0f, 1.0f, 1.0f);
    glass_material.absorption[0] = 1.0f; /* a red-tinting medium inside */
    uint32_t glass = ref_scene_add_material(scene, glass_material);
    uint32_t mirror = ref_scene_add_material(scene, ref_material(PF_MATERIAL_MIRROR, 0.9f, 0.9f,
                                                                 0.9f));
    pf_material metal = ref_material(PF_MATERIAL_LAMBERT, 0.8f, 0.5f, 0.3f);
    metal.metallic = 1.0f;
    metal.roughness = 0.6f;
    uint32_t rough_metal = ref_scene_add_material(scene, metal);
    uint32_t lamp = ref_scene_add_material(scene, ref_material_emitter(4.0f, 4.0f, 3.0f));
    ref_scene_add_box(scene, (float[]){-1, -1, -1}, (float[]){1, 1, 1}, 1, wall);
    ref_scene_add_sphere(scene, (float[]){-0.4f, -0.5f, 0.1f}, 0.35f, 16, 8, 0, glass);
    ref_scene_add_sphere(scene, (float[]){0.45f, -0.6f, -0.2f}, 0.3f, 12, 6, 0, rough_metal);
    ref_scene_add_quad(scene, (float[]){0.0f, 0.2f, -0.99f}, (float[]){0.4f, 0, 0},
                       (float[]){0, 0.3f, 0}, mirror);
    /* Facing down (u × v = -y) into the box. */
    ref_scene_add_quad(scene, (float[]){0.0f, 0.98f, 0.0f}, (float[]){0.25f, 0, 0},
                       (float[]){0, 0, 0.25f}, lamp);
    pf_light point = {.position = {0.5f, 0.6f, 0.5f}, .kind = PF_LIGHT_POINT,
                      .intensity = {1.5f, 1.2f, 1.0f}};
    ref_scene_add_light(scene, point);
    pf_light spot = {.position = {-0.6f, 0.8f, 0.6f}, .kind = PF_LIGHT_SPOT,
                     .direction = {0.3f, -1.0f, -0.3f}, .intensity = {2.0f, 2.0f, 2.0f},
                     .cos_inner_cone = 0.9f, .cos_outer_cone = 0.7f};
    float length = sqrtf(0.09f + 1.0f + 0.09f);
    for (int k = 0; k < 3; k++)
        spot.direction[k] /= length;
    ref_scene_add_light(scene, spot);
    ref_scene_look_at(scene, (float[]){0, 0, 0.95f}, (float[]){0, -0.2f, -1}, (float[]){0, 1, 0},
                      1.2f);
}

PF_TEST(a_box_with_lights_glass_and_metals_is_the_same_image_from_both_drivers)
{
    ref_scene scene;
    lit_box(&scene);
    pf_render_settings settings = ref_settings(40, 32, 4, 11, 1);
    /* Ties between equally distant triangles (the spheres' shared edges) may send a path
     * another way: a few pixels of a thousand at most. */
    check_drivers_agree(&scene.frame, &settings, "lit box", 0.01);
    settings.aovs = 0;
    check_drivers_agree(&scene.frame, &settings, "lit box without AOVs", 0.01);
    ref_scene_free(&scene);
}

PF_TEST(the_wavefront_tail_ends_the_paths_as_the_megakernel)
{
    /* Enough passes for the plan to compile the tail's kernel (a tail a slice a pass). */
    ref_scene scene;
    lit_box(&scene);
    pf_render_settings settings = ref_settings(16, 12, PF_REFERENCE_WAVE_TAIL_MIN_TAILS, 3, 1);
    int tails = check_drivers_agree(&scene.frame, &settings, "lit box, many passes", 0.01);
    PF_CHECK(tails || !host_traces_by_default());
    ref_scene_free(&scene);
}

PF_TEST(an_image_larger_than_a_slice_gets_every_pixel_once)
{
    /* 640 × 420 pixels: more than the wavefront's 2^18 paths at once, so two slices. */
    ref_scene scene;
    lit_box(&scene);
    pf_render_settings settings = ref_settings(640, 420, 1, 5, 0);
    check_drivers_agree(&scene.frame, &settings, "two slices", 0.01);
    ref_scene_free(&scene);
}

/* final's settings: passes, photons a pass. */
static pf_render_settings final_settings(uint32_t width, uint32_t height, uint32_t passes,
                                         uint32_t photons, uint64_t seed)
{
    pf_render_settings settings = ref_settings(width, height, passes, seed, 1);
    settings.quality = PF_QUALITY_FINAL;
    settings.photons_per_pass = photons;
    return settings;
}

/* Renders final both ways; checks the images, the rays and the rows; returns the host's
 * shade-row counter `counter` (NAN when a render failed). */
static double check_gathers_agree(const pf_scene_frame *frame, const pf_render_settings *settings,
                                  const char *what, const char *counter)
{
    pf_image device = {0}, host = {0};
    pf_frame_report device_report, host_report;
    double value = NAN;
    if (render_with(frame, settings, PF_TRACE_DEVICE, &device, &device_report) &&
        render_with(frame, settings, PF_TRACE_HOST, &host, &host_report)) {
        PF_CHECK(device.channel_count == host.channel_count);
        /* The photon maps' stores land in another order from run to run: sums round
         * differently, far below the noise (two device runs differ by ~1e-12). */
        double relmse = ref_layer_relmse(&host, &device, REF_CH_RGB);
        double indirect = ref_layer_relmse(&host, &device, REF_CH_INDIRECT);
        double device_rays = ref_stage_counter(&device_report, "shade", "rays");
        double host_rays = ref_stage_counter(&host_report, "shade", "rays");
        printf("  %s: RGB relMSE %.3g, indirect %.3g; rays %g (device) %g (host)\n", what,
               relmse, indirect, device_rays, host_rays);
        PF_CHECK_MSG(relmse <= 1e-6 && indirect <= 1e-6, "%s: relMSE %g, indirect %g", what,
                     relmse, indirect);
        PF_CHECK_MSG(device_rays > 0 && fabs(device_rays - host_rays) <= 0.001 * device_rays,
                     "%s: %g rays on the device, %g on the host", what, device_rays, host_rays);
        PF_CHECK(ref_stage_counter(&device_report, "shade", "lookup_passes") ==
                 ref_stage_counter(&host_report, "shade", "lookup_passes"));
        const pf_stage_timing *device_row = ref_row(&device_report, "shade");
        const pf_stage_timing *host_row = ref_row(&host_report, "shade");
        PF_CHECK(device_row && strstr(device_row->reason,
                                      "camera and gather rays traced on the device (forced)"));
        PF_CHECK(host_row &&
                 strstr(host_row->reason, "camera and gather rays traced on the host (forced)"));
        PF_CHECK(isnan(ref_stage_counter(&device_report, "shade", "host_traces")));
        PF_CHECK(ref_stage_counter(&device_report, "photon_trace", "stored") ==
                 ref_stage_counter(&host_report, "photon_trace", "stored"));
        PF_CHECK(ref_stage_counter(&host_report, "photon_trace", "waves") > 0.0);
        PF_CHECK(ref_stage_counter(&host_report, "shade", "trace_threads") >= 1.0);
        value = ref_stage_counter(&host_report, "shade", counter);
    }
    pf_image_free(&device);
    pf_image_free(&host);
    return value;
}

PF_TEST(final_gathers_the_same_light_from_host_traced_rays)
{
    ref_scene scene;
    lit_box(&scene);
    /* Few gather rays for the photons stored: estimates in place, no irradiance points. The
     * glass and the mirror send gather rays on, traced in the gather. */
    pf_render_settings settings = final_settings(40, 32, 2, 20000, 3);
    double lookups = check_gathers_agree(&scene.frame, &settings, "lit box, estimates",
                                         "lookup_passes");
    PF_CHECK_MSG(lookups == 0.0, "lit box at 40x32: %g passes with lookups", lookups);
    /* Many gather rays a stored photon: the irradiance points and the deferred estimates. */
    settings = final_settings(160, 120, 2, 4000, 4);
    lookups = check_gathers_agree(&scene.frame, &settings, "lit box, lookups", "lookup_passes");
    PF_CHECK_MSG(lookups == 2.0, "lit box at 160x120: %g passes with lookups", lookups);
    ref_scene_free(&scene);
}

PF_TEST(an_image_larger_than_a_band_is_shaded_band_by_band)
{
    /* 640 × 420 pixels: more than a band's 2^18 pixels, so two bands a pass, each traced
     * twice on the host: its camera rays, its gather rays. */
    ref_scene scene;
    lit_box(&scene);
    pf_render_settings settings = final_settings(640, 420, 1, 20000, 5);
    double traces = check_gathers_agree(&scene.frame, &settings, "two bands", "host_traces");
    PF_CHECK_MSG(traces == 4.0, "640x420, 1 pass: %g host traces", traces);
    ref_scene_free(&scene);
}

PF_TEST(fast_traces_the_same_photons_on_the_host)
{
    ref_scene scene;
    lit_box(&scene);
    pf_render_settings settings = ref_settings(40, 32, 2, 6, 1);
    settings.quality = PF_QUALITY_FAST;
    settings.photons_per_pass = 20000;
    pf_image device = {0}, host = {0};
    pf_frame_report device_report, host_report;
    if (render_with(&scene.frame, &settings, PF_TRACE_DEVICE, &device, &device_report) &&
        render_with(&scene.frame, &settings, PF_TRACE_HOST, &host, &host_report)) {
        double relmse = ref_layer_relmse(&host, &device, REF_CH_RGB);
        double device_vpls = ref_stage_counter(&device_report, "photon_trace", "vpls");
        double host_vpls = ref_stage_counter(&host_report, "photon_trace", "vpls");
        printf("  fast: RGB relMSE %.3g; VPLs %g (device) %g (host), caustic photons %g %g\n",
               relmse, device_vpls, host_vpls,
               ref_stage_counter(&device_report, "photon_trace", "caustic_photons"),
               ref_stage_counter(&host_report, "photon_trace", "caustic_photons"));
        PF_CHECK_MSG(relmse <= 1e-6, "fast: relMSE %g between the sites", relmse);
        PF_CHECK(device_vpls > 0 && device_vpls == host_vpls);
        PF_CHECK(ref_stage_counter(&device_report, "photon_trace", "caustic_photons") ==
                 ref_stage_counter(&host_report, "photon_trace", "caustic_photons"));
        const pf_stage_timing *device_row = ref_row(&device_report, "photon_trace");
        const pf_stage_timing *host_row = ref_row(&host_report, "photon_trace");
        PF_CHECK(device_row && strstr(device_row->reason, "photons traced on the device (forced)"));
        PF_CHECK(host_row && strstr(host_row->reason, "photons traced on the host (forced)"));
        PF_CHECK(isnan(ref_stage_counter(&device_report, "photon_trace", "waves")));
        PF_CHECK(ref_stage_counter(&host_report, "photon_trace", "waves") >= 2.0);
    }
    pf_image_free(&device);
    pf_image_free(&host);
    ref_scene_free(&scene);
}

/*
 * lit_box behind cut-out cards: two blended cards (half of a card's hits count, by a hash of
 * the ray: stochastic transparency), one before the camera, one under the lamp, so that
 * camera, shadow, gather and photon rays meet them, and beside each a masked card whose alpha
 * is below its cutoff everywhere (none of its hits counts).
 */
static void cut_out_box(ref_scene *scene)
{
    lit_box(scene);
    pf_material blended = ref_material(PF_MATERIAL_LAMBERT, 0.2f, 0.7f, 0.3f);
    blended.alpha_mode = PF_ALPHA_BLEND;
    blended.alpha = 0.5f;
    pf_material masked = ref_material(PF_MATERIAL_LAMBERT, 0.9f, 0.1f, 0.1f);
    masked.alpha_mode = PF_ALPHA_MASK;
    masked.alpha = 0.3f;
    masked.alpha_cutoff = 0.5f;
    uint32_t card = ref_scene_add_material(scene, blended);
    uint32_t cut = ref_scene_add_material(scene, masked);
    ref_scene_add_quad(scene, (float[]){0.0f, -0.2f, 0.2f}, (float[]){0.45f, 0, 0},
                       (float[]){0, 0.35f, 0}, card);
    ref_scene_add_quad(scene, (float[]){0.1f, -0.1f, 0.1f}, (float[]){0.5f, 0, 0},
                       (float[]){0, 0.5f, 0}, cut);
    ref_scene_add_quad(scene, (float[]){0.0f, 0.7f, 0.0f}, (float[]){0.7f, 0, 0},
                       (float[]){0, 0, -0.7f}, card);
    ref_scene_add_quad(scene, (float[]){0.0f, 0.6f, 0.0f}, (float[]){0.7f, 0, 0},
                       (float[]){0, 0, -0.7f}, cut);
}

PF_TEST(alpha_tested_materials_are_the_same_image_from_both_sites)
{
    ref_scene scene;
    cut_out_box(&scene);
    PF_CHECK(pf_scene_frame_surface_features(&scene.frame) & PF_SURFACE_ALPHA);
    /* reference: the megakernel's image from the wavefront, whose host says so (AUTO). */
    pf_render_settings settings = ref_settings(40, 32, 4, 12, 1);
    check_drivers_agree(&scene.frame, &settings, "cut-out cards", 0.01);
    /* With the tail, whose first hits are the host's too. */
    settings = ref_settings(16, 12, PF_REFERENCE_WAVE_TAIL_MIN_TAILS, 13, 1);
    PF_CHECK(check_drivers_agree(&scene.frame, &settings, "cut-out cards, many passes", 0.01) ||
             !host_traces_by_default());
    /* final: the camera and gather rays' first hits, and the photons. */
    settings = final_settings(40, 32, 2, 20000, 14);
    check_gathers_agree(&scene.frame, &settings, "cut-out cards, final", "lookup_passes");
    ref_scene_free(&scene);
}

/*
 * llvmpipe's loop cap, never silent: the lit box with 400 more point lights. A vertex's
 * next-event estimation loops over every light; the megakernel traces each shadow ray inside
 * that loop, so a path of a few vertices goes past 65,535 loop iterations in one invocation
 * and the rest of its loops would end short, silently darker (kernel_guard.glsl): the frame
 * fails saying so. The wavefront's vertex only writes the shadow rays (the host traces
 * them): the same frame renders whole there. final's primary traces its shadow rays in the
 * kernel: it fails too.
 */
/* lit_box's lights and MANY_LIGHTS more, on a grid under the ceiling, in lights (the frame's
 * own array for the render: more than ref_scene holds). */
enum { MANY_LIGHTS = 400 };
static void add_many_lights(ref_scene *scene, pf_light lights[MANY_LIGHTS + REF_SCENE_LIGHTS_MAX])
{
    uint32_t own_count = scene->frame.light_count;
    memcpy(lights, scene->frame.lights, own_count * sizeof *lights);
    for (int i = 0; i < MANY_LIGHTS; i++)
        lights[own_count + i] = (pf_light){
            .position = {-0.9f + 1.8f * (float)(i % 25) / 24.0f, 0.9f,
                         -0.9f + 1.8f * (float)(i / 25) / 15.0f},
            .kind = PF_LIGHT_POINT, .intensity = {0.01f, 0.01f, 0.01f}};
    scene->frame.lights = lights;
    scene->frame.light_count = own_count + MANY_LIGHTS;
}

PF_TEST(many_lights_are_sampled_alike_by_every_kernel)
{
    /* Past PF_DIRECT_LIGHTS_EVERY_MAX lights each vertex resamples a few (direct_light.glsl):
     * its shadow rays stop growing with the lights, the megakernel and the wavefront still
     * draw the same samples (the wavefront's shadow slots: pf_direct_light_slots), and no
     * invocation meets llvmpipe's loop cap (402 lights cut samples before, silently, then
     * failing the frame). */
    ref_scene scene;
    lit_box(&scene);
    pf_render_settings settings = ref_settings(16, 12, 1, 15, 0);
    pf_image image = {0};
    pf_frame_report report = {0};
    double few_rays = 0.0;
    if (render_with(&scene.frame, &settings, PF_TRACE_DEVICE, &image, &report)) {
        few_rays = ref_stage_counter(&report, "shade", "rays");
        PF_CHECK(isnan(ref_stage_counter(&report, "shade", "light_samples"))); /* each visited */
    }
    pf_image_free(&image);
    pf_light *own_lights = scene.frame.lights;
    uint32_t own_count = scene.frame.light_count;
    pf_light lights[MANY_LIGHTS + REF_SCENE_LIGHTS_MAX];
    add_many_lights(&scene, lights);
    if (render_with(&scene.frame, &settings, PF_TRACE_DEVICE, &image, &report)) {
        double rays = ref_stage_counter(&report, "shade", "rays");
        printf("  megakernel: %g rays with %u lights, %g with %u; %g samples cut\n", rays,
               scene.frame.light_count, few_rays, own_count,
               ref_stage_counter(&report, "shade", "loop_truncated"));
        PF_CHECK(ref_stage_counter(&report, "shade", "loop_truncated") == 0.0);
        PF_CHECK(ref_stage_counter(&report, "shade", "light_samples") == PF_DIRECT_LIGHT_SAMPLES);
        /* A vertex casts up to 1 + 4 shadow rays instead of 1 + 2, not 1 + 402 (~100 times
         * as many rays as with 2 lights). */
        PF_CHECK_MSG(rays <= 3.0 * few_rays, "%g rays against %g", rays, few_rays);
    }
    pf_image_free(&image);
    /* This renderer's earlier frames had more than PF_REFERENCE_WAVE_TAIL_MIN_TAILS tails
     * (the_wavefront_tail_ends_the_paths_as_the_megakernel ran first), so AUTO's frame has a
     * tail, whose lanes trace their shadow rays on the device: the same samples again. */
    int tails = check_drivers_agree(&scene.frame, &settings, "400 lights", 0.0);
    PF_CHECK(tails || !host_traces_by_default());
    /* final's primary traces its shadow rays in the kernel. */
    settings = final_settings(16, 12, 1, 20000, 16);
    if (render_with(&scene.frame, &settings, PF_TRACE_AUTO, &image, &report)) {
        PF_CHECK(ref_stage_counter(&report, "shade", "loop_truncated") == 0.0);
        PF_CHECK(ref_stage_counter(&report, "shade", "light_samples") ==
                 PF_DIRECT_LIGHT_PIXEL_SAMPLES);
    }
    pf_image_free(&image);
    scene.frame.lights = own_lights;
    scene.frame.light_count = own_count;
    ref_scene_free(&scene);
}

PF_TEST(the_loop_cap_fails_a_frame_where_the_device_traces)
{
    /* llvmpipe ends an invocation's loops after 65,535 rounds in all (kernel_guard.glsl). A
     * stack of coincident quads in front of the camera makes every closest hit test each of
     * their triangles: the megakernel's paths meet the cap and the frame fails, naming it;
     * the wavefront, whose kernels only read the host's hits, renders it whole. */
    ref_scene scene;
    lit_box(&scene);
    uint32_t card = ref_scene_add_material(&scene, ref_material(PF_MATERIAL_LAMBERT, 0.5f, 0.5f,
                                                                0.5f));
    enum { STACKED = 20000 };
    for (int i = 0; i < STACKED; i++)
        ref_scene_add_quad(&scene, (float[]){0.0f, -0.2f, -0.3f}, (float[]){0.5f, 0, 0},
                           (float[]){0, 0.5f, 0}, card);
    pf_render_settings settings = ref_settings(16, 12, 1, 15, 0);
    pf_renderer_set_trace_site(renderer, PF_TRACE_DEVICE);
    pf_image image = {0};
    pf_frame_report report = {0};
    pf_error err = {0};
    pf_status status = pf_render_frame(renderer, &scene.frame, &settings, &image, &report, &err);
    pf_renderer_set_trace_site(renderer, PF_TRACE_AUTO);
    printf("  megakernel: status %d: %s\n", (int)status, err.message);
    PF_CHECK(status == PF_ERR_LIMIT && strstr(err.message, "loop cap") &&
             strstr(err.message, "the device traces every path"));
    PF_CHECK(image.pixels == NULL);
    pf_image_free(&image);
    if (render_with(&scene.frame, &settings, PF_TRACE_HOST, &image, &report)) {
        double truncated = ref_stage_counter(&report, "shade", "loop_truncated");
        printf("  wavefront: %g samples cut, %g discarded\n", truncated,
               ref_stage_counter(&report, "shade", "discarded_samples"));
        PF_CHECK(truncated == 0.0);
        PF_CHECK(ref_stage_counter(&report, "shade", "discarded_samples") == 0.0);
    }
    pf_image_free(&image);
    /* final, its rays traced on the device, is caught too (by its photons, traced first). */
    settings = final_settings(16, 12, 1, 20000, 16);
    pf_renderer_set_trace_site(renderer, PF_TRACE_DEVICE);
    status = pf_render_frame(renderer, &scene.frame, &settings, &image, &report, &err);
    pf_renderer_set_trace_site(renderer, PF_TRACE_AUTO);
    printf("  final: status %d: %s\n", (int)status, err.message);
    PF_CHECK(status == PF_ERR_LIMIT && strstr(err.message, "loop cap"));
    pf_image_free(&image);
    ref_scene_free(&scene);
}

PF_TEST(a_moved_scene_is_traced_through_its_own_tree)
{
    /* The host's traces share one wide view of the frame's tree (pf_renderer_bih_wide). A
     * frame whose geometry moved refits the tree: the view must be built again, or the host
     * would trace the old geometry. */
    ref_scene scene;
    lit_box(&scene);
    pf_render_settings settings = ref_settings(32, 24, 2, 8, 0);
    pf_image before = {0}, host = {0}, device = {0};
    pf_frame_report report;
    int rendered = render_with(&scene.frame, &settings, PF_TRACE_HOST, &before, &report);
    /* Everything 5 cm to the side: the same triangles, moved (a refit). */
    for (uint32_t v = 0; v < 3 * scene.frame.triangle_count; v++)
        scene.frame.vertices[v][0] += 0.05f;
    rendered = rendered && render_with(&scene.frame, &settings, PF_TRACE_HOST, &host, &report);
    const pf_stage_timing *bih = rendered ? ref_row(&report, "bih_build") : NULL;
    PF_CHECK_MSG(bih && strstr(bih->reason, "refit"), "bih_build: '%s'", bih ? bih->reason : "");
    rendered = rendered && render_with(&scene.frame, &settings, PF_TRACE_DEVICE, &device, &report);
    if (rendered) {
        double moved = ref_layer_relmse(&host, &before, REF_CH_RGB);
        double relmse = ref_layer_relmse(&host, &device, REF_CH_RGB);
        printf("  moved: relMSE %.3g against the device, %.3g against before the move\n", relmse,
               moved);
        PF_CHECK_MSG(relmse <= 1e-6, "moved: relMSE %g between the sites", relmse);
        PF_CHECK(moved > 1e-4); /* the move shows */
    }
    pf_image_free(&before);
    pf_image_free(&host);
    pf_image_free(&device);
    ref_scene_free(&scene);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    /* The host traces only where the device is the CPU (its memory the host's), with AVX2. */
    if (!pf_vk_device_is_cpu(ctx) || !pf_bih_wide_available()) {
        printf("skipped: the host traces only where the device is the CPU, with AVX2\n");
        return render_test_finish(ctx, renderer);
    }
    PF_RUN(the_cornell_box_is_the_same_image_from_both_drivers);
    PF_RUN(a_box_with_lights_glass_and_metals_is_the_same_image_from_both_drivers);
    PF_RUN(the_wavefront_tail_ends_the_paths_as_the_megakernel);
    PF_RUN(an_image_larger_than_a_slice_gets_every_pixel_once);
    PF_RUN(final_gathers_the_same_light_from_host_traced_rays);
    PF_RUN(an_image_larger_than_a_band_is_shaded_band_by_band);
    PF_RUN(fast_traces_the_same_photons_on_the_host);
    PF_RUN(alpha_tested_materials_are_the_same_image_from_both_sites);
    PF_RUN(many_lights_are_sampled_alike_by_every_kernel);
    PF_RUN(the_loop_cap_fails_a_frame_where_the_device_traces);
    PF_RUN(a_moved_scene_is_traced_through_its_own_tree);
    return render_test_finish(ctx, renderer);
}
