/*
 * The render parameters a job stores as JSON in the queue (jobs.parameters):
 * {"width":640,"height":480,"quality":"auto","spp":0,"seed":0} (and
 * "time_budget_ms" when the reference preset has one). `enqueue`
 * writes them, the worker reads them back for every task of the job.
 */
#ifndef PF_JOB_PARAMS_H
#define PF_JOB_PARAMS_H

#include "pf_common.h"
#include "pf_render.h"

#include <stddef.h>

/* Formats settings (and name, when not NULL, as "name") as the JSON object
 * above into out (0 if it does not fit). */
int pf_job_params_format(const pf_render_settings *settings, const char *name, char *out,
                         size_t size);

/* Copies the job's "name" (or "" when none) into out. */
void pf_job_params_name(const char *json, char *out, size_t size);

/*
 * Parses a job's parameters into *settings (absent keys keep their defaults:
 * size 0x0 = the default size, auto quality, the preset's spp, seed 0, AOVs on).
 * Text that is not a JSON object, an unknown quality or an out-of-range number
 * → PF_ERR_FORMAT naming the key.
 */
pf_status pf_job_params_parse(const char *json, pf_render_settings *settings, pf_error *err);

#endif
