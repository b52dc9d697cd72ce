/* The farm's keys in a job's parameters (job_extras.h). */
#include "job_extras.h"

#include <cjson/cJSON.h>
#include <stdio.h>
#include <string.h>

/* The settings codec's largest output, with room for the extras. */
#define PARAMETERS_MAX 8192

int pf_job_parameters_format(const pf_render_settings *settings, const pf_job_extras *extras,
                             char *out, size_t size)
{
    char fields[PARAMETERS_MAX];
    if (!pf_settings_format(settings, fields, sizeof fields) || fields[0] != '{')
        return 0;
    cJSON *root = cJSON_CreateObject();
    if (!root)
        return 0;
    if (extras && extras->name)
        cJSON_AddStringToObject(root, "name", extras->name);
    if (extras && extras->allow_outside_scene_dir)
        cJSON_AddBoolToObject(root, "allow_outside_scene_dir", 1);
    if (extras && extras->animation)
        cJSON_AddStringToObject(root, "animation", extras->animation);
    if (extras && extras->material_variant)
        cJSON_AddStringToObject(root, "material_variant", extras->material_variant);
    char *keys = root->child ? cJSON_PrintUnformatted(root) : NULL;
    cJSON_Delete(root);
    /* The extras' members, then the settings' as the codec wrote them: not parsed and
     * printed again, which would round the seed's 16 digits to cJSON's 15. */
    int written = keys ? snprintf(out, size, "%.*s,%s", (int)strlen(keys) - 1, keys, fields + 1)
                       : snprintf(out, size, "%s", fields);
    cJSON_free(keys);
    return written >= 0 && (size_t)written < size;
}

/* The job's string member key into out ("" and 0 when it has none). */
static int job_string(const char *json, const char *key, char *out, size_t size)
{
    out[0] = '\0';
    cJSON *root = cJSON_Parse(json ? json : "{}");
    const cJSON *value = cJSON_GetObjectItemCaseSensitive(root, key);
    int found = cJSON_IsString(value);
    if (found)
        snprintf(out, size, "%s", value->valuestring);
    cJSON_Delete(root);
    return found;
}

void pf_job_name(const char *json, char *out, size_t size)
{
    job_string(json, "name", out, size);
}

int pf_job_animation(const char *json, char *out, size_t size)
{
    return job_string(json, "animation", out, size);
}

int pf_job_material_variant(const char *json, char *out, size_t size)
{
    return job_string(json, "material_variant", out, size);
}

int pf_job_allow_outside(const char *json)
{
    cJSON *root = cJSON_Parse(json ? json : "{}");
    int allowed = cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(root, "allow_outside_scene_dir"));
    cJSON_Delete(root);
    return allowed;
}
