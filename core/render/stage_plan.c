/*
 * The stage planner (DESIGN.md §4): before a frame renders, which of its
 * preset's stages run, which reuse the previous frame's output, which the
 * scene does not need, and with what parameters, each with its reason.
 * The integrators (frame_*.c) carry the plan out and never decide for
 * themselves; their rows carry the plan's reasons.
 *
 * Every stage has a row in stage_table: its inputs and what it makes. A
 * stage's reuse key is the fingerprint of each input it reads (directly or
 * through the stages before it); a preset's stage memory (pf_stage_memory,
 * kept in the renderer) holds the fingerprints each kept output was made
 * from. Equal fingerprints → reuse; otherwise the stage runs and its reason
 * names the inputs that changed ("traced: lights changed"), so a user
 * reading `timings` sees why a frame cost what it did. Fingerprints are
 * 64-bit content hashes, so a worker switching scenes never reuses what
 * does not fit, and a scene that returns to an earlier state after a
 * change (a light switched off and on) is recognised by content.
 *
 * The BIH is the exception: its tree is compared with the frame's
 * triangles exactly (frame_bih.c), because a refit needs the old tree
 * anyway, and only the execution knows whether the refit holds its SAH.
 */
#include "render_internal.h"

#include <stdio.h>
#include <string.h>

/*
 * fast: camera samples per pixel. The direct light's one light sample per
 * camera sample is the noise of this preset (the LPV is smooth). Measured on
 * the Cornell box at 160×120 against a 512-spp reference: relMSE 0.035,
 * 0.016, 0.011 at 1, 2, 4 spp (preview: 0.062), at 0.45, 0.95, 1.9 s of
 * shading per 640×480 frame on lavapipe. 2 keeps the error well under a
 * third of preview's at half the cost of 4.
 */
#define FAST_DEFAULT_SAMPLES 2u
/*
 * fast: photons per frame. The LPV averages a cell's VPLs, so a few tens of
 * thousands suffice (the Kaplanyan paper injects 128² = 16k VPLs per
 * cascade); this count costs well under a second on lavapipe.
 */
#define FAST_DEFAULT_PHOTONS 32768u
/* final: passes (= camera samples per pixel) when the settings ask for the default. */
#define FINAL_DEFAULT_PASSES 4u
/*
 * final: photons emitted per pass: about a second per pass on lavapipe (2
 * shared cores: 3.7 s for 4 passes on cornell-anim), and the Cornell box's
 * global map then holds ~10^5 photons (its open front lets the rest
 * escape), r_1 ≈ 2.5 cm.
 */
#define FINAL_DEFAULT_PHOTONS_PER_PASS 100000u
/* reference: samples per pixel by default; preview: one at the pixel centre (no jitter). */
#define REFERENCE_DEFAULT_SAMPLES 64u
#define PREVIEW_DEFAULT_SAMPLES 1u

/* Inputs, in the order a reason names them. */
static const char *const input_names[PF_INPUT_COUNT] = {
    "geometry", "materials", "lights", "seed, photon count or bounces", "cascade origins",
    "LPV iterations"};

#define IN(x) (1u << (x))
#define PHOTON_INPUTS                                                                          \
    (IN(PF_INPUT_GEOMETRY) | IN(PF_INPUT_SURFACES) | IN(PF_INPUT_LIGHTS) | IN(PF_INPUT_PHOTONS))

/* The stages: their rows' names, what they read, what they make, how a run is named. */
static const struct stage_spec {
    const char *name;
    uint32_t inputs; /* IN() of every pf_stage_input its output depends on */
    const char *makes;
    const char *verb;          /* the run's reason starts "<verb>: " */
    const char *reuse_reason;  /* NULL: never reused (the frame's own film) */
} stage_table[PF_STAGE_COUNT] = {
    [PF_STAGE_BIH_BUILD] = {"bih_build", IN(PF_INPUT_GEOMETRY), "the BIH over the frame's triangles",
                            "built", "geometry unchanged → BIH reused"},
    [PF_STAGE_PHOTON_TRACE] = {"photon_trace", PHOTON_INPUTS,
                               "photons (final: per pass; fast: the VPLs)", "traced",
                               "lights and geometry unchanged → photon maps reused"},
    [PF_STAGE_PHOTON_GRID] = {"photon_grid", PHOTON_INPUTS, "the global photon grids",
                              "gridded", "lights and geometry unchanged → photon grids reused"},
    [PF_STAGE_CAUSTIC_MAP] = {"caustic_map", PHOTON_INPUTS, "the caustic photon grids", "built",
                              "lights and geometry unchanged → caustic grids reused"},
    [PF_STAGE_LPV_GEOMETRY] = {"lpv_geometry", IN(PF_INPUT_GEOMETRY) | IN(PF_INPUT_CASCADES),
                               "the geometry volume of every cascade", "built",
                               "geometry and cascade origins unchanged → geometry volume reused"},
    [PF_STAGE_LPV_INJECT] = {"lpv_inject", PHOTON_INPUTS | IN(PF_INPUT_CASCADES),
                             "the VPLs' SH in every cascade", "injected",
                             "VPLs and cascade origins unchanged → injection reused"},
    [PF_STAGE_LPV_PROPAGATE] = {"lpv_propagate",
                                PHOTON_INPUTS | IN(PF_INPUT_CASCADES) | IN(PF_INPUT_ITERATIONS),
                                "the propagated volumes", "propagated",
                                "lights, geometry and snapped cascade origins unchanged → LPV "
                                "reused"},
    [PF_STAGE_SHADE] = {"shade", 0, "the frame's film", "shaded", NULL},
};

const char *pf_stage_name(pf_stage_id stage) { return stage_table[stage].name; }

/* 64-bit content hash (FNV-1a over 8-byte words, then a final mix). */
uint64_t pf_hash_bytes(uint64_t h, const void *data, size_t bytes)
{
    const unsigned char *p = data;
    while (bytes >= 8) {
        uint64_t word;
        memcpy(&word, p, 8);
        h = (h ^ word) * 0x100000001b3ull;
        h ^= h >> 29;
        p += 8;
        bytes -= 8;
    }
    while (bytes--)
        h = (h ^ *p++) * 0x100000001b3ull;
    return h;
}

static uint64_t hash_u64(uint64_t h, uint64_t value) { return pf_hash_bytes(h, &value, sizeof value); }


static void fingerprint_scene(const pf_scene_frame *frame, uint64_t inputs[PF_INPUT_COUNT])
{
    uint64_t h = hash_u64(PF_HASH_START, frame->triangle_count);
    inputs[PF_INPUT_GEOMETRY] =
        pf_hash_bytes(h, frame->vertices, (size_t)frame->triangle_count * 3 * sizeof frame->vertices[0]);
    h = hash_u64(PF_HASH_START, frame->material_count);
    h = pf_hash_bytes(h, frame->materials, frame->material_count * sizeof(pf_material));
    inputs[PF_INPUT_SURFACES] =
        pf_hash_bytes(h, frame->triangle_material, frame->triangle_count * sizeof(uint32_t));
    h = hash_u64(PF_HASH_START, frame->light_count);
    inputs[PF_INPUT_LIGHTS] = pf_hash_bytes(h, frame->lights, frame->light_count * sizeof(pf_light));
}

static void fingerprint_cascades(const pf_lpv_layout *layout, uint64_t inputs[PF_INPUT_COUNT])
{
    uint64_t h = hash_u64(PF_HASH_START, layout->count);
    h = hash_u64(h, layout->size);
    h = pf_hash_bytes(h, &layout->offset_cells, sizeof layout->offset_cells);
    uint64_t iterations = hash_u64(PF_HASH_START, layout->count);
    for (uint32_t k = 0; k < layout->count; k++) {
        h = pf_hash_bytes(h, &layout->cascades[k].cell_size, sizeof layout->cascades[k].cell_size);
        h = pf_hash_bytes(h, layout->cascades[k].origin_cell, sizeof layout->cascades[k].origin_cell);
        iterations = hash_u64(iterations, layout->cascades[k].iterations);
    }
    inputs[PF_INPUT_CASCADES] = h;
    inputs[PF_INPUT_ITERATIONS] = iterations;
}

void pf_stage_decide(pf_stage_plan *plan, pf_stage_id stage, const pf_stage_memory *memory)
{
    const struct stage_spec *spec = &stage_table[stage];
    pf_stage_decision *d = &plan->stages[stage];
    d->action = PF_STAGE_RUN;
    if (!spec->reuse_reason) {
        d->reason[0] = '\0';
        return;
    }
    if (!memory || !memory->valid[stage]) {
        snprintf(d->reason, sizeof d->reason, "%s: %s", spec->verb,
                 !memory || memory->frames == 0 ? "first frame"
                 : memory->pilot_replaced      ? "nothing kept (auto's pilot replaced what "
                                                 "the previous frame kept)"
                                               : "nothing kept (the previous frame did not "
                                                 "keep it)");
        return;
    }
    size_t used = (size_t)snprintf(d->reason, sizeof d->reason, "%s: ", spec->verb);
    int changed = 0;
    for (int i = 0; i < PF_INPUT_COUNT; i++) {
        if (!(spec->inputs & IN(i)) || memory->made_from[stage][i] == plan->inputs[i])
            continue;
        if (used < sizeof d->reason)
            used += (size_t)snprintf(d->reason + used, sizeof d->reason - used, "%s%s",
                                     changed ? ", " : "", input_names[i]);
        changed++;
    }
    if (!changed) {
        d->action = PF_STAGE_REUSE;
        snprintf(d->reason, sizeof d->reason, "%s", spec->reuse_reason);
    } else if (used < sizeof d->reason) {
        snprintf(d->reason + used, sizeof d->reason - used, " changed");
    }
}

void pf_stage_plan_release(pf_stage_plan *plan)
{
    pf_photon_emitters_free(&plan->emitters);
}

void pf_stage_skip(pf_stage_plan *plan, pf_stage_id stage, const char *reason)
{
    plan->stages[stage].action = PF_STAGE_SKIP;
    snprintf(plan->stages[stage].reason, sizeof plan->stages[stage].reason, "%s", reason);
}

void pf_stage_remember(pf_stage_memory *memory, const pf_stage_plan *plan, pf_stage_id stage)
{
    memory->valid[stage] = 1;
    memcpy(memory->made_from[stage], plan->inputs, sizeof plan->inputs);
}

void pf_stage_forget(pf_stage_memory *memory)
{
    memset(memory->valid, 0, sizeof memory->valid);
    memory->kept_passes = 0;
}

/* "N per pixel (the preset's default)" or "(asked)". */
static uint32_t samples_of(const pf_render_settings *settings, uint32_t preset_default,
                           pf_stage_plan *plan, const char *what)
{
    uint32_t samples = settings->samples_per_pixel ? settings->samples_per_pixel : preset_default;
    char *reason = plan->stages[PF_STAGE_SHADE].reason;
    snprintf(reason, PF_STAGE_REASON_MAX, "%s: %u per pixel (%s)", what, samples,
             settings->samples_per_pixel ? "asked" : "the preset's default");
    uint32_t scale = settings->sample_scale;
    if (scale > 1 && samples <= UINT32_MAX / scale) {
        samples *= scale;
        size_t used = strlen(reason);
        snprintf(reason + used, PF_STAGE_REASON_MAX - used,
                 " × %u (first of a run, nothing to blend)", scale);
    }
    return samples;
}

/*
 * Who traces the rays the host can trace (pf_trace_site): reference's (its wavefront),
 * final's camera rays and gather rays' first segments, and final's and fast's photons. The
 * host traces where it can and the device is the CPU: its wide traversal runs several times
 * the device's speed there (bench/RESULTS.md, "Rays where the device traces them best"); a
 * forced site the frame cannot honour falls back to the device. Alpha-tested materials are
 * no reason: the host's traversal has no textures, so the kernels that read its hits test
 * them and go on past a hit that does not count themselves (bih_traverse.glsl
 * trace_bih_surfaces_after). Sets plan->host_traces; returns why the device traces, or NULL.
 */
static const char *plan_trace_site(const pf_stage_previous *previous, pf_stage_plan *plan)
{
    const char *why_not = NULL;
    if (previous->trace_site == PF_TRACE_DEVICE)
        why_not = "forced";
    else if (!previous->device_is_host && previous->trace_site == PF_TRACE_AUTO)
        why_not = "the device is not the CPU";
    else if (!previous->device_is_host)
        why_not = "the device's memory is not the host's";
    else if (!previous->host_traversal)
        why_not = "this CPU has no AVX2 for the host's wide traversal";
    else if (!previous->tree_on_host)
        why_not = "the BIH is built on the device";
    plan->host_traces = why_not == NULL;
    return why_not;
}

/* Appends who traces to stage's reason where the stage runs: `host_rays` traced on the host
 * (why), or `rays` on the device (why_not). */
static void say_trace_site(pf_stage_plan *plan, pf_stage_id stage,
                           const pf_stage_previous *previous, const char *why_not,
                           const char *host_rays, const char *rays)
{
    if (plan->stages[stage].action != PF_STAGE_RUN)
        return;
    char *reason = plan->stages[stage].reason;
    size_t used = strlen(reason);
    if (!why_not)
        snprintf(reason + used, PF_STAGE_REASON_MAX - used, "; %s traced on the host%s", host_rays,
                 previous->trace_site == PF_TRACE_HOST ? " (forced)"
                                                        : " (the device is the CPU)");
    else
        snprintf(reason + used, PF_STAGE_REASON_MAX - used, "; %s traced on the device (%s)",
                 rays, why_not);
}

/*
 * reference's wavefront: the tails of this frame (a slice a pass) in plan->wave_tails, and
 * whether its tail kernel has paid or pays for its compilation with them
 * (PF_REFERENCE_WAVE_TAIL_MIN_TAILS), or is compiled already. (A tail's lane traces a
 * shadow ray a light at each of up to ~100 vertices in one invocation, whose loops llvmpipe
 * ends after 65,535 rounds in all: direct light visits at most PF_DIRECT_LIGHTS_EVERY_MAX
 * lights a vertex and samples a few past that, so no frame has too many for a tail.)
 */
static int worth_a_tail(const pf_scene_frame *frame, const pf_render_settings *settings,
                        const pf_stage_previous *previous, pf_stage_plan *plan)
{
    uint64_t pixels = (uint64_t)settings->width * settings->height;
    uint64_t slices = (pixels + PF_REFERENCE_WAVE_MAX_PATHS - 1) / PF_REFERENCE_WAVE_MAX_PATHS;
    plan->wave_tails = (uint64_t)plan->samples * slices;
    uint32_t variant = pf_scene_frame_surface_features(frame) % PF_SURFACE_VARIANTS;
    return ((previous->wave_tail_compiled[variant / 64u] >> (variant % 64u)) & 1u) != 0 ||
           previous->wave_tails_before + plan->wave_tails >= PF_REFERENCE_WAVE_TAIL_MIN_TAILS;
}

/* final and fast: the photon stages from the scene's emitters and specular surfaces. */
static void plan_photons(pf_stage_plan *plan, const pf_stage_memory *memory, int with_grid)
{
    const char *no_light = "no lights or emissive surfaces → no photons";
    pf_stage_decide(plan, PF_STAGE_PHOTON_TRACE, memory);
    if (with_grid)
        pf_stage_decide(plan, PF_STAGE_PHOTON_GRID, memory);
    pf_stage_decide(plan, PF_STAGE_CAUSTIC_MAP, memory);
    if (plan->emitters.count == 0) {
        pf_stage_skip(plan, PF_STAGE_PHOTON_TRACE, no_light);
        if (with_grid)
            pf_stage_skip(plan, PF_STAGE_PHOTON_GRID, no_light);
        pf_stage_skip(plan, PF_STAGE_CAUSTIC_MAP, no_light);
    } else if (!plan->caustic_map) {
        pf_stage_skip(plan, PF_STAGE_CAUSTIC_MAP,
                      plan->has_specular ? "--max-bounces 0: direct light only → no caustic map"
                                         : "no specular or refractive material → no caustic map");
    }
}

/*
 * final's photon passes are reused as a prefix: the kept passes of the same
 * inputs serve the first passes of this frame, and only the rest are traced.
 */
static void plan_final_passes(pf_stage_plan *plan, const pf_stage_memory *memory)
{
    pf_stage_decision *trace = &plan->stages[PF_STAGE_PHOTON_TRACE];
    plan->reused_passes = 0;
    if (trace->action == PF_STAGE_SKIP)
        return;
    if (trace->action == PF_STAGE_REUSE)
        plan->reused_passes =
            memory->kept_passes < plan->samples ? memory->kept_passes : plan->samples;
    if (trace->action == PF_STAGE_REUSE && plan->reused_passes < plan->samples) {
        for (int s = PF_STAGE_PHOTON_TRACE; s <= PF_STAGE_CAUSTIC_MAP; s++) {
            if (plan->stages[s].action != PF_STAGE_REUSE)
                continue;
            plan->stages[s].action = PF_STAGE_RUN;
            if (plan->reused_passes == 0)
                snprintf(plan->stages[s].reason, sizeof plan->stages[s].reason,
                         "%s: nothing kept", stage_table[s].verb);
            else
                snprintf(plan->stages[s].reason, sizeof plan->stages[s].reason,
                         "%s: passes %u–%u (1–%u kept from the previous frame)",
                         stage_table[s].verb, plan->reused_passes + 1, plan->samples,
                         plan->reused_passes);
        }
    }
}

/* Hits per photon under --max-bounces B: B (0 = the tracer's default). */
static uint32_t photon_depth_of(const pf_render_settings *settings)
{
    if (!settings->bounce_limit)
        return 0;
    return settings->bounce_limit > 1 ? settings->bounce_limit - 1 : 1;
}

/* Whether the kept tree holds exactly frame's triangles (in its leaf order). */
static int same_triangles(const pf_bih *bih, const pf_scene_frame *frame)
{
    if (bih->triangle_count != frame->triangle_count)
        return 0;
    for (uint32_t p = 0; p < bih->triangle_count; p++) {
        uint32_t t = bih->triangle_index[p];
        for (int c = 0; c < 3; c++)
            if (memcmp(bih->vertices[3 * p + c], frame->vertices[3 * t + c], 3 * sizeof(float)))
                return 0;
    }
    return 1;
}

void pf_bih_plan(const pf_stage_previous *previous, const pf_scene_frame *frame,
                 pf_stage_decision *decision)
{
    decision->action = PF_STAGE_RUN;
    if (!previous->tree)
        snprintf(decision->reason, sizeof decision->reason, "%s",
                 previous->bih_frames == 0   ? "built: first frame"
                 : previous->bih_pilot_replaced ? "built: auto's pilot replaced the previous "
                                                  "frame's tree"
                                                : "built: no tree kept (previous frame failed)");
    else if (previous->tree->triangle_count != frame->triangle_count)
        snprintf(decision->reason, sizeof decision->reason,
                 "built: triangle count changed (%u → %u)", previous->tree->triangle_count,
                 frame->triangle_count);
    else if (same_triangles(previous->tree, frame)) {
        decision->action = PF_STAGE_REUSE;
        snprintf(decision->reason, sizeof decision->reason, "geometry unchanged → BIH reused");
    } else
        snprintf(decision->reason, sizeof decision->reason, "refit: triangles moved");
}

pf_stage_previous pf_stage_previous_of(const pf_renderer *renderer, pf_quality preset)
{
    pf_stage_previous previous = {
        (unsigned)preset < PF_QUALITY_AUTO ? &renderer->stage_memory[preset] : NULL,
        renderer->bih_valid ? &renderer->bih : NULL, renderer->bih_frames,
        renderer->bih_pilot_replaced, pf_vk_info(renderer->ctx)->max_storage_buffer_range};
    previous.trace_site = renderer->trace_site;
    previous.device_is_host = pf_vk_storage_is_host_memory(renderer->ctx);
    previous.host_traversal = pf_bih_wide_available();
    previous.tree_on_host = pf_renderer_bih_site(renderer) == PF_BIH_BUILD_CPU;
    for (uint32_t v = 0; v < PF_SURFACE_VARIANTS; v++)
        if (renderer->pipelines[0][v][PF_PIPELINE_REFERENCE_WAVE_TAIL])
            previous.wave_tail_compiled[v / 64u] |= UINT64_C(1) << (v % 64u);
    previous.wave_tails_before = renderer->wave_tails;
    return previous;
}

pf_status pf_plan_stages(const pf_scene_frame *frame, const pf_render_settings *settings,
                         const pf_stage_previous *previous, pf_stage_plan *plan, pf_error *err)
{
    memset(plan, 0, sizeof *plan);
    plan->preset = settings->quality;
    /* Every preset's plan has the scene's fingerprints (the temporal denoiser compares
     * them with its history's: pf_renderer.frame_inputs). */
    fingerprint_scene(frame, plan->inputs);
    pf_bih_plan(previous, frame, &plan->stages[PF_STAGE_BIH_BUILD]);
    plan->stages[PF_STAGE_SHADE].action = PF_STAGE_RUN;
    switch (settings->quality) {
    case PF_QUALITY_PREVIEW:
        plan->samples = samples_of(settings, PREVIEW_DEFAULT_SAMPLES, plan, "camera samples");
        return PF_OK;
    case PF_QUALITY_REFERENCE:
        plan->samples = samples_of(settings, REFERENCE_DEFAULT_SAMPLES, plan, "path samples");
        say_trace_site(plan, PF_STAGE_SHADE, previous, plan_trace_site(previous, plan),
                       "wavefront, rays", "rays");
        /* Forced onto the host, the host traces every ray. */
        if (plan->host_traces && previous->trace_site != PF_TRACE_HOST &&
            worth_a_tail(frame, settings, previous, plan)) {
            plan->wave_tail_paths = PF_REFERENCE_WAVE_TAIL_PATHS;
            char *reason = plan->stages[PF_STAGE_SHADE].reason;
            size_t used = strlen(reason);
            snprintf(reason + used, PF_STAGE_REASON_MAX - used,
                     "; a slice's last ≤ %u paths traced on the device",
                     plan->wave_tail_paths);
        }
        return PF_OK;
    case PF_QUALITY_FAST:
    case PF_QUALITY_FINAL:
        break;
    default:
        return pf_error_set(err, PF_ERR_UNSUPPORTED, "no stage plan for quality '%s'",
                            pf_quality_name(settings->quality));
    }
    const pf_stage_memory *memory = previous->memory;
    /* What photon emission picks from (lights and emissive triangles of positive power),
     * built once: the integrator traces from the plan's table. */
    pf_status status = pf_photon_emitters_build(frame, &plan->emitters, err);
    if (status != PF_OK)
        return status;
    plan->has_specular = pf_scene_frame_has_specular(frame);
    if (settings->quality == PF_QUALITY_FINAL) {
        plan->samples = samples_of(settings, FINAL_DEFAULT_PASSES, plan, "passes");
        plan->photons = settings->photons_per_pass ? settings->photons_per_pass
                                                   : FINAL_DEFAULT_PHOTONS_PER_PASS;
        plan->photon_depth = photon_depth_of(settings);
        plan->caustic_map = plan->has_specular && settings->bounce_limit != 1;
        plan->inputs[PF_INPUT_PHOTONS] =
            hash_u64(hash_u64(hash_u64(PF_HASH_START, settings->seed), plan->photons),
                     plan->photon_depth);
        plan_photons(plan, memory, 1);
        plan_final_passes(plan, memory);
        const char *why_not = plan_trace_site(previous, plan);
        say_trace_site(plan, PF_STAGE_SHADE, previous, why_not, "camera and gather rays",
                       "camera and gather rays");
        say_trace_site(plan, PF_STAGE_PHOTON_TRACE, previous, why_not, "photons", "photons");
        return PF_OK;
    }
    pf_lpv_setting which;
    status = pf_lpv_settings_check(
        &settings->lpv, previous->max_buffer_range, &which, err);
    if (status != PF_OK) {
        pf_stage_plan_release(plan);
        return status;
    }
    plan->samples = samples_of(settings, FAST_DEFAULT_SAMPLES, plan, "camera samples");
    plan->photons = settings->photons_per_pass ? settings->photons_per_pass : FAST_DEFAULT_PHOTONS;
    plan->caustic_map = plan->has_specular;
    plan->inputs[PF_INPUT_PHOTONS] =
        hash_u64(hash_u64(PF_HASH_START, settings->seed), plan->photons);
    float focus[3];
    pf_lpv_focus(frame, focus);
    pf_lpv_layout_make(&settings->lpv, focus, settings->lpv.cell_size, frame, &plan->layout);
    fingerprint_cascades(&plan->layout, plan->inputs);
    plan_photons(plan, memory, 0);
    pf_stage_decide(plan, PF_STAGE_LPV_GEOMETRY, memory);
    pf_stage_decide(plan, PF_STAGE_LPV_INJECT, memory);
    pf_stage_decide(plan, PF_STAGE_LPV_PROPAGATE, memory);
    say_trace_site(plan, PF_STAGE_PHOTON_TRACE, previous, plan_trace_site(previous, plan),
                   "photons", "photons");
    return PF_OK;
}
