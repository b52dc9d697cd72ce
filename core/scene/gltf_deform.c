/*
 * glTF skins and morph targets → scene_deform_mesh and scene_skin records,
 * validated at load (glTF 2.0 §3.7.2.2 morph targets, §3.7.3 skins) so that
 * deform.c never has to check anything per frame:
 *   - JOINTS_n are unsigned bytes or shorts naming a skin's joints, WEIGHTS_n are
 *     finite and non-negative; up to two sets (8 influences) a vertex;
 *   - a vertex's weights are normalised to sum 1, as the spec asks of writers; a
 *     vertex with no weight at all keeps its bind pose (one warning);
 *   - every primitive of a mesh has the same number of morph targets, and the
 *     mesh's and node's `weights` have that many entries.
 */
#include "gltf_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int gltf_mesh_deforms(const cJSON *mesh)
{
    const cJSON *primitives = cJSON_GetObjectItemCaseSensitive(mesh, "primitives");
    const cJSON *primitive;
    cJSON_ArrayForEach(primitive, primitives) {
        const cJSON *attributes = cJSON_GetObjectItemCaseSensitive(primitive, "attributes");
        if (cJSON_GetObjectItemCaseSensitive(primitive, "targets") ||
            cJSON_GetObjectItemCaseSensitive(attributes, "JOINTS_0"))
            return 1;
    }
    return 0;
}

void scene_deform_mesh_free(scene_deform_mesh *deform)
{
    if (!deform)
        return;
    free(deform->corner_vertex);
    free(deform->positions);
    free(deform->normals);
    free(deform->joints);
    free(deform->weights);
    free(deform->target_positions);
    free(deform->target_normals);
    free(deform->target_tangents);
    free(deform->default_weights);
    free(deform);
}

static uint32_t accessor_count(const gltf_context *ctx)
{
    return (uint32_t)cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(ctx->root, "accessors"));
}

/* Grows *array (elements of size bytes, count now) to hold count + more; NULL on failure. */
static int grow(void **array, size_t count, size_t more, size_t size)
{
    void *grown = realloc(*array, (count + more) * size + 1);
    if (!grown)
        return 0;
    *array = grown;
    return 1;
}

/*
 * Reads JOINTS_set and WEIGHTS_set of the primitive into influences 4·set..4·set+3 of
 * the vertices from `first`. *present: the primitive has JOINTS_set.
 */
static pf_status read_influence_set(gltf_context *ctx, scene_deform_mesh *deform,
                                    const cJSON *attributes, const char *element, int set,
                                    uint32_t first, uint32_t vertex_count, int *present,
                                    pf_error *err)
{
    char joints_name[24], weights_name[24], sub[224];
    snprintf(joints_name, sizeof joints_name, "JOINTS_%d", set);
    snprintf(weights_name, sizeof weights_name, "WEIGHTS_%d", set);
    int32_t joints_index, weights_index;
    pf_status status = gltf_index(ctx, attributes, joints_name, accessor_count(ctx),
                                  &joints_index, element, err);
    if (!status)
        status = gltf_index(ctx, attributes, weights_name, accessor_count(ctx), &weights_index,
                            element, err);
    if (status)
        return status;
    *present = joints_index != SCENE_NONE;
    if (joints_index == SCENE_NONE && weights_index == SCENE_NONE)
        return PF_OK;
    if (joints_index == SCENE_NONE || weights_index == SCENE_NONE)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "%s without %s",
                         joints_index == SCENE_NONE ? weights_name : joints_name,
                         joints_index == SCENE_NONE ? joints_name : weights_name);
    uint32_t *joints = NULL, joint_count = 0, weight_count = 0;
    float *weights = NULL;
    char joints_element[192], weights_element[192];
    snprintf(joints_element, sizeof joints_element, "%s.attributes.%s (accessors[%d])", element,
             joints_name, joints_index);
    snprintf(weights_element, sizeof weights_element, "%s.attributes.%s (accessors[%d])", element,
             weights_name, weights_index);
    snprintf(sub, sizeof sub, "%s.attributes.%s", element, joints_name);
    status = gltf_read_uints(ctx, joints_index, 4, &joints, &joint_count, sub, err);
    if (!status) {
        snprintf(sub, sizeof sub, "%s.attributes.%s", element, weights_name);
        status = gltf_read_floats(ctx, weights_index, 4, &weights, &weight_count, sub, err);
    }
    if (!status && (joint_count != vertex_count || weight_count != vertex_count))
        status = gltf_fail(ctx, err, PF_ERR_FORMAT, joint_count != vertex_count ? joints_element
                                                                                : weights_element,
                           "%u values for %u positions",
                           joint_count != vertex_count ? joint_count : weight_count,
                           vertex_count);
    for (uint32_t v = 0; !status && v < vertex_count; v++)
        for (int k = 0; k < 4 && !status; k++) {
            float weight = weights[4 * (size_t)v + k];
            uint32_t joint = joints[4 * (size_t)v + k];
            if (!(weight >= 0.0f))
                status = gltf_fail(ctx, err, PF_ERR_FORMAT, weights_element,
                                   "vertex %u weight %d is negative (%g)", v, k, weight);
            else if (joint > UINT16_MAX)
                status = gltf_fail(ctx, err, PF_ERR_FORMAT, joints_element,
                                   "vertex %u joint %u: joints are unsigned bytes or shorts", v,
                                   joint);
            if (status)
                break;
            deform->joints[first + v][4 * set + k] = (uint16_t)joint;
            deform->weights[first + v][4 * set + k] = weight;
            /* An unweighted influence may name any joint (writers pad with 0). */
            if (weight > 0.0f && joint > deform->max_joint) {
                deform->max_joint = joint;
                snprintf(deform->joints_element, sizeof deform->joints_element, "%s",
                         joints_element);
            }
        }
    free(joints);
    free(weights);
    return status;
}

/* JOINTS_0/WEIGHTS_0 and _1 of the primitive, normalised. */
static pf_status read_influences(gltf_context *ctx, scene_mesh *mesh, const cJSON *attributes,
                                 const char *element, uint32_t first, uint32_t vertex_count,
                                 pf_error *err)
{
    scene_deform_mesh *deform = mesh->deform;
    memset(deform->joints + first, 0, (size_t)vertex_count * sizeof *deform->joints);
    memset(deform->weights + first, 0, (size_t)vertex_count * sizeof *deform->weights);
    int present[2] = {0, 0};
    pf_status status = PF_OK;
    for (int set = 0; set < 2 && !status; set++)
        status = read_influence_set(ctx, deform, attributes, element, set, first, vertex_count,
                                    &present[set], err);
    if (status)
        return status;
    if (!present[0] && present[1])
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "JOINTS_1 without JOINTS_0");
    /* glTF: a skinned mesh has JOINTS_0 on every primitive. */
    if (!present[0] && deform->influences > 0)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "JOINTS_0 is missing while other primitives of the mesh have it");
    if (present[0] && deform->influences == 0 && first > 0)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "JOINTS_0 is present while earlier primitives of the mesh lack it");
    uint32_t influences = present[1] ? 8u : present[0] ? 4u : 0u;
    if (influences > deform->influences)
        deform->influences = influences;
    uint32_t unweighted = 0;
    for (uint32_t v = 0; v < vertex_count && present[0]; v++) {
        float *weights = deform->weights[first + v];
        float sum = 0.0f;
        for (int k = 0; k < SCENE_MAX_INFLUENCES; k++)
            sum += weights[k];
        if (!(sum > 0.0f)) {
            unweighted++;
            continue;
        }
        for (int k = 0; k < SCENE_MAX_INFLUENCES; k++)
            weights[k] /= sum;
    }
    if (unweighted)
        scene_warn_once(ctx->scene, "unweighted vertices",
                        "%s: %s: %u vertices have no joint weight: they keep their bind pose",
                        ctx->path, element, unweighted);
    return PF_OK;
}

/* Reads one target attribute (VEC3) into out's [vertex][target][3] slots from `first`. */
static pf_status read_target_attribute(gltf_context *ctx, const cJSON *target,
                                       const char *name, const char *element, uint32_t t,
                                       uint32_t target_count, uint32_t first,
                                       uint32_t vertex_count, float **out, size_t total_vertices,
                                       pf_error *err)
{
    int32_t index;
    pf_status status = gltf_index(ctx, target, name, accessor_count(ctx), &index, element, err);
    if (status || index == SCENE_NONE)
        return status;
    if (!*out) {
        *out = calloc(total_vertices * target_count * 3 + 1, sizeof **out);
        if (!*out)
            return gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
    }
    char sub[224];
    snprintf(sub, sizeof sub, "%s.%s", element, name);
    float *deltas = NULL;
    uint32_t count = 0;
    status = gltf_read_floats(ctx, index, 3, &deltas, &count, sub, err);
    if (!status && count != vertex_count)
        status = gltf_fail(ctx, err, PF_ERR_FORMAT, sub, "%u values for %u positions", count,
                           vertex_count);
    for (uint32_t v = 0; !status && v < vertex_count; v++)
        memcpy(*out + ((size_t)(first + v) * target_count + t) * 3, deltas + 3 * (size_t)v,
               3 * sizeof(float));
    free(deltas);
    return status;
}

/* The primitive's morph targets into the mesh's [vertex][target] arrays. */
static pf_status read_targets(gltf_context *ctx, scene_mesh *mesh, const cJSON *primitive,
                              const char *element, uint32_t first, uint32_t vertex_count,
                              pf_error *err)
{
    scene_deform_mesh *deform = mesh->deform;
    const cJSON *targets;
    uint32_t target_count;
    pf_status status = gltf_array(ctx, primitive, "targets", &targets, &target_count, element,
                                  err);
    if (status)
        return status;
    if (first == 0)
        deform->target_count = target_count;
    else if (target_count != deform->target_count)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "%u morph targets where the mesh's first primitive has %u (every "
                         "primitive must have the same)",
                         target_count, deform->target_count);
    if (target_count == 0)
        return PF_OK;
    size_t total = (size_t)first + vertex_count;
    float **arrays[3] = {&deform->target_positions, &deform->target_normals,
                         &deform->target_tangents};
    for (int a = 0; a < 3; a++) {
        if (!*arrays[a])
            continue;
        /* Grown for this primitive's vertices, zero until a target writes them. */
        if (!grow((void **)arrays[a], (size_t)first * target_count * 3,
                  (size_t)vertex_count * target_count * 3, sizeof(float)))
            return gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
        memset(*arrays[a] + (size_t)first * target_count * 3, 0,
               (size_t)vertex_count * target_count * 3 * sizeof(float));
    }
    static const char *const names[3] = {"POSITION", "NORMAL", "TANGENT"};
    for (uint32_t t = 0; t < target_count && !status; t++) {
        char target_element[192];
        snprintf(target_element, sizeof target_element, "%s.targets[%u]", element, t);
        const cJSON *target = cJSON_GetArrayItem(targets, (int)t);
        if (!cJSON_IsObject(target))
            return gltf_fail(ctx, err, PF_ERR_FORMAT, target_element, "expected an object");
        for (int a = 0; a < 3 && !status; a++) {
            /* An array a later primitive starts: zero for the vertices before it. */
            status = read_target_attribute(ctx, target, names[a], target_element, t,
                                           target_count, first, vertex_count, arrays[a], total,
                                           err);
        }
    }
    return status;
}

pf_status gltf_append_deform_vertices(gltf_context *ctx, scene_mesh *mesh,
                                      const cJSON *primitive, const char *element,
                                      const float *positions, const float *normals,
                                      uint32_t vertex_count, const uint32_t *corners,
                                      uint32_t triangle_count, pf_error *err)
{
    if (!mesh->deform) {
        mesh->deform = calloc(1, sizeof *mesh->deform);
        if (!mesh->deform)
            return gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
    }
    scene_deform_mesh *deform = mesh->deform;
    uint32_t first = deform->vertex_count;
    if ((uint64_t)first + vertex_count > UINT32_MAX / 4)
        return gltf_fail(ctx, err, PF_ERR_LIMIT, element, "too many vertices in one mesh");
    /* The triangles were appended just before: they are the mesh's last ones. */
    uint32_t first_corner = 3 * (mesh->triangle_count - triangle_count);
    if (!grow((void **)&deform->corner_vertex, first_corner, 3 * (size_t)triangle_count,
              sizeof *deform->corner_vertex) ||
        !grow((void **)&deform->positions, first, vertex_count, sizeof *deform->positions) ||
        !grow((void **)&deform->normals, first, vertex_count, sizeof *deform->normals) ||
        !grow((void **)&deform->joints, first, vertex_count, sizeof *deform->joints) ||
        !grow((void **)&deform->weights, first, vertex_count, sizeof *deform->weights))
        return gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
    for (size_t k = 0; k < 3 * (size_t)triangle_count; k++)
        deform->corner_vertex[first_corner + k] = first + corners[k];
    memcpy(deform->positions + first, positions, (size_t)vertex_count * sizeof *deform->positions);
    if (normals)
        memcpy(deform->normals + first, normals, (size_t)vertex_count * sizeof *deform->normals);
    else
        memset(deform->normals + first, 0, (size_t)vertex_count * sizeof *deform->normals);
    const cJSON *attributes = cJSON_GetObjectItemCaseSensitive(primitive, "attributes");
    pf_status status = read_influences(ctx, mesh, attributes, element, first, vertex_count, err);
    if (!status)
        status = read_targets(ctx, mesh, primitive, element, first, vertex_count, err);
    if (!status)
        deform->vertex_count = first + vertex_count;
    return status;
}

/* A `weights` array of exactly count finite numbers into out (malloc'ed). */
static pf_status read_weights(gltf_context *ctx, const cJSON *weights, uint32_t count,
                              const char *element, float **out, pf_error *err)
{
    uint32_t given = (uint32_t)cJSON_GetArraySize(weights);
    if (!cJSON_IsArray(weights) || given != count)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "weights: %u values for %u morph targets", given, count);
    *out = calloc((size_t)count + 1, sizeof **out);
    if (!*out)
        return gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
    for (uint32_t k = 0; k < count; k++) {
        const cJSON *item = cJSON_GetArrayItem(weights, (int)k);
        if (!cJSON_IsNumber(item) || !isfinite(item->valuedouble))
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                             "weights[%u] is not a finite number", k);
        (*out)[k] = (float)item->valuedouble;
    }
    return PF_OK;
}

pf_status gltf_load_mesh_weights(gltf_context *ctx, const cJSON *mesh_json, scene_mesh *mesh,
                                 const char *element, pf_error *err)
{
    const cJSON *weights = cJSON_GetObjectItemCaseSensitive(mesh_json, "weights");
    uint32_t targets = mesh->deform ? mesh->deform->target_count : 0;
    if (targets == 0) {
        if (weights)
            scene_warn_once(ctx->scene, "weights without targets",
                            "%s: %s: weights without morph targets: ignored", ctx->path,
                            element);
        return PF_OK;
    }
    if (!weights) {
        mesh->deform->default_weights = calloc(targets, sizeof(float));
        return mesh->deform->default_weights
                   ? PF_OK
                   : gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
    }
    return read_weights(ctx, weights, targets, element, &mesh->deform->default_weights, err);
}

static pf_status load_skin(gltf_context *ctx, const cJSON *skin, const char *element,
                           scene_skin *out, pf_error *err)
{
    pf_scene *scene = ctx->scene;
    if (!cJSON_IsObject(skin))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "expected an object");
    const cJSON *joints;
    uint32_t joint_count;
    int32_t matrices_index;
    pf_status status = gltf_array(ctx, skin, "joints", &joints, &joint_count, element, err);
    if (!status)
        status = gltf_index(ctx, skin, "inverseBindMatrices", accessor_count(ctx),
                            &matrices_index, element, err);
    if (status)
        return status;
    if (joint_count == 0 || joint_count > UINT16_MAX + 1u)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "%u joints (1 to 65536 allowed)",
                         joint_count);
    out->joints = malloc(joint_count * sizeof *out->joints);
    out->inverse_bind = malloc(joint_count * sizeof *out->inverse_bind);
    if (!out->joints || !out->inverse_bind)
        return gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
    out->joint_count = joint_count;
    for (uint32_t j = 0; j < joint_count; j++) {
        const cJSON *item = cJSON_GetArrayItem(joints, (int)j);
        double value = cJSON_IsNumber(item) ? item->valuedouble : -1;
        if (!(value >= 0 && value < scene->node_count && value == floor(value)))
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                             "joints[%u]: not a valid node index", j);
        out->joints[j] = (uint32_t)value;
        scene_mat4_identity(out->inverse_bind[j]);
    }
    if (matrices_index == SCENE_NONE)
        return PF_OK;
    char sub[128];
    snprintf(sub, sizeof sub, "%s.inverseBindMatrices", element);
    float *matrices = NULL;
    uint32_t count = 0;
    status = gltf_read_floats(ctx, matrices_index, 16, &matrices, &count, sub, err);
    if (!status && count < joint_count)
        status = gltf_fail(ctx, err, PF_ERR_FORMAT, sub, "%u matrices for %u joints", count,
                           joint_count);
    if (!status)
        memcpy(out->inverse_bind, matrices, joint_count * sizeof *out->inverse_bind);
    free(matrices);
    return status;
}

/* A node's skin and weights against its mesh (and the skin's joints against the mesh's). */
static pf_status check_node(gltf_context *ctx, uint32_t index, const cJSON *node_json,
                            pf_error *err)
{
    pf_scene *scene = ctx->scene;
    scene_node *node = &scene->nodes[index];
    char element[64];
    snprintf(element, sizeof element, "nodes[%u]", index);
    const scene_mesh *mesh = node->mesh == SCENE_NONE ? NULL : &scene->meshes[node->mesh];
    const scene_deform_mesh *deform = mesh ? mesh->deform : NULL;
    const cJSON *weights = cJSON_GetObjectItemCaseSensitive(node_json, "weights");
    if (weights && deform && deform->target_count > 0) {
        pf_status status = read_weights(ctx, weights, deform->target_count, element,
                                        &node->weights, err);
        if (status)
            return status;
    } else if (weights) {
        scene_warn_once(scene, "weights without targets",
                        "%s: %s: weights without morph targets: ignored", ctx->path, element);
    }
    if (node->skin == SCENE_NONE)
        return PF_OK;
    if (!mesh) {
        scene_warn_once(scene, "skin without mesh", "%s: %s: a skin without a mesh: ignored",
                        ctx->path, element);
        node->skin = SCENE_NONE;
        return PF_OK;
    }
    if (!deform || deform->influences == 0)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "skin %d on meshes[%d], whose primitives have no JOINTS_0", node->skin,
                         node->mesh);
    const scene_skin *skin = &scene->skins[node->skin];
    if (deform->max_joint >= skin->joint_count)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, deform->joints_element,
                         "joint %u is outside skins[%d], which has %u joints (used by %s)",
                         deform->max_joint, node->skin, skin->joint_count, element);
    return PF_OK;
}

pf_status gltf_load_skins(gltf_context *ctx, pf_error *err)
{
    pf_scene *scene = ctx->scene;
    const cJSON *skins;
    uint32_t count;
    pf_status status = gltf_array(ctx, ctx->root, "skins", &skins, &count, "", err);
    if (status)
        return status;
    if (count > 0) {
        scene->skins = calloc(count, sizeof *scene->skins);
        if (!scene->skins)
            return gltf_fail(ctx, err, PF_ERR_NOMEM, "skins", "out of memory");
        scene->skin_count = count;
    }
    for (uint32_t k = 0; k < count && !status; k++) {
        char element[64];
        snprintf(element, sizeof element, "skins[%u]", k);
        status = load_skin(ctx, cJSON_GetArrayItem(skins, (int)k), element, &scene->skins[k],
                           err);
    }
    const cJSON *nodes = cJSON_GetObjectItemCaseSensitive(ctx->root, "nodes");
    for (uint32_t k = 0; k < scene->node_count && !status; k++)
        status = check_node(ctx, k, cJSON_GetArrayItem(nodes, (int)k), err);
    return status;
}
