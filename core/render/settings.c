/* The one codec of pf_render_settings: job JSON and EXR metadata (pf_render.h). */
#include "pf_render.h"

#include <cjson/cJSON.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <string.h>


/* Reads an optional integer key in [0, max] into *value. */
static pf_status read_number(const cJSON *root, const char *key, double max, double *value,
                             pf_error *err)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(root, key);
    if (!item)
        return PF_OK;
    if (!cJSON_IsNumber(item) || item->valuedouble < 0 || item->valuedouble > max ||
        item->valuedouble != (double)(int64_t)item->valuedouble)
        return pf_error_set(err, PF_ERR_FORMAT,
                            "job parameters: \"%s\" must be an integer 0..%.0f", key, max);
    *value = item->valuedouble;
    return PF_OK;
}

/* An optional number key: more than 0 (0 too with zero_allowed) and at most max; absent: untouched. */
static pf_status read_real(const cJSON *root, const char *key, int zero_allowed, double max,
                           double *value, pf_error *err)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(root, key);
    if (!item)
        return PF_OK;
    double number = cJSON_IsNumber(item) ? item->valuedouble : NAN;
    if (!(zero_allowed ? number >= 0.0 : number > 0.0) || !(number <= max))
        return pf_error_set(err, PF_ERR_FORMAT, "job parameters: \"%s\" must be a number %s %.0f",
                            key, zero_allowed ? "0.." : "more than 0 and at most", max);
    *value = number;
    return PF_OK;
}

/* An optional true/false key; absent: untouched. */
static pf_status read_bool(const cJSON *root, const char *key, int *value, pf_error *err)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(root, key);
    if (!item)
        return PF_OK;
    if (!cJSON_IsBool(item))
        return pf_error_set(err, PF_ERR_FORMAT, "job parameters: \"%s\" must be true or false",
                            key);
    *value = cJSON_IsTrue(item);
    return PF_OK;
}

/* An optional key naming one of an enum's values (parse: its name → value, -1 unknown);
 * absent: untouched; anything else: PF_ERR_FORMAT with message. */
static pf_status read_name(const cJSON *root, const char *key, int (*parse)(const char *),
                           const char *message, int *value, pf_error *err)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(root, key);
    if (!item)
        return PF_OK;
    int parsed = cJSON_IsString(item) ? parse(item->valuestring) : -1;
    if (parsed < 0)
        return pf_error_set(err, PF_ERR_FORMAT, "%s", message);
    *value = parsed;
    return PF_OK;
}

/* "lpv": {"cascades", "size", "iterations": [...], "cell"} with the non-default fields only. */
static void add_lpv(cJSON *root, const pf_lpv_settings *lpv)
{
    uint32_t iteration_count = 0;
    for (uint32_t k = 0; k < PF_LPV_MAX_CASCADES; k++) {
        if (lpv->iterations[k])
            iteration_count = k + 1;
    }
    if (!lpv->cascades && !lpv->size && !iteration_count && !(lpv->cell_size > 0.0f) &&
        !(lpv->offset_cells > 0.0f) && !lpv->undamped && !lpv->unscaled)
        return;
    cJSON *object = cJSON_AddObjectToObject(root, "lpv");
    if (!object)
        return;
    if (lpv->cascades)
        cJSON_AddNumberToObject(object, "cascades", lpv->cascades);
    if (lpv->size)
        cJSON_AddNumberToObject(object, "size", lpv->size);
    if (iteration_count) {
        cJSON *list = cJSON_AddArrayToObject(object, "iterations");
        for (uint32_t k = 0; list && k < iteration_count; k++)
            cJSON_AddItemToArray(list, cJSON_CreateNumber(lpv->iterations[k]));
    }
    if (lpv->cell_size > 0.0f)
        cJSON_AddNumberToObject(object, "cell", lpv->cell_size);
    /* Measurement settings (bench/lpv), no command-line option: kept so a file says all. */
    if (lpv->offset_cells > 0.0f)
        cJSON_AddNumberToObject(object, "offset_cells", lpv->offset_cells);
    if (lpv->undamped)
        cJSON_AddBoolToObject(object, "undamped", 1);
    if (lpv->unscaled)
        cJSON_AddBoolToObject(object, "unscaled", 1);
}

/* Reads "lpv" (absent: defaults); PF_ERR_FORMAT naming the key when a value is out of range. */
static pf_status read_lpv(const cJSON *root, pf_lpv_settings *lpv, pf_error *err)
{
    const cJSON *object = cJSON_GetObjectItemCaseSensitive(root, "lpv");
    memset(lpv, 0, sizeof *lpv);
    if (!object)
        return PF_OK;
    if (!cJSON_IsObject(object))
        return pf_error_set(err, PF_ERR_FORMAT, "job parameters: \"lpv\" must be an object");
    double cascades = 0, size = 0;
    pf_status status = read_number(object, "cascades", PF_LPV_MAX_CASCADES, &cascades, err);
    if (status == PF_OK)
        status = read_number(object, "size", PF_LPV_MAX_SIZE, &size, err);
    if (status != PF_OK)
        return pf_error_prefix(err, "\"lpv\""), status;
    lpv->cascades = (uint32_t)cascades;
    lpv->size = (uint32_t)size;
    const cJSON *iterations = cJSON_GetObjectItemCaseSensitive(object, "iterations");
    if (iterations) {
        int count = cJSON_IsArray(iterations) ? cJSON_GetArraySize(iterations) : -1;
        if (count < 1 || count > (int)PF_LPV_MAX_CASCADES)
            return pf_error_set(err, PF_ERR_FORMAT,
                                "job parameters: \"lpv\".\"iterations\" must be an array of "
                                "1..%u integers",
                                PF_LPV_MAX_CASCADES);
        for (int k = 0; k < count; k++) {
            const cJSON *item = cJSON_GetArrayItem(iterations, k);
            if (!cJSON_IsNumber(item) || item->valuedouble < 1 ||
                item->valuedouble > PF_LPV_MAX_ITERATIONS ||
                item->valuedouble != (double)(int64_t)item->valuedouble)
                return pf_error_set(err, PF_ERR_FORMAT,
                                    "job parameters: \"lpv\".\"iterations\"[%d] must be an "
                                    "integer 1..%u",
                                    k, PF_LPV_MAX_ITERATIONS);
            lpv->iterations[k] = (uint32_t)item->valuedouble;
        }
    }
    const cJSON *cell = cJSON_GetObjectItemCaseSensitive(object, "cell");
    if (cell) {
        if (!cJSON_IsNumber(cell) || !(cell->valuedouble > 0.0) || cell->valuedouble > 1e6)
            return pf_error_set(err, PF_ERR_FORMAT,
                                "job parameters: \"lpv\".\"cell\" must be a size in meters, "
                                "more than 0 and at most 1e6");
        lpv->cell_size = (float)cell->valuedouble;
    }
    const cJSON *offset = cJSON_GetObjectItemCaseSensitive(object, "offset_cells");
    if (offset) {
        if (!cJSON_IsNumber(offset) || !(offset->valuedouble > 0.0))
            return pf_error_set(err, PF_ERR_FORMAT,
                                "job parameters: \"lpv\".\"offset_cells\" must be a number more "
                                "than 0");
        lpv->offset_cells = (float)offset->valuedouble;
    }
    pf_status undamped = read_bool(object, "undamped", &lpv->undamped, err);
    if (undamped != PF_OK)
        return pf_error_prefix(err, "\"lpv\""), undamped;
    pf_status unscaled = read_bool(object, "unscaled", &lpv->unscaled, err);
    if (unscaled != PF_OK)
        return pf_error_prefix(err, "\"lpv\""), unscaled;
    pf_lpv_setting which;
    if (pf_lpv_settings_check(lpv, 0, &which, err) != PF_OK)
        return pf_error_prefix(err, "job parameters: \"lpv\""), PF_ERR_FORMAT;
    return PF_OK;
}

int pf_settings_format(const pf_render_settings *settings, char *out, size_t size)
{
    cJSON *root = cJSON_CreateObject();
    if (!root)
        return 0;
    cJSON_AddNumberToObject(root, "width", settings->width);
    cJSON_AddNumberToObject(root, "height", settings->height);
    cJSON_AddStringToObject(root, "quality", pf_quality_name(settings->quality));
    cJSON_AddNumberToObject(root, "spp", settings->samples_per_pixel);
    /* Digits of our own: cJSON prints 15 significant digits, and a seed has up to 16. */
    char seed[24];
    snprintf(seed, sizeof seed, "%" PRIu64, settings->seed);
    cJSON_AddRawToObject(root, "seed", seed);
    if (settings->time_budget_ms > 0.0)
        cJSON_AddNumberToObject(root, "time_budget_ms", settings->time_budget_ms);
    if (settings->photons_per_pass > 0)
        cJSON_AddNumberToObject(root, "photons", settings->photons_per_pass);
    if (!settings->aovs)
        cJSON_AddBoolToObject(root, "aovs", 0);
    if (settings->float_pixels)
        cJSON_AddBoolToObject(root, "float", 1);
    if (settings->pixel_filter != PF_FILTER_GAUSSIAN)
        cJSON_AddStringToObject(root, "filter", pf_pixel_filter_name(settings->pixel_filter));
    if (settings->bounce_limit)
        cJSON_AddNumberToObject(root, "max_bounces", settings->bounce_limit - 1);
    if (settings->budget_ms > 0.0)
        cJSON_AddNumberToObject(root, "budget_ms", settings->budget_ms);
    if (settings->target_relmse > 0.0)
        cJSON_AddNumberToObject(root, "target_relmse", settings->target_relmse);
    if (settings->denoise != PF_DENOISE_AUTO)
        cJSON_AddStringToObject(root, "denoise", pf_denoise_name(settings->denoise));
    add_lpv(root, &settings->lpv);
    char *text = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    int fits = text && strlen(text) < size;
    if (fits)
        memcpy(out, text, strlen(text) + 1);
    cJSON_free(text);
    return fits;
}

pf_status pf_settings_parse(const char *json, pf_render_settings *settings, pf_error *err)
{
    pf_render_settings parsed = pf_render_settings_default();
    cJSON *root = cJSON_Parse(json ? json : "{}");
    if (!cJSON_IsObject(root)) {
        cJSON_Delete(root);
        return pf_error_set(err, PF_ERR_FORMAT, "job parameters are not a JSON object: %.80s",
                            json ? json : "");
    }
    double width = 0, height = 0, spp = 0, seed = 0, photons = 0, bounces = -1;
    pf_status status = read_number(root, "width", PF_FRAME_MAX_EDGE, &width, err);
    if (status == PF_OK)
        status = read_number(root, "height", PF_FRAME_MAX_EDGE, &height, err);
    if (status == PF_OK)
        status = read_number(root, "spp", PF_SETTINGS_MAX_SPP, &spp, err);
    if (status == PF_OK)
        status = read_number(root, "seed", (double)PF_SETTINGS_MAX_SEED, &seed, err);
    if (status == PF_OK)
        status = read_number(root, "photons", (double)PF_SETTINGS_MAX_PHOTONS, &photons, err);
    if (status == PF_OK && cJSON_GetObjectItemCaseSensitive(root, "max_bounces"))
        status = read_number(root, "max_bounces", PF_MAX_BOUNCES_LIMIT, &bounces, err);
    if (status == PF_OK)
        status = read_lpv(root, &parsed.lpv, err);
    int filter = (int)parsed.pixel_filter, denoise = (int)parsed.denoise;
    int quality = (int)parsed.quality;
    if (status == PF_OK)
        status = read_name(root, "filter", pf_pixel_filter_parse,
                           "job parameters: \"filter\" must be \"gaussian\", \"box\" or "
                           "\"blackman-harris\"",
                           &filter, err);
    if (status == PF_OK)
        status = read_name(root, "denoise", pf_denoise_parse,
                           "job parameters: \"denoise\" must be \"auto\", \"on\", "
                           "\"spatial\" or \"off\"",
                           &denoise, err);
    if (status == PF_OK)
        status = read_bool(root, "aovs", &parsed.aovs, err);
    if (status == PF_OK)
        status = read_bool(root, "float", &parsed.float_pixels, err);
    if (status == PF_OK)
        status = read_real(root, "budget_ms", 0, PF_SETTINGS_MAX_BUDGET_MS, &parsed.budget_ms,
                           err);
    if (status == PF_OK)
        status = read_real(root, "target_relmse", 0, PF_SETTINGS_MAX_TARGET_RELMSE,
                           &parsed.target_relmse, err);
    if (status == PF_OK)
        status = read_real(root, "time_budget_ms", 1, PF_SETTINGS_MAX_TIME_BUDGET_MS,
                           &parsed.time_budget_ms, err);
    if (status == PF_OK)
        status = read_name(root, "quality", pf_quality_parse,
                           "job parameters: unknown \"quality\"", &quality, err);
    cJSON_Delete(root);
    if (status != PF_OK)
        return status;
    parsed.pixel_filter = (pf_pixel_filter)filter;
    parsed.denoise = (pf_denoise_mode)denoise;
    parsed.quality = (pf_quality)quality;
    parsed.width = (uint32_t)width;
    parsed.height = (uint32_t)height;
    parsed.samples_per_pixel = (uint32_t)spp;
    parsed.seed = (uint64_t)seed;
    parsed.photons_per_pass = (uint32_t)photons;
    parsed.bounce_limit = bounces >= 0 ? pf_bounce_limit((uint32_t)bounces) : 0u;
    *settings = parsed;
    return PF_OK;
}

