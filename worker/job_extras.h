/*
 * What a job's stored parameters carry besides its render settings: the
 * farm's own keys, beside the settings codec's (pf_settings_format) in one
 * JSON object (jobs.parameters).
 */
#ifndef PF_JOB_EXTRAS_H
#define PF_JOB_EXTRAS_H

#include "pf_render.h"

#include <stddef.h>

typedef struct pf_job_extras {
    const char *name;            /* "name": a label for status (NULL: none) */
    int allow_outside_scene_dir; /* "allow_outside_scene_dir": true (pf_scene_load_options) */
    const char *animation;       /* "animation": the one that plays (NULL: every one) */
    const char *material_variant; /* "material_variant": the one worn (NULL: none) */
} pf_job_extras;

/* The job's parameters: extras (when not NULL) and settings as one JSON object into out
 * (0 if it does not fit). */
int pf_job_parameters_format(const pf_render_settings *settings, const pf_job_extras *extras,
                             char *out, size_t size);

/* Copies the job's "name" (or "" when none) into out. */
void pf_job_name(const char *json, char *out, size_t size);
/* The job's "allow_outside_scene_dir" (0 when absent or not true). */
int pf_job_allow_outside(const char *json);
/* Copies the job's "animation" into out; returns 0 (out "") when it has none. */
int pf_job_animation(const char *json, char *out, size_t size);
/* Copies the job's "material_variant" into out; returns 0 (out "") when it has none. */
int pf_job_material_variant(const char *json, char *out, size_t size);

#endif
