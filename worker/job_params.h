/*
 * The one codec of pf_render_settings: JSON such as
 * {"width":640,"height":480,"quality":"auto","spp":0,"seed":0} plus every
 * field that differs from pf_render_settings_default() ("time_budget_ms",
 * "photons", "aovs", "float", "filter", "max_bounces", "budget_ms",
 * "target_relmse", "lpv"). `enqueue` stores it in the queue (jobs.parameters),
 * the worker reads it back for every task, and every EXR carries it as
 * photonfarm/settings. The bounds below are the command line's too
 * (cli_settings.c), so whatever one accepts the other does.
 */
#ifndef PF_JOB_PARAMS_H
#define PF_JOB_PARAMS_H

#include "pf_common.h"
#include "pf_render.h"

#include <stddef.h>

#define PF_SETTINGS_MAX_SPP 65536
/* 2^53: the largest integer a JSON number carries exactly. */
#define PF_SETTINGS_MAX_SEED 9007199254740992ll
#define PF_SETTINGS_MAX_PHOTONS 100000000ll
/* --time-budget (a progressive preset's stop): a week. */
#define PF_SETTINGS_MAX_TIME_BUDGET_MS 604800000.0
/* --budget-ms (auto's aim per frame): a day. */
#define PF_SETTINGS_MAX_BUDGET_MS 86400000.0
#define PF_SETTINGS_MAX_TARGET_RELMSE 100.0

/* What a job's JSON carries besides its render settings. */
typedef struct pf_job_extras {
    const char *name;            /* "name": a label for status (NULL: none) */
    int allow_outside_scene_dir; /* "allow_outside_scene_dir": true (pf_scene_load_options) */
} pf_job_extras;

/* Formats settings (and extras, when not NULL) as the JSON object above into
 * out (0 if it does not fit). */
int pf_job_params_format(const pf_render_settings *settings, const pf_job_extras *extras,
                         char *out, size_t size);

/* Copies the job's "name" (or "" when none) into out. */
void pf_job_params_name(const char *json, char *out, size_t size);
/* The job's "allow_outside_scene_dir" (0 when absent or not true). */
int pf_job_params_allow_outside(const char *json);

/*
 * Parses a job's parameters into *settings (absent keys keep their defaults:
 * size 0x0 = the default size, auto quality, the preset's spp, seed 0, AOVs on).
 * Text that is not a JSON object, an unknown quality or an out-of-range number
 * → PF_ERR_FORMAT naming the key.
 */
pf_status pf_job_params_parse(const char *json, pf_render_settings *settings, pf_error *err);

#endif
