/*
 * The public side of core/scene: loading by extension, finalising what a
 * loader produced (hierarchy flags, counts, default camera), and evaluating a
 * frame: sample channels → compose the hierarchy → flat world-space arrays.
 * Eval only reads the scene, so several threads may evaluate one scene at once.
 */
#include "scene_internal.h"

#include <errno.h>
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

/* Vertical fov of the default camera (no camera in the file): 45°, the usual
 * viewer default. */
#define DEFAULT_CAMERA_YFOV 0.78539816f
/* Default camera near plane as a fraction of its distance to the scene centre. */
#define DEFAULT_CAMERA_NEAR_FRACTION 1e-3f

void scene_warn_once(pf_scene *scene, const char *key, const char *format, ...)
{
    for (uint32_t k = 0; k < scene->warned_count; k++)
        if (strcmp(scene->warned[k], key) == 0)
            return;
    char **grown = realloc(scene->warned, (scene->warned_count + 1) * sizeof *grown);
    char *copy = strdup(key);
    if (grown)
        scene->warned = grown;
    if (grown && copy)
        scene->warned[scene->warned_count++] = copy;
    else
        free(copy);
    char message[PF_ERROR_MESSAGE_MAX];
    va_list args;
    va_start(args, format);
    vsnprintf(message, sizeof message, format, args);
    va_end(args);
    pf_log(PF_LOG_WARN, "%s", message);
}

pf_status scene_read_file(const char *path, char **out, size_t *size, pf_error *err)
{
    struct stat info;
    if (stat(path, &info) != 0)
        return pf_error_set(err, PF_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    if (!S_ISREG(info.st_mode))
        return pf_error_set(err, PF_ERR_IO, "%s: not a regular file", path);
    FILE *file = fopen(path, "rb");
    if (!file)
        return pf_error_set(err, PF_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    size_t expected = (size_t)info.st_size;
    char *data = malloc(expected + 1);
    if (!data) {
        fclose(file);
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory for %zu bytes", path, expected);
    }
    size_t read = fread(data, 1, expected, file);
    int failed = ferror(file);
    fclose(file);
    if (failed) {
        free(data);
        return pf_error_set(err, PF_ERR_IO, "%s: read error", path);
    }
    data[read] = 0;
    *out = data;
    *size = read;
    return PF_OK;
}

static int has_extension(const char *path, const char *extension)
{
    size_t length = strlen(path), extension_length = strlen(extension);
    return length >= extension_length &&
           strcasecmp(path + length - extension_length, extension) == 0;
}

pf_status pf_scene_load(const char *path, pf_scene **out, pf_error *err)
{
    return pf_scene_load_with(path, NULL, out, err);
}

pf_status pf_scene_load_with(const char *path, const pf_scene_load_options *options,
                             pf_scene **out, pf_error *err)
{
    *out = NULL;
    if (!path)
        return pf_error_set(err, PF_ERR_INVALID, "pf_scene_load: path is NULL");
    int is_gltf = has_extension(path, ".gltf"), is_glb = has_extension(path, ".glb");
    int is_obj = has_extension(path, ".obj");
    if (!is_gltf && !is_glb && !is_obj)
        return pf_error_set(err, PF_ERR_UNSUPPORTED,
                            "%s: unknown scene file extension (expected .gltf, .glb or .obj)",
                            path);
    static atomic_uint_fast64_t loads;
    pf_scene *scene = calloc(1, sizeof *scene);
    if (scene)
        scene->texture_set = atomic_fetch_add(&loads, 1) + 1;
    if (!scene)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", path);
    scene->path = strdup(path);
    scene->camera_node = SCENE_NONE;
    scene->allow_outside_dir = options && options->allow_outside_scene_dir;
    scene->animation = SCENE_NONE;
    scene->variant = SCENE_NONE;
    if (options && options->animation)
        scene->animation_choice = strdup(options->animation);
    if (options && options->material_variant)
        scene->variant_choice = strdup(options->material_variant);
    pf_status status =
        scene->path && (!options || !options->animation || scene->animation_choice) &&
                (!options || !options->material_variant || scene->variant_choice)
            ? PF_OK
            : pf_error_set(err, PF_ERR_NOMEM, "out of memory");
    if (!status && scene->animation_choice && is_obj)
        status = pf_error_set(err, PF_ERR_INVALID, "%s: --animation '%s': an OBJ file has no "
                              "animations", path, scene->animation_choice);
    if (!status && scene->variant_choice && is_obj)
        status = pf_error_set(err, PF_ERR_INVALID, "%s: --variant '%s': an OBJ file has no "
                              "material variants", path, scene->variant_choice);
    if (!status)
        status = is_obj ? scene_load_obj(scene, err) : scene_load_gltf(scene, is_glb, err);
    if (!status)
        status = scene_finalize(scene, err);
    for (uint32_t k = 0; k < scene->warned_count; k++)
        free(scene->warned[k]);
    free(scene->warned);
    scene->warned = NULL;
    scene->warned_count = 0;
    if (status) {
        pf_scene_destroy(scene);
        return status;
    }
    *out = scene;
    return PF_OK;
}

void pf_scene_destroy(pf_scene *scene)
{
    if (!scene)
        return;
    for (uint32_t k = 0; k < scene->mesh_count; k++) {
        scene_deform_mesh_free(scene->meshes[k].deform);
        free(scene->meshes[k].positions);
        free(scene->meshes[k].normals);
        free(scene->meshes[k].corners);
        free(scene->meshes[k].materials);
    }
    for (uint32_t k = 0; k < scene->channel_count; k++) {
        free(scene->channels[k].times);
        free(scene->channels[k].values);
    }
    for (uint32_t k = 0; k < scene->skin_count; k++) {
        free(scene->skins[k].joints);
        free(scene->skins[k].inverse_bind);
    }
    free(scene->skins);
    for (uint32_t k = 0; k < scene->node_count; k++)
        free(scene->nodes[k].weights);
    for (uint32_t k = 0; k < scene->warned_count; k++)
        free(scene->warned[k]);
    free(scene->warned);
    free(scene->animation_choice);
    free(scene->variant_choice);
    free(scene->channels);
    free(scene->meshes);
    free(scene->materials);
    free(scene->textures);
    free(scene->texels);
    free(scene->cameras);
    free(scene->lights);
    free(scene->nodes);
    free(scene->order);
    free(scene->path);
    free(scene);
}

const pf_scene_info *pf_scene_get_info(const pf_scene *scene) { return &scene->info; }

double pf_scene_frame_time(const pf_scene *scene, int64_t frame)
{
    return (double)(frame - 1 + (int64_t)scene->info.frame_offset) / scene->info.fps;
}

void pf_camera_image_plane(const pf_camera *camera, uint32_t width, uint32_t height,
                           float *tan_half_x, float *tan_half_y)
{
    float aspect = 1.0f;
    if (width > 0 && height > 0)
        aspect = (float)width / (float)height;
    else if (camera->aspect > 0.0f)
        aspect = camera->aspect;
    if (camera->orthographic) {
        /* The larger magnification spans the image's longer side, as Blender's importer
         * (ortho_scale = 2 max(xmag, ymag), fitted automatically) and Cycles read the file:
         * the same view as the file's where the aspects agree. */
        float xmag = camera->aspect > 0.0f ? camera->ymag * camera->aspect : camera->ymag;
        float mag = xmag > camera->ymag ? xmag : camera->ymag;
        *tan_half_x = aspect >= 1.0f ? mag : mag * aspect;
        *tan_half_y = aspect >= 1.0f ? mag / aspect : mag;
        return;
    }
    *tan_half_y = tanf(0.5f * camera->yfov);
    *tan_half_x = *tan_half_y * aspect;
}

void pf_camera_ray(const pf_camera *camera, float tan_half_x, float tan_half_y, double ndc_x,
                   double ndc_y, double origin[3], double direction[3])
{
    double length = 0.0;
    for (int k = 0; k < 3; k++) {
        double x = ndc_x * tan_half_x * camera->right[k], y = ndc_y * tan_half_y * camera->up[k];
        /* Parallel rays start on the view's plane; a pinhole's leave its position. */
        origin[k] = camera->orthographic ? camera->position[k] + x + y : camera->position[k];
        direction[k] = camera->orthographic ? camera->forward[k] : camera->forward[k] + x + y;
        length += direction[k] * direction[k];
    }
    length = sqrt(length);
    for (int k = 0; k < 3; k++)
        direction[k] /= length;
}

pf_status scene_world_matrices(const pf_scene *scene, double time_seconds, float (**out)[16],
                               pf_error *err)
{
    uint32_t count = scene->node_count;
    float(*world)[16] = malloc(((size_t)count + 1) * sizeof *world);
    float(*trs)[10] = malloc(((size_t)count + 1) * sizeof *trs);
    if (!world || !trs) {
        free(world);
        free(trs);
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory evaluating nodes", scene->path);
    }
    for (uint32_t k = 0; k < count; k++) {
        memcpy(trs[k], scene->nodes[k].translation, 3 * sizeof(float));
        memcpy(trs[k] + 3, scene->nodes[k].rotation, 4 * sizeof(float));
        memcpy(trs[k] + 7, scene->nodes[k].scale, 3 * sizeof(float));
        scene_mat4_identity(world[k]);
    }
    static const uint32_t path_offset[] = {0, 3, 7};
    for (uint32_t c = 0; c < scene->channel_count; c++) {
        const scene_channel *channel = &scene->channels[c];
        if (channel->path <= SCENE_PATH_SCALE) /* weights are deform.c's */
            scene_channel_sample(channel, time_seconds,
                                 trs[channel->node] + path_offset[channel->path]);
    }
    for (uint32_t k = 0; k < scene->order_count; k++) {
        uint32_t index = scene->order[k];
        const scene_node *node = &scene->nodes[index];
        float local[16];
        if (node->has_matrix) {
            memcpy(local, node->matrix, sizeof local);
        } else {
            scene_quat_normalize(trs[index] + 3);
            scene_mat4_from_trs(trs[index], trs[index] + 3, trs[index] + 7, local);
        }
        if (node->parent == SCENE_NONE)
            memcpy(world[index], local, sizeof local);
        else
            scene_mat4_mul(world[node->parent], local, world[index]);
    }
    free(trs);
    *out = world;
    return PF_OK;
}

static void camera_from_matrix(const float world[16], const scene_camera_def *def,
                               pf_camera *camera)
{
    static const float origin[3] = {0, 0, 0}, minus_z[3] = {0, 0, -1}, plus_y[3] = {0, 1, 0};
    scene_mat4_point(world, origin, camera->position);
    scene_mat4_vector(world, minus_z, camera->forward);
    scene_mat4_vector(world, plus_y, camera->up);
    scene_vec3_normalize(camera->forward);
    /* Gram-Schmidt: a sheared or non-uniformly scaled camera node still yields an
     * orthonormal frame. */
    float along = camera->up[0] * camera->forward[0] + camera->up[1] * camera->forward[1] +
                  camera->up[2] * camera->forward[2];
    for (int k = 0; k < 3; k++)
        camera->up[k] -= along * camera->forward[k];
    scene_vec3_normalize(camera->up);
    scene_cross(camera->forward, camera->up, camera->right);
    camera->yfov = def->yfov;
    camera->aspect = def->aspect;
    camera->znear = def->znear;
    camera->zfar = def->zfar;
    camera->orthographic = def->orthographic;
    camera->ymag = def->ymag;
}

void scene_corner_texels(const float corner[SCENE_CORNER_FLOATS], const float tangent[3],
                         float det, float (*texels)[4])
{
    memcpy(texels[0], corner, 4 * sizeof(float));
    memcpy(texels[1], corner + 4, 4 * sizeof(float));
    memcpy(texels[2], tangent, 3 * sizeof(float));
    float length = scene_vec3_normalize(texels[2]);
    if (!(length > 0.0f) || !isfinite(length))
        memset(texels[2], 0, 3 * sizeof(float));
    texels[2][3] = det < 0.0f ? -corner[11] : corner[11];
}

void scene_finish_triangle(pf_scene_frame *frame, size_t t)
{
    const float *v = frame->vertices[3 * t];
    for (int c = 0; c < 3; c++)
        for (int axis = 0; axis < 3; axis++) {
            frame->bounds_min[axis] = fminf(frame->bounds_min[axis], v[4 * c + axis]);
            frame->bounds_max[axis] = fmaxf(frame->bounds_max[axis], v[4 * c + axis]);
        }
    float geometric[3];
    scene_triangle_normal(v, v + 4, v + 8, geometric);
    for (int c = 0; c < 3; c++) {
        float *normal = frame->normals[3 * t + c];
        float length = scene_vec3_normalize(normal);
        /* A zero (none in the file) or degenerate normal falls back to the face normal. */
        if (!(length > 0.0f) || !isfinite(length))
            memcpy(normal, geometric, sizeof geometric);
    }
}

/* Triangle t's corners in world space (PF_CORNER_TEXELS texels each): the tangent turns
 * with the node. */
static void flatten_corners(const scene_mesh *mesh, uint32_t t, const float world[16],
                            float det, const int corner_order[3], float (*out)[4])
{
    for (int c = 0; c < 3; c++) {
        float defaults[SCENE_CORNER_FLOATS], tangent[3];
        scene_corner_defaults(defaults);
        const float *corner = mesh->corners
                                  ? mesh->corners[t] + SCENE_CORNER_FLOATS * corner_order[c]
                                  : defaults;
        scene_mat4_vector(world, corner + 8, tangent);
        scene_corner_texels(corner, tangent, det, out + PF_CORNER_TEXELS * c);
    }
}

/* Fills the triangle arrays for every mesh node, in order; a deforming node's vertices and
 * normals are left zero (and out of the bounds) for scene_deform_nodes. */
static void flatten_triangles(const pf_scene *scene, const float (*world)[16],
                              pf_scene_frame *out)
{
    uint32_t next = 0;
    for (uint32_t k = 0; k < scene->order_count; k++) {
        uint32_t index = scene->order[k];
        const scene_node *node = &scene->nodes[index];
        if (node->mesh == SCENE_NONE)
            continue;
        const scene_mesh *mesh = &scene->meshes[node->mesh];
        if (node->deforms) {
            size_t corners = 3 * (size_t)mesh->triangle_count;
            memset(out->vertices + 3 * (size_t)next, 0, corners * sizeof *out->vertices);
            memset(out->normals + 3 * (size_t)next, 0, corners * sizeof *out->normals);
            for (uint32_t t = 0; t < mesh->triangle_count; t++) {
                out->triangle_material[next + t] = mesh->materials[t];
                out->triangle_node[next + t] = index;
            }
            next += mesh->triangle_count;
            continue;
        }
        float normal_matrix[9];
        float det = scene_mat4_normal_matrix(world[index], normal_matrix);
        /* glTF §3.7.4: a mirroring transform reverses the winding; swapping two
         * corners keeps the front face (and emission side) where the file meant it. */
        static const int straight[3] = {0, 1, 2}, swapped[3] = {0, 2, 1};
        const int *corner_order = det < 0.0f ? swapped : straight;
        for (uint32_t t = 0; t < mesh->triangle_count; t++, next++) {
            for (int c = 0; c < 3; c++) {
                int source = corner_order[c];
                float *vertex = out->vertices[3 * (size_t)next + c];
                scene_mat4_point(world[index], mesh->positions[t] + 3 * source, vertex);
                vertex[3] = 0.0f;
                scene_mat3_vector(normal_matrix, mesh->normals[t] + 3 * source,
                                  out->normals[3 * (size_t)next + c]);
                out->normals[3 * (size_t)next + c][3] = 0.0f;
            }
            scene_finish_triangle(out, next);
            out->triangle_material[next] = mesh->materials[t];
            out->triangle_node[next] = index;
            if (out->corners)
                flatten_corners(mesh, t, world[index], det, corner_order,
                                out->corners + 3 * PF_CORNER_TEXELS * (size_t)next);
        }
    }
}

/* A frame with no triangle has the zero box: an empty bounds box stays inverted until then. */
static void close_bounds(pf_scene_frame *frame)
{
    if (frame->triangle_count == 0 || frame->bounds_min[0] > frame->bounds_max[0])
        for (int axis = 0; axis < 3; axis++)
            frame->bounds_min[axis] = frame->bounds_max[axis] = 0.0f;
}

/* Everything but the deforming nodes' vertices and normals, with the world matrices it used
 * (*world_out, when not NULL: the caller frees them). */
static pf_status eval_rigid(const pf_scene *scene, double time_seconds, pf_scene_frame *out,
                            float (**world_out)[16], pf_error *err)
{
    memset(out, 0, sizeof *out);
    if (!isfinite(time_seconds))
        return pf_error_set(err, PF_ERR_INVALID, "%s: eval time %g is not finite", scene->path,
                            time_seconds);
    float(*world)[16] = NULL;
    pf_status status = scene_world_matrices(scene, time_seconds, &world, err);
    if (status)
        return status;
    size_t triangles = scene->info.triangle_count;
    out->triangle_count = scene->info.triangle_count;
    out->vertices = malloc(3 * triangles * sizeof *out->vertices);
    out->normals = malloc(3 * triangles * sizeof *out->normals);
    out->triangle_material = malloc(triangles * sizeof *out->triangle_material);
    out->triangle_node = malloc(triangles * sizeof *out->triangle_node);
    out->material_count = scene->material_count;
    out->materials = malloc(((size_t)scene->material_count + 1) * sizeof *out->materials);
    out->light_count = scene->info.light_count;
    out->lights = calloc((size_t)scene->info.light_count + 1, sizeof *out->lights);
    if (scene->frame_corners)
        out->corners = malloc(3 * PF_CORNER_TEXELS * triangles * sizeof *out->corners);
    out->texture_set = scene->texture_set;
    out->texture_count = scene->texture_count;
    out->textures = scene->textures;
    out->texel_count = scene->texel_count;
    out->texels = scene->texels;
    if (!out->vertices || !out->normals || !out->triangle_material || !out->triangle_node ||
        !out->materials || !out->lights || (scene->frame_corners && !out->corners)) {
        free(world);
        pf_scene_frame_free(out);
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory for %zu triangles",
                            scene->path, triangles);
    }
    memcpy(out->materials, scene->materials, scene->material_count * sizeof *out->materials);
    out->emissive_triangle_count = scene->info.emissive_triangle_count;
    for (int axis = 0; axis < 3; axis++) {
        out->bounds_min[axis] = INFINITY;
        out->bounds_max[axis] = -INFINITY;
    }
    flatten_triangles(scene, (const float(*)[16])world, out);
    /* With deforming nodes the box stays open (inverted if nothing rigid) for
     * pf_scene_deform to widen and close. */
    if (scene->info.deformed_node_count == 0)
        close_bounds(out);

    uint32_t light = 0;
    out->camera = scene->default_camera;
    for (uint32_t k = 0; k < scene->order_count; k++) {
        uint32_t index = scene->order[k];
        const scene_node *node = &scene->nodes[index];
        if ((int32_t)index == scene->camera_node)
            camera_from_matrix(world[index], &scene->cameras[node->camera], &out->camera);
        if (node->light == SCENE_NONE)
            continue;
        static const float origin[3] = {0, 0, 0}, minus_z[3] = {0, 0, -1};
        const scene_light_def *def = &scene->lights[node->light];
        pf_light *target = &out->lights[light++];
        scene_mat4_point(world[index], origin, target->position);
        /* KHR_lights_punctual: spot and directional lights shine along the node's -Z. */
        scene_mat4_vector(world[index], minus_z, target->direction);
        scene_vec3_normalize(target->direction);
        target->kind = def->kind;
        target->range = def->range;
        memcpy(target->intensity, def->intensity, sizeof target->intensity);
        target->cos_inner_cone = def->cos_inner_cone;
        target->cos_outer_cone = def->cos_outer_cone;
    }
    if (world_out)
        *world_out = world;
    else
        free(world);
    return PF_OK;
}

pf_status pf_scene_eval_rigid(const pf_scene *scene, double time_seconds, pf_scene_frame *out,
                              pf_error *err)
{
    return eval_rigid(scene, time_seconds, out, NULL, err);
}

pf_status pf_scene_deform(const pf_scene *scene, double time_seconds, pf_scene_frame *frame,
                          pf_deform_report *report, pf_error *err)
{
    return pf_scene_deform_with(scene, time_seconds, frame, NULL, NULL, report, err);
}

pf_status pf_scene_deform_with(const pf_scene *scene, double time_seconds, pf_scene_frame *frame,
                               pf_deform_fn fn, void *user, pf_deform_report *report,
                               pf_error *err)
{
    memset(report, 0, sizeof *report);
    if (scene->info.deformed_node_count == 0)
        return PF_OK;
    if (!isfinite(time_seconds))
        return pf_error_set(err, PF_ERR_INVALID, "%s: eval time %g is not finite", scene->path,
                            time_seconds);
    if (frame->triangle_count != scene->info.triangle_count)
        return pf_error_set(err, PF_ERR_INVALID, "%s: deform: the frame has %u triangles, the "
                            "scene %u", scene->path, frame->triangle_count,
                            scene->info.triangle_count);
    float(*world)[16] = NULL;
    pf_status status = scene_world_matrices(scene, time_seconds, &world, err);
    if (status)
        return status;
    status = scene_deform_nodes(scene, time_seconds, (const float(*)[16])world, frame, fn, user,
                                report, err);
    close_bounds(frame);
    free(world);
    return status;
}

pf_status pf_scene_eval(const pf_scene *scene, double time_seconds, pf_scene_frame *out,
                        pf_error *err)
{
    float(*world)[16] = NULL;
    pf_status status = eval_rigid(scene, time_seconds, out, &world, err);
    if (status || scene->info.deformed_node_count == 0) {
        free(world);
        return status;
    }
    pf_deform_report report;
    status = scene_deform_nodes(scene, time_seconds, (const float(*)[16])world, out, NULL, NULL,
                                &report, err);
    close_bounds(out);
    free(world);
    if (status)
        pf_scene_frame_free(out);
    return status;
}

void pf_scene_frame_free(pf_scene_frame *frame)
{
    if (!frame)
        return;
    free(frame->vertices);
    free(frame->normals);
    free(frame->corners);
    free(frame->triangle_material);
    free(frame->triangle_node);
    free(frame->materials);
    free(frame->lights);
    memset(frame, 0, sizeof *frame);
}

/* A camera looking down -Z at the scene's bounds at time 0, far enough back
 * that the bounding sphere fits the vertical field of view. */
static pf_status make_default_camera(pf_scene *scene, pf_error *err)
{
    pf_scene_frame frame;
    pf_status status = pf_scene_eval(scene, 0.0, &frame, err);
    if (status)
        return status;
    float center[3], radius_squared = 0.0f;
    for (int axis = 0; axis < 3; axis++) {
        center[axis] = 0.5f * (frame.bounds_min[axis] + frame.bounds_max[axis]);
        float half = 0.5f * (frame.bounds_max[axis] - frame.bounds_min[axis]);
        radius_squared += half * half;
    }
    pf_scene_frame_free(&frame);
    float radius = sqrtf(radius_squared);
    if (!(radius > 0.0f))
        radius = 1.0f;
    float distance = radius / sinf(0.5f * DEFAULT_CAMERA_YFOV);
    pf_camera *camera = &scene->default_camera;
    memset(camera, 0, sizeof *camera);
    camera->position[0] = center[0];
    camera->position[1] = center[1];
    camera->position[2] = center[2] + distance;
    camera->forward[2] = -1.0f;
    camera->up[1] = 1.0f;
    camera->right[0] = 1.0f;
    camera->yfov = DEFAULT_CAMERA_YFOV;
    camera->znear = distance * DEFAULT_CAMERA_NEAR_FRACTION;
    pf_log(PF_LOG_WARN, "%s: no camera: using a default camera framing the scene bounds",
           scene->path);
    return PF_OK;
}

/*
 * Whether node's mesh deforms each frame (a skin with JOINTS_0, or morph targets) and
 * whether that changes over time: a joint (or an ancestor of one) is animated, or the
 * node's weights are. Joints come after their skinned node in no particular order, so
 * their `animated` flags are taken from the channels and the hierarchy directly.
 */
static int node_or_ancestor_has_channel(const pf_scene *scene, uint32_t index)
{
    for (int32_t at = (int32_t)index; at != SCENE_NONE; at = scene->nodes[at].parent)
        if (scene->nodes[at].has_channel)
            return 1;
    return 0;
}

static void mark_deformation(pf_scene *scene, scene_node *node)
{
    const scene_deform_mesh *deform = scene->meshes[node->mesh].deform;
    int skinned = deform && node->skin != SCENE_NONE && deform->influences > 0;
    int morphed = deform && deform->target_count > 0;
    node->deforms = skinned || morphed;
    node->deform_animated = morphed && node->has_weights_channel;
    if (skinned) {
        const scene_skin *skin = &scene->skins[node->skin];
        for (uint32_t j = 0; j < skin->joint_count && !node->deform_animated; j++)
            node->deform_animated = node_or_ancestor_has_channel(scene, skin->joints[j]);
    }
}

pf_status scene_finalize(pf_scene *scene, pf_error *err)
{
    pf_scene_info *info = &scene->info;
    uint64_t triangles = 0, emissive = 0;
    uint32_t lights = 0;
    int *material_used = calloc((size_t)scene->material_count + 1, sizeof *material_used);
    if (!material_used)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", scene->path);
    for (uint32_t m = 0; m < scene->mesh_count; m++) {
        scene_mesh *mesh = &scene->meshes[m];
        mesh->emissive_count = 0;
        for (uint32_t t = 0; t < mesh->triangle_count; t++) {
            const float *emission = scene->materials[mesh->materials[t]].emission;
            mesh->emissive_count += emission[0] > 0 || emission[1] > 0 || emission[2] > 0;
        }
    }
    for (uint32_t k = 0; k < scene->order_count; k++) {
        scene_node *node = &scene->nodes[scene->order[k]];
        node->animated = node->has_channel ||
                         (node->parent != SCENE_NONE && scene->nodes[node->parent].animated);
        if (node->mesh != SCENE_NONE) {
            const scene_mesh *mesh = &scene->meshes[node->mesh];
            node->first_triangle = (uint32_t)(triangles < UINT32_MAX ? triangles : UINT32_MAX);
            mark_deformation(scene, node);
            if (node->deforms) {
                info->deformed_node_count++;
                info->deformed_vertex_count += mesh->deform->vertex_count;
                info->deformation_animated |= node->deform_animated;
                info->geometry_animated |= node->deform_animated && mesh->triangle_count > 0;
            }
            triangles += mesh->triangle_count;
            emissive += mesh->emissive_count;
            for (uint32_t t = 0; t < mesh->triangle_count; t++)
                material_used[mesh->materials[t]] = 1;
            info->geometry_animated |= node->animated && mesh->triangle_count > 0;
        }
        if (node->light != SCENE_NONE) {
            lights++;
            info->lights_animated |= node->animated;
        }
        if (node->camera != SCENE_NONE && scene->camera_node == SCENE_NONE) {
            scene->camera_node = (int32_t)scene->order[k];
            info->camera_animated = node->animated;
        }
    }
    for (uint32_t m = 0; m < scene->material_count; m++)
        if (material_used[m] && scene->materials[m].kind != PF_MATERIAL_LAMBERT)
            info->has_specular = 1;
    scene->frame_corners = scene->texture_count > 0;
    for (uint32_t m = 0; m < scene->mesh_count; m++)
        scene->frame_corners |= scene->meshes[m].has_color;
    info->texture_count = scene->texture_count;
    info->texel_count = scene->texel_count;
    info->skin_count = scene->skin_count;
    free(material_used);
    if (triangles == 0)
        return pf_error_set(err, PF_ERR_FORMAT, "%s: no triangles in the scene", scene->path);
    /* Three vertices of 16 bytes per triangle must stay indexable by uint32. */
    if (triangles > UINT32_MAX / 3)
        return pf_error_set(err, PF_ERR_LIMIT, "%s: %llu triangles is more than supported",
                            scene->path, (unsigned long long)triangles);

    info->fps = scene->fps > 0.0 ? scene->fps : SCENE_DEFAULT_FPS;
    double duration = 0.0;
    for (uint32_t c = 0; c < scene->channel_count; c++) {
        const scene_channel *channel = &scene->channels[c];
        duration = fmax(duration, (double)channel->times[channel->key_count - 1]);
    }
    /* Frame numbers must stay representable; an animation this long is a broken file. */
    if (!scene->file_frame_count && duration * info->fps >= (double)(UINT32_MAX / 2))
        return pf_error_set(err, PF_ERR_FORMAT,
                            "%s: animations: last key at %g s gives more frames than supported",
                            scene->path, duration);
    info->path = scene->path;
    info->node_count = scene->node_count;
    info->mesh_count = scene->mesh_count;
    info->material_count = scene->material_count;
    info->light_count = lights;
    info->animation_count = scene->animation_count;
    info->animation = scene->animation;
    info->material_variant_count = scene->variant_count;
    info->material_variant = scene->variant;
    info->triangle_count = (uint32_t)triangles;
    info->emissive_triangle_count = (uint32_t)emissive;
    info->has_emissive = emissive > 0;
    info->duration_seconds = duration;
    info->frame_offset = scene->frame_offset;
    /* The last key's frame: frames 1 .. that (at time 0 a Blender file has frame 0). */
    uint32_t last_key_frame = (uint32_t)llround(duration * info->fps) + 1 - scene->frame_offset;
    info->frame_count = scene->file_frame_count ? scene->file_frame_count
                                                : (last_key_frame > 1 ? last_key_frame : 1);
    info->has_camera = scene->camera_node != SCENE_NONE;
    if (!info->has_camera)
        return make_default_camera(scene, err);
    return PF_OK;
}
