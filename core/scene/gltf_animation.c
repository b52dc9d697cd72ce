/*
 * glTF animations → scene_channel records: each channel gets its own copy of
 * the sampler's key times and values, validated (counts, finite values,
 * non-decreasing times) so sampling at eval time cannot fail.
 */
#include "gltf_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static pf_status load_channel(gltf_context *ctx, const cJSON *channel, const cJSON *samplers,
                              uint32_t sampler_count, const char *element, scene_channel *out,
                              int *skipped, pf_error *err)
{
    pf_scene *scene = ctx->scene;
    *skipped = 0;
    int32_t sampler_index, node_index;
    pf_status status =
        gltf_index(ctx, channel, "sampler", sampler_count, &sampler_index, element, err);
    if (status)
        return status;
    if (sampler_index == SCENE_NONE)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "sampler is missing");
    char target_element[128];
    snprintf(target_element, sizeof target_element, "%s.target", element);
    const cJSON *target = cJSON_GetObjectItemCaseSensitive(channel, "target");
    if (!cJSON_IsObject(target))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, target_element, "expected an object");
    status = gltf_index(ctx, target, "node", scene->node_count, &node_index, target_element, err);
    if (status)
        return status;
    const cJSON *path = cJSON_GetObjectItemCaseSensitive(target, "path");
    const char *path_name = cJSON_IsString(path) ? path->valuestring : "";
    if (strcmp(path_name, "translation") == 0) {
        out->path = SCENE_PATH_TRANSLATION;
        out->components = 3;
    } else if (strcmp(path_name, "rotation") == 0) {
        out->path = SCENE_PATH_ROTATION;
        out->components = 4;
    } else if (strcmp(path_name, "scale") == 0) {
        out->path = SCENE_PATH_SCALE;
        out->components = 3;
    } else if (strcmp(path_name, "weights") == 0) {
        out->path = SCENE_PATH_WEIGHTS;
        out->components = 0; /* the node's mesh's target count, below */
    } else {
        return gltf_fail(ctx, err, PF_ERR_FORMAT, target_element,
                         "path \"%s\" is not translation, rotation, scale or weights", path_name);
    }
    if (node_index == SCENE_NONE) {
        scene_warn_once(scene, "channel without node",
                        "%s: %s: channel without a target node (an extension's pointer?): "
                        "ignored", ctx->path, element);
        *skipped = 1;
        return PF_OK;
    }
    const scene_node *node = &scene->nodes[node_index];
    if (out->path == SCENE_PATH_WEIGHTS) {
        const scene_mesh *mesh = node->mesh == SCENE_NONE ? NULL : &scene->meshes[node->mesh];
        out->components = mesh && mesh->deform ? mesh->deform->target_count : 0;
        if (out->components == 0)
            return gltf_fail(ctx, err, PF_ERR_FORMAT, target_element,
                             "weights of node %d, whose mesh has no morph targets", node_index);
    } else if (node->has_matrix) {
        return gltf_fail(ctx, err, PF_ERR_FORMAT, target_element,
                         "node %d has a matrix, which glTF forbids animating", node_index);
    }
    out->node = (uint32_t)node_index;

    char sampler_element[128];
    const char *animation_end = strstr(element, ".channels");
    snprintf(sampler_element, sizeof sampler_element, "%.*s.samplers[%d]",
             animation_end ? (int)(animation_end - element) : (int)strlen(element), element,
             sampler_index);
    const cJSON *sampler = cJSON_GetArrayItem(samplers, sampler_index);
    if (!cJSON_IsObject(sampler))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, sampler_element, "expected an object");
    const cJSON *interpolation = cJSON_GetObjectItemCaseSensitive(sampler, "interpolation");
    const char *interpolation_name =
        cJSON_IsString(interpolation) ? interpolation->valuestring : "LINEAR";
    if (strcmp(interpolation_name, "LINEAR") == 0)
        out->interpolation = SCENE_INTERP_LINEAR;
    else if (strcmp(interpolation_name, "STEP") == 0)
        out->interpolation = SCENE_INTERP_STEP;
    else if (strcmp(interpolation_name, "CUBICSPLINE") == 0)
        out->interpolation = SCENE_INTERP_CUBICSPLINE;
    else
        return gltf_fail(ctx, err, PF_ERR_FORMAT, sampler_element,
                         "interpolation \"%s\" is not LINEAR, STEP or CUBICSPLINE",
                         interpolation_name);
    uint32_t accessor_count = (uint32_t)cJSON_GetArraySize(
        cJSON_GetObjectItemCaseSensitive(ctx->root, "accessors"));
    int32_t input, output;
    status = gltf_index(ctx, sampler, "input", accessor_count, &input, sampler_element, err);
    if (!status)
        status = gltf_index(ctx, sampler, "output", accessor_count, &output, sampler_element, err);
    if (status)
        return status;
    if (input == SCENE_NONE || output == SCENE_NONE)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, sampler_element, "input and output are required");
    char sub[160];
    uint32_t key_count, value_count;
    snprintf(sub, sizeof sub, "%s.input", sampler_element);
    status = gltf_read_floats(ctx, input, 1, &out->times, &key_count, sub, err);
    if (status)
        return status;
    out->key_count = key_count;
    for (uint32_t k = 1; k < key_count; k++)
        if (out->times[k] < out->times[k - 1])
            return gltf_fail(ctx, err, PF_ERR_FORMAT, sub,
                             "key times must increase (key %u: %g after %g)", k, out->times[k],
                             out->times[k - 1]);
    snprintf(sub, sizeof sub, "%s.output", sampler_element);
    /* Weights are SCALAR: one value per target per key (glTF §3.11). */
    uint32_t element_components = out->path == SCENE_PATH_WEIGHTS ? 1 : out->components;
    uint32_t per_element = out->path == SCENE_PATH_WEIGHTS ? out->components : 1;
    status = gltf_read_floats(ctx, output, element_components, &out->values, &value_count, sub,
                              err);
    if (status)
        return status;
    uint32_t per_key = out->interpolation == SCENE_INTERP_CUBICSPLINE ? 3 : 1;
    uint64_t expected = (uint64_t)key_count * per_key * per_element;
    if ((uint64_t)value_count != expected)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, sub,
                         "%u values for %u keys (expected %llu%s%s)", value_count, key_count,
                         (unsigned long long)expected,
                         per_key == 3 ? ": in-tangent, value, out-tangent per key" : "",
                         per_element > 1 ? ", one per morph target" : "");
    if (out->path == SCENE_PATH_ROTATION && out->interpolation != SCENE_INTERP_CUBICSPLINE)
        for (uint32_t k = 0; k < key_count; k++)
            scene_quat_normalize(out->values + 4 * (size_t)k);
    return PF_OK;
}

/* The index of the animation the load options chose (by name, else by index), or a
 * PF_ERR_INVALID naming the choice and the file's animations. */
static pf_status choose_animation(gltf_context *ctx, const cJSON *animations, uint32_t count,
                                  pf_error *err)
{
    pf_scene *scene = ctx->scene;
    char names[512];
    scene->animation = gltf_named_entry(animations, count, scene->animation_choice, names,
                                        sizeof names);
    if (scene->animation != SCENE_NONE)
        return PF_OK;
    return pf_error_set(err, PF_ERR_INVALID, "%s: --animation '%s': no animation of that name or "
                        "index (the file's: %s)", ctx->path, scene->animation_choice, names);
}

pf_status gltf_load_animations(gltf_context *ctx, pf_error *err)
{
    pf_scene *scene = ctx->scene;
    const cJSON *animations;
    uint32_t animation_count;
    pf_status status =
        gltf_array(ctx, ctx->root, "animations", &animations, &animation_count, "", err);
    if (!status && scene->animation_choice)
        status = choose_animation(ctx, animations, animation_count, err);
    if (status || animation_count == 0)
        return status;
    scene->animation_count = animation_count;
    uint32_t total = 0;
    for (uint32_t a = 0; a < animation_count; a++)
        total += (uint32_t)cJSON_GetArraySize(
            cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(animations, (int)a), "channels"));
    if (total == 0)
        return PF_OK;
    scene->channels = calloc(total, sizeof *scene->channels);
    if (!scene->channels)
        return gltf_fail(ctx, err, PF_ERR_NOMEM, "animations", "out of memory");
    for (uint32_t a = 0; a < animation_count; a++) {
        if (scene->animation != SCENE_NONE && (int32_t)a != scene->animation)
            continue; /* not the one chosen to play: neither read nor checked */
        char element[64];
        snprintf(element, sizeof element, "animations[%u]", a);
        const cJSON *animation = cJSON_GetArrayItem(animations, (int)a);
        if (!cJSON_IsObject(animation))
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "expected an object");
        const cJSON *channels, *samplers;
        uint32_t channel_count, sampler_count;
        status = gltf_array(ctx, animation, "channels", &channels, &channel_count, element, err);
        if (!status)
            status = gltf_array(ctx, animation, "samplers", &samplers, &sampler_count, element,
                                err);
        if (status)
            return status;
        for (uint32_t c = 0; c < channel_count; c++) {
            char channel_element[96];
            snprintf(channel_element, sizeof channel_element, "animations[%u].channels[%u]", a, c);
            const cJSON *channel = cJSON_GetArrayItem(channels, (int)c);
            if (!cJSON_IsObject(channel))
                return gltf_fail(ctx, err, PF_ERR_FORMAT, channel_element, "expected an object");
            scene_channel *out = &scene->channels[scene->channel_count];
            int skipped;
            /* Counted before loading so a failure still frees what was allocated. */
            scene->channel_count++;
            status = load_channel(ctx, channel, samplers, sampler_count, channel_element, out,
                                  &skipped, err);
            if (status)
                return status;
            if (skipped) {
                scene->channel_count--;
                free(out->times);
                free(out->values);
                memset(out, 0, sizeof *out);
                continue;
            }
            if (out->path == SCENE_PATH_WEIGHTS)
                scene->nodes[out->node].has_weights_channel = 1;
            else
                scene->nodes[out->node].has_channel = 1;
        }
    }
    return PF_OK;
}
