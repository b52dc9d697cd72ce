/*
 * The render-settings options, one parser for `render` and `enqueue` so that
 * both accept the same options with the same ranges and messages (cli_queue.h).
 * What they fill is pf_render_settings, whose one codec (core/render/settings.c) carries
 * it into the queue and into every EXR's photonfarm/settings.
 */
#include "cli_queue.h"
#include "pf_render.h"
#include "pf_cli.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A finite number in (0, max], the whole string. */
static int parse_positive(const char *value, double max, double *out)
{
    char *end = NULL;
    double number = value ? strtod(value, &end) : 0.0;
    if (!value || end == value || *end || !(number > 0.0) || !(number <= max))
        return 0;
    *out = number;
    return 1;
}

/* --time-budget: seconds, more than 0 and at most a week, into milliseconds. */
static int parse_time_budget(const char *text, double *milliseconds)
{
    if (!text || !*text || text[0] == '-')
        return 0;
    errno = 0;
    char *end = NULL;
    double seconds = strtod(text, &end);
    if (errno || *end || !(seconds > 0.0) || seconds * 1000.0 > PF_SETTINGS_MAX_TIME_BUDGET_MS)
        return 0;
    *milliseconds = seconds * 1000.0;
    return 1;
}

/* "WxH", each side parsed whole and range-checked (sscanf's %u wraps 4294967297 to 1). */
static int parse_size(const char *value, int64_t *width, int64_t *height)
{
    char side[32];
    const char *x = strchr(value, 'x');
    if (!x || (size_t)(x - value) >= sizeof side)
        return 0;
    memcpy(side, value, (size_t)(x - value));
    side[x - value] = '\0';
    return pf_cli_parse_int(side, 1, PF_FRAME_MAX_EDGE, width) &&
           pf_cli_parse_int(x + 1, 1, PF_FRAME_MAX_EDGE, height);
}

/* The options that take no value. */
static int flag_option(const char *arg, pf_render_settings *settings)
{
    if (!strcmp(arg, "--float"))
        settings->float_pixels = 1;
    else if (!strcmp(arg, "--no-aovs"))
        settings->aovs = 0;
    else
        return 0;
    return 1;
}

/* --size, --quality, --spp, --seed, --photons, --time-budget: -1 none of them. */
static int frame_option(const char *command, const char *arg, const char *value,
                        pf_render_settings *settings)
{
    int64_t number;
    if (!strcmp(arg, "--size")) {
        int64_t width, height;
        if (!parse_size(value, &width, &height))
            return pf_cli_fail(command, 2, "--size '%s': expected WxH, each 1..%u", value,
                               PF_FRAME_MAX_EDGE);
        settings->width = (uint32_t)width;
        settings->height = (uint32_t)height;
    } else if (!strcmp(arg, "--quality")) {
        int quality = pf_quality_parse(value);
        if (quality < 0)
            return pf_cli_fail(command, 2,
                               "--quality '%s': expected preview, fast, final, reference or auto",
                               value);
        settings->quality = (pf_quality)quality;
    } else if (!strcmp(arg, "--spp")) {
        if (!pf_cli_parse_int(value, 1, PF_SETTINGS_MAX_SPP, &number))
            return pf_cli_fail(command, 2, "--spp '%s': expected 1..%d", value, PF_SETTINGS_MAX_SPP);
        settings->samples_per_pixel = (uint32_t)number;
    } else if (!strcmp(arg, "--seed")) {
        if (!pf_cli_parse_int(value, 0, PF_SETTINGS_MAX_SEED, &number))
            return pf_cli_fail(command, 2, "--seed '%s': expected an integer 0..%lld", value,
                               (long long)PF_SETTINGS_MAX_SEED);
        settings->seed = (uint64_t)number;
    } else if (!strcmp(arg, "--photons")) {
        if (!pf_cli_parse_int(value, 1, PF_SETTINGS_MAX_PHOTONS, &number))
            return pf_cli_fail(command, 2, "--photons '%s': expected 1..%llu", value,
                               (unsigned long long)PF_SETTINGS_MAX_PHOTONS);
        settings->photons_per_pass = (uint32_t)number;
    } else if (!strcmp(arg, "--time-budget")) {
        if (!parse_time_budget(value, &settings->time_budget_ms))
            return pf_cli_fail(command, 2,
                               "--time-budget '%s': expected seconds, more than 0 and at most %.0f",
                               value, PF_SETTINGS_MAX_TIME_BUDGET_MS / 1000.0);
    } else {
        return -1;
    }
    return 0;
}

/* --denoise, --filter, --max-bounces, --budget-ms, --target-relmse: -1 none of them. */
static int sampling_option(const char *command, const char *arg, const char *value,
                           pf_render_settings *settings)
{
    if (!strcmp(arg, "--denoise")) {
        int mode = pf_denoise_parse(value);
        if (mode < 0)
            return pf_cli_fail(command, 2, "--denoise '%s': expected auto, on, spatial or off",
                               value);
        settings->denoise = (pf_denoise_mode)mode;
    } else if (!strcmp(arg, "--filter")) {
        int filter = pf_pixel_filter_parse(value);
        if (filter < 0)
            return pf_cli_fail(command, 2,
                               "--filter '%s': expected gaussian, box or blackman-harris", value);
        settings->pixel_filter = (pf_pixel_filter)filter;
    } else if (!strcmp(arg, "--max-bounces")) {
        int64_t bounces;
        if (!pf_cli_parse_int(value, 0, PF_MAX_BOUNCES_LIMIT, &bounces))
            return pf_cli_fail(command, 2, "--max-bounces '%s': expected an integer 0..%u", value,
                               PF_MAX_BOUNCES_LIMIT);
        settings->bounce_limit = pf_bounce_limit((uint32_t)bounces);
    } else if (!strcmp(arg, "--budget-ms")) {
        if (!parse_positive(value, PF_SETTINGS_MAX_BUDGET_MS, &settings->budget_ms))
            return pf_cli_fail(command, 2,
                               "--budget-ms '%s': expected milliseconds per frame, more than 0 "
                               "and at most %.0f",
                               value, PF_SETTINGS_MAX_BUDGET_MS);
    } else if (!strcmp(arg, "--target-relmse")) {
        if (!parse_positive(value, PF_SETTINGS_MAX_TARGET_RELMSE, &settings->target_relmse))
            return pf_cli_fail(command, 2,
                               "--target-relmse '%s': expected a relMSE more than 0 and at most "
                               "%.0f",
                               value, PF_SETTINGS_MAX_TARGET_RELMSE);
    } else {
        return -1;
    }
    return 0;
}

/* The settings options that take a value (the --lpv-* ones are cli_lpv.c's). */
static const char *const valued_options[] = {
    "--size",      "--quality",       "--spp",       "--seed",           "--photons",
    "--time-budget", "--filter",      "--max-bounces", "--budget-ms",    "--target-relmse",
    "--lpv-cascades", "--lpv-size",   "--lpv-iterations", "--lpv-cell", "--denoise",
};

int pf_cli_settings_option(const char *command, const char *arg, const char *value,
                           pf_render_settings *settings, int *used_value)
{
    *used_value = 0;
    if (flag_option(arg, settings))
        return 0;
    int known = 0;
    for (size_t i = 0; i < sizeof valued_options / sizeof valued_options[0] && !known; i++)
        known = !strcmp(arg, valued_options[i]);
    if (!known)
        return -1;
    if (!value)
        return pf_cli_fail(command, 2, "%s needs a value (see --help)", arg);
    *used_value = 1;
    int code = frame_option(command, arg, value, settings);
    if (code < 0)
        code = sampling_option(command, arg, value, settings);
    if (code < 0)
        code = pf_cli_lpv_option(command, arg, value, &settings->lpv);
    return code;
}

/* pf_cli_store for the settings rows: the option's own parser above. */
static int store_setting(const char *command, const pf_cli_option *option, const char *value)
{
    int used_value = 0;
    int code = pf_cli_settings_option(command, option->name, value, option->target, &used_value);
    return code < 0 ? pf_cli_fail(command, 2, "%s: not a settings option", option->name) : code;
}

/* pf_cli_store for --allow-outside-scene-dir (target: the pf_cli_scene). */
static int store_outside(const char *command, const pf_cli_option *option, const char *value)
{
    (void)command;
    (void)value;
    ((pf_cli_scene *)option->target)->load.allow_outside_scene_dir = 1;
    return 0;
}

/* pf_cli_store for --animation NAME|INDEX (target: the pf_cli_scene). */
static int store_animation(const char *command, const pf_cli_option *option, const char *value)
{
    if (!*value)
        return pf_cli_fail(command, 2, "--animation needs a name or an index");
    ((pf_cli_scene *)option->target)->load.animation = value;
    return 0;
}

/* pf_cli_store for --variant NAME|INDEX (target: the pf_cli_scene). */
static int store_variant(const char *command, const pf_cli_option *option, const char *value)
{
    if (!*value)
        return pf_cli_fail(command, 2, "--variant needs a name or an index");
    ((pf_cli_scene *)option->target)->load.material_variant = value;
    return 0;
}

size_t pf_cli_settings_table(pf_render_settings *settings, pf_cli_scene *scene,
                             pf_cli_option rows[PF_CLI_SETTINGS_OPTIONS])
{
    const pf_cli_option table[PF_CLI_SETTINGS_OPTIONS] = {
        {"--size", NULL, "WxH", "image size, each side 1..16384",
         "640 wide, height by the camera's aspect", NULL, NULL, 0, 0, NULL},
        {"--quality", NULL, "Q",
         "preview (direct light) | fast (direct light + LPV\n"
         "indirect + caustic map) | final (photon maps + final\n"
         "gather) | reference (unbiased path tracer) | auto (the\n"
         "planner picks fast or final)",
         "auto", NULL, NULL, 0, 0, NULL},
        {"--spp", NULL, "N",
         "samples per pixel; for final, photon passes (preview 1,\nfast 2, final 4, reference 64)",
         "the preset's", NULL, NULL, 0, 0, NULL},
        {"--seed", NULL, "S", "random seed; same seed, same pixels", "0", NULL, NULL, 0, 0, NULL},
        {"--photons", NULL, "N", "fast: photons per frame; final: photons per pass",
         "32768 for fast, 100000 for final", NULL, NULL, 0, 0, NULL},
        {"--time-budget", NULL, "SEC",
         "final, reference: stop adding passes/samples after SEC\nseconds per frame (at least one)",
         "no limit", NULL, NULL, 0, 0, NULL},
        {"--float", NULL, NULL, "32-bit float pixels", "half", NULL, NULL, 0, 0, NULL},
        {"--no-aovs", NULL, NULL,
         "beauty RGBA only, without the direct/indirect/caustic\nsplit and the albedo, normal and "
         "depth layers",
         "all layers", NULL, NULL, 0, 0, NULL},
        {"--denoise", NULL, "MODE",
         "fast, final, reference: filter the indirect light, guided\nby the albedo, normal and "
         "depth layers, blending the\nprevious frame's where this worker rendered it (on),\n"
         "each frame alone (spatial), or not (off); the raw\nbeauty is kept as noisy.R/G/B",
         "auto: " PF_DENOISE_AUTO_TEXT, NULL, NULL, 0, 0, NULL},
        {"--filter", NULL, "F",
         "pixel filter: gaussian (sigma 0.5 px, radius 1.5 px),\nbox (1 px), blackman-harris "
         "(1.5 px either side, Cycles')",
         "gaussian", NULL, NULL, 0, 0, NULL},
        {"--max-bounces", NULL, "N",
         "reference, final: light of at most N bounces after the\nfirst surface (0: direct light "
         "only)",
         "no limit", NULL, NULL, 0, 0, NULL},
        {"--budget-ms", NULL, "MS",
         "auto: aim at MS milliseconds per frame (final with the\npasses that fit, else fast; a "
         "pilot render calibrates)",
         "none: fast", NULL, NULL, 0, 0, NULL},
        {"--target-relmse", NULL, "X",
         "auto: aim at relMSE X (fast when it reaches it, else\nfinal with the passes it needs)",
         "none: fast", NULL, NULL, 0, 0, NULL},
        {"--lpv-cascades", NULL, "N", "fast: LPV cascades, 1..8", "4", NULL, NULL, 0, 0, NULL},
        {"--lpv-size", NULL, "N", "fast: cells per axis of a cascade, a multiple of 4 in\n4..256",
         "32", NULL, NULL, 0, 0, NULL},
        {"--lpv-iterations", NULL, "N[,N...]",
         "fast: propagation iterations, one value or one per\ncascade, 1..1024", "8", NULL, NULL,
         0, 0, NULL},
        {"--lpv-cell", NULL, "M", "fast: the finest cascade's cell in meters",
         "a power of two: the coarsest cascade spans the scene", NULL, NULL, 0, 0, NULL},
        {"--allow-outside-scene-dir", NULL, NULL,
         "let the scene's buffers and material libraries lie\noutside its directory (a job "
         "carries it to its workers)",
         "refused", store_outside, NULL, 0, 0, NULL},
        {"--animation", NULL, "NAME|INDEX",
         "play only this glTF animation (its name, or its index\nin the file); the frame range "
         "is then its own",
         "every animation plays, as in the authoring tool", store_animation, NULL, 0, 0, NULL},
        {"--variant", NULL, "NAME|INDEX",
         "dress the scene in this glTF material variant\n(KHR_materials_variants: its name, "
         "or its index in the\nfile)",
         "each primitive's own material", store_variant, NULL, 0, 0, NULL},
    };
    for (size_t i = 0; i < PF_CLI_SETTINGS_OPTIONS; i++) {
        rows[i] = table[i];
        int scene_row = i >= PF_CLI_SETTINGS_OPTIONS - PF_CLI_SCENE_OPTIONS;
        rows[i].store = scene_row ? table[i].store : store_setting;
        rows[i].target = scene_row ? (void *)scene : (void *)settings;
    }
    return PF_CLI_SETTINGS_OPTIONS;
}

int pf_cli_parse_job(const char *name, const char *synopsis, const char *description,
                     const pf_cli_option *own, size_t own_count, pf_render_settings *settings,
                     pf_cli_scene *scene, int argc, char **argv, int *help)
{
    pf_cli_option settings_rows[PF_CLI_SETTINGS_OPTIONS];
    pf_cli_settings_table(settings, scene, settings_rows);
    pf_cli_command command = {
        .name = name,
        .synopsis = synopsis,
        .description = description,
        .options = own,
        .option_count = own_count,
        .more_options = settings_rows,
        .more_option_count = PF_CLI_SETTINGS_OPTIONS,
        .positional = &scene->path,
        .positional_max = 1,
    };
    int code = pf_cli_parse(&command, argc, argv, help);
    if (!code && !*help && !scene->path)
        code = pf_cli_fail(name, 2, "no scene given (see --help)");
    return code;
}
