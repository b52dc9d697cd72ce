/*
 * The `deform` stage's work on the host: glTF morph targets and linear blend
 * skinning of every deforming mesh node into a frame (pf_scene_deform in
 * pf_scene.h says what it computes). Per vertex it forms one 3×4 matrix M
 * (the skin's weighted joint matrices, or the node's world matrix for a mesh
 * that is only morphed) and applies it to the morphed rest position, its
 * cofactor (det · inverse transpose) to the normal and its 3×3 part to the
 * corner tangents; the corners then gather their vertex. The loops are plain
 * arrays of floats so that the compiler vectorises them.
 */
#include "scene_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Per-vertex work arrays of one node, reused from node to node. */
typedef struct deform_scratch {
    size_t capacity;         /* vertices */
    float (*position)[3];    /* morphed rest position, then world */
    float (*normal)[3];      /* morphed rest normal, then world (unnormalised) */
    float (*tangent)[3];     /* the morph's tangent delta (NULL unless targets have one) */
    float (*matrix)[12];     /* M: column-major 3×4 */
    float *weights;          /* the node's morph weights this frame */
} deform_scratch;

static int scratch_reserve(deform_scratch *scratch, size_t vertices, uint32_t targets)
{
    if (vertices <= scratch->capacity && scratch->weights)
        return 1;
    free(scratch->position);
    free(scratch->normal);
    free(scratch->tangent);
    free(scratch->matrix);
    free(scratch->weights);
    size_t n = vertices + 1;
    scratch->position = malloc(n * sizeof *scratch->position);
    scratch->normal = malloc(n * sizeof *scratch->normal);
    scratch->tangent = malloc(n * sizeof *scratch->tangent);
    scratch->matrix = malloc(n * sizeof *scratch->matrix);
    scratch->weights = malloc(((size_t)targets + 1) * sizeof *scratch->weights);
    scratch->capacity = vertices;
    return scratch->position && scratch->normal && scratch->tangent && scratch->matrix &&
           scratch->weights;
}

static void scratch_free(deform_scratch *scratch)
{
    free(scratch->position);
    free(scratch->normal);
    free(scratch->tangent);
    free(scratch->matrix);
    free(scratch->weights);
}

/* The node's morph weights at time: the node's own, else the mesh's, then its channels. */
static void node_weights(const pf_scene *scene, uint32_t index, double time, float *weights)
{
    const scene_node *node = &scene->nodes[index];
    const scene_deform_mesh *deform = scene->meshes[node->mesh].deform;
    const float *base = node->weights ? node->weights : deform->default_weights;
    memcpy(weights, base, deform->target_count * sizeof *weights);
    if (!node->has_weights_channel)
        return;
    /* Channels are few; the last one for this node wins, as for transforms. */
    for (uint32_t c = 0; c < scene->channel_count; c++) {
        const scene_channel *channel = &scene->channels[c];
        if (channel->path == SCENE_PATH_WEIGHTS && channel->node == index)
            scene_channel_sample(channel, time, weights);
    }
}

/* Rest positions and normals plus the weighted target deltas; tangent deltas too. */
static void morph(const pf_deform_node *node, const pf_deform_vertices *out)
{
    uint32_t vertices = node->vertex_count, targets = node->target_count;
    memcpy(out->position, node->positions, vertices * sizeof *out->position);
    memcpy(out->normal, node->normals, vertices * sizeof *out->normal);
    if (node->target_tangents)
        memset(out->tangent, 0, vertices * sizeof *out->tangent);
    for (uint32_t t = 0; t < targets; t++) {
        float w = node->weights[t];
        if (w == 0.0f)
            continue;
        const float *dp = node->target_positions;
        const float *dn = node->target_normals;
        const float *dt = node->target_tangents;
        for (uint32_t v = 0; v < vertices; v++) {
            size_t at = ((size_t)v * targets + t) * 3;
            for (int k = 0; k < 3; k++) {
                if (dp)
                    out->position[v][k] += w * dp[at + k];
                if (dn)
                    out->normal[v][k] += w * dn[at + k];
                if (dt)
                    out->tangent[v][k] += w * dt[at + k];
            }
        }
    }
}

/* joint_matrices[j] = world[joint j] · inverse_bind[j], as 3×4. */
static void joint_matrices(const scene_skin *skin, const float (*world)[16], float (*out)[12])
{
    for (uint32_t j = 0; j < skin->joint_count; j++) {
        float full[16];
        scene_mat4_mul(world[skin->joints[j]], skin->inverse_bind[j], full);
        for (int column = 0; column < 4; column++)
            memcpy(out[j] + 3 * column, full + 4 * column, 3 * sizeof(float));
    }
}

/* M of every vertex: the weighted sum of its joints' matrices (identity without weight), or
 * the node's one matrix for a node without influences. */
static void blend_matrices(const pf_deform_node *node, float (*matrix)[12])
{
    static const float identity[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
    uint32_t influences = node->influences;
    for (uint32_t v = 0; v < node->vertex_count; v++) {
        if (influences == 0) {
            memcpy(matrix[v], node->matrices[0], sizeof matrix[v]);
            continue;
        }
        float m[12] = {0};
        float total = 0.0f;
        for (uint32_t i = 0; i < influences; i++) {
            float w = node->joint_weights[v][i];
            if (w == 0.0f)
                continue;
            const float *joint = node->matrices[node->joints[v][i]];
            for (int k = 0; k < 12; k++)
                m[k] += w * joint[k];
            total += w;
        }
        memcpy(matrix[v], total > 0.0f ? m : identity, sizeof m);
    }
}

/* Cofactor of M's 3×3 (= det · inverse transpose) applied to n; returns det. */
static float cofactor_apply(const float m[12], const float n[3], float out[3])
{
    float a = m[0], b = m[3], c = m[6];
    float d = m[1], e = m[4], f = m[7];
    float g = m[2], h = m[5], i = m[8];
    float c00 = e * i - f * h, c01 = -(d * i - f * g), c02 = d * h - e * g;
    float c10 = -(b * i - c * h), c11 = a * i - c * g, c12 = -(a * h - b * g);
    float c20 = b * f - c * e, c21 = -(a * f - c * d), c22 = a * e - b * d;
    /* c_rc is the cofactor of M's row r, column c: out = cof(M) · n. */
    out[0] = c00 * n[0] + c01 * n[1] + c02 * n[2];
    out[1] = c10 * n[0] + c11 * n[1] + c12 * n[2];
    out[2] = c20 * n[0] + c21 * n[1] + c22 * n[2];
    return a * c00 + b * c01 + c * c02;
}

static void apply_point(const float m[12], const float p[3], float out[3])
{
    for (int r = 0; r < 3; r++)
        out[r] = m[r] * p[0] + m[3 + r] * p[1] + m[6 + r] * p[2] + m[9 + r];
}

static void apply_vector(const float m[12], const float v[3], float out[3])
{
    for (int r = 0; r < 3; r++)
        out[r] = m[r] * v[0] + m[3 + r] * v[1] + m[6 + r] * v[2];
}

/* World positions and normals of every vertex from its M. */
static void transform_vertices(uint32_t vertices, const pf_deform_vertices *out)
{
    for (uint32_t v = 0; v < vertices; v++) {
        float p[3], n[3];
        apply_point(out->matrix[v], out->position[v], p);
        cofactor_apply(out->matrix[v], out->normal[v], n);
        memcpy(out->position[v], p, sizeof p);
        memcpy(out->normal[v], n, sizeof n);
    }
}

pf_status pf_deform_vertices_host(void *user, const pf_deform_node *node,
                                  const pf_deform_vertices *out, pf_error *err)
{
    (void)user;
    (void)err;
    morph(node, out);
    blend_matrices(node, out->matrix);
    transform_vertices(node->vertex_count, out);
    return PF_OK;
}

static float det3(const float m[12])
{
    return m[0] * (m[4] * m[8] - m[7] * m[5]) - m[3] * (m[1] * m[8] - m[7] * m[2]) +
           m[6] * (m[1] * m[5] - m[4] * m[2]);
}

/* Corner texels of one triangle (uv, colour, tangent turned by its vertex's M). */
static void gather_corners(const scene_mesh *mesh, uint32_t t, const uint32_t *vertex,
                           const int order[3], float det, const deform_scratch *s,
                           int tangent_deltas, float (*out)[4])
{
    for (int c = 0; c < 3; c++) {
        float defaults[SCENE_CORNER_FLOATS], world[3];
        scene_corner_defaults(defaults);
        const float *corner =
            mesh->corners ? mesh->corners[t] + SCENE_CORNER_FLOATS * order[c] : defaults;
        uint32_t v = vertex[order[c]];
        float tangent[3] = {corner[8], corner[9], corner[10]};
        if (tangent_deltas && corner[11] != 0.0f)
            for (int k = 0; k < 3; k++)
                tangent[k] += s->tangent[v][k];
        apply_vector(s->matrix[v], tangent, world);
        scene_corner_texels(corner, world, det, out + PF_CORNER_TEXELS * c);
    }
}

/* The node's triangles from its deformed vertices, widening the frame's bounds. */
static void gather_triangles(const scene_mesh *mesh, uint32_t first, const deform_scratch *s,
                             int skinned, float node_det, int tangent_deltas,
                             pf_scene_frame *frame)
{
    static const int straight[3] = {0, 1, 2}, swapped[3] = {0, 2, 1};
    const scene_deform_mesh *deform = mesh->deform;
    for (uint32_t t = 0; t < mesh->triangle_count; t++) {
        const uint32_t *vertex = deform->corner_vertex + 3 * (size_t)t;
        /* glTF §3.7.4: a mirroring transform reverses the winding (skinned: the first
         * corner's blended matrix decides for its triangle). */
        float det = skinned ? det3(s->matrix[vertex[0]]) : node_det;
        const int *order = det < 0.0f ? swapped : straight;
        size_t at = 3 * ((size_t)first + t);
        for (int c = 0; c < 3; c++) {
            uint32_t v = vertex[order[c]];
            memcpy(frame->vertices[at + c], s->position[v], 3 * sizeof(float));
            frame->vertices[at + c][3] = 0.0f;
            memcpy(frame->normals[at + c], s->normal[v], 3 * sizeof(float));
            frame->normals[at + c][3] = 0.0f;
        }
        scene_finish_triangle(frame, (size_t)first + t);
        if (frame->corners)
            gather_corners(mesh, t, vertex, order, det, s, tangent_deltas,
                           frame->corners + 3 * PF_CORNER_TEXELS * ((size_t)first + t));
    }
}

pf_status scene_deform_nodes(const pf_scene *scene, double time_seconds,
                             const float (*world)[16], pf_scene_frame *frame, pf_deform_fn fn,
                             void *user, pf_deform_report *report, pf_error *err)
{
    memset(report, 0, sizeof *report);
    if (!fn)
        fn = pf_deform_vertices_host;
    uint32_t most_joints = 0, most_targets = 0;
    for (uint32_t k = 0; k < scene->skin_count; k++)
        if (scene->skins[k].joint_count > most_joints)
            most_joints = scene->skins[k].joint_count;
    for (uint32_t m = 0; m < scene->mesh_count; m++)
        if (scene->meshes[m].deform && scene->meshes[m].deform->target_count > most_targets)
            most_targets = scene->meshes[m].deform->target_count;
    deform_scratch scratch = {0};
    float(*joints)[12] = malloc(((size_t)most_joints + 1) * sizeof *joints);
    pf_status status = joints ? PF_OK
                              : pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory for %u joints",
                                             scene->path, most_joints);
    for (uint32_t k = 0; k < scene->order_count && !status; k++) {
        uint32_t index = scene->order[k];
        const scene_node *node = &scene->nodes[index];
        if (!node->deforms)
            continue;
        const scene_mesh *mesh = &scene->meshes[node->mesh];
        const scene_deform_mesh *deform = mesh->deform;
        if (!scratch_reserve(&scratch, deform->vertex_count, most_targets)) {
            status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory deforming %u vertices",
                                  scene->path, deform->vertex_count);
            break;
        }
        if (deform->target_count > 0)
            node_weights(scene, index, time_seconds, scratch.weights);
        else
            scratch.weights[0] = 0.0f;
        int skinned = node->skin != SCENE_NONE && deform->influences > 0;
        float node_det = 1.0f;
        pf_deform_node in = {deform->vertex_count,
                             deform->target_count,
                             skinned ? deform->influences : 0,
                             1,
                             (const float(*)[3])deform->positions,
                             (const float(*)[3])deform->normals,
                             deform->target_positions,
                             deform->target_normals,
                             deform->target_tangents,
                             scratch.weights,
                             (const uint16_t(*)[PF_DEFORM_MAX_INFLUENCES])deform->joints,
                             (const float(*)[PF_DEFORM_MAX_INFLUENCES])deform->weights,
                             (const float(*)[12])joints,
                             scene->texture_set,
                             index};
        if (skinned) {
            /* glTF §3.7.3.3: only the joints place a skinned mesh, not its node. */
            joint_matrices(&scene->skins[node->skin], world, joints);
            in.matrix_count = scene->skins[node->skin].joint_count;
        } else {
            for (int column = 0; column < 4; column++)
                memcpy(joints[0] + 3 * column, world[index] + 4 * column, 3 * sizeof(float));
            node_det = det3(joints[0]);
        }
        pf_deform_vertices out = {scratch.position, scratch.normal, scratch.tangent,
                                  scratch.matrix};
        status = fn(user, &in, &out, err);
        if (status != PF_OK)
            break;
        gather_triangles(mesh, node->first_triangle, &scratch, skinned, node_det,
                         deform->target_tangents != NULL, frame);
        report->skinned_meshes += skinned;
        report->morphed_meshes += deform->target_count > 0;
        report->vertices += deform->vertex_count;
    }
    free(joints);
    scratch_free(&scratch);
    return status;
}
