/*
 * Wavefront OBJ + MTL loader (the secondary format, DESIGN.md §5). Each `o` or
 * `g` group becomes one node (identity transform) with one mesh; polygons are
 * fan-triangulated; negative (relative) indices are resolved. OBJ has no
 * cameras, lights or animation, so the scene gets the default camera.
 *
 * MTL → pf_material (the nearest of our three kinds):
 *   Ke                          → emission (radiance, W/(sr·m²))
 *   illum 4, 6, 7 or 9, d < 1, Tr > 0
 *                               → glass, ior = Ni (1.5 if absent), tint Tf (else white)
 *   illum 3, 5 or 8             → mirror, tint Ks (else white)
 *   otherwise                   → Lambert, albedo Kd (default 0.8)
 * Texture maps (map_*, bump, disp, refl) are not sampled: one warning.
 */
#include "scene_internal.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Default diffuse reflectance, also used for faces without a material. */
#define OBJ_DEFAULT_ALBEDO 0.8f
#define OBJ_DEFAULT_IOR 1.5f
/* Longest line element name kept for messages and material names. */
#define OBJ_NAME_MAX 128

typedef struct obj_material {
    char name[OBJ_NAME_MAX];
    pf_material material;
} obj_material;

typedef struct float_list {
    float *data;
    size_t count, capacity; /* in floats */
} float_list;

typedef struct obj_state {
    pf_scene *scene;
    float_list positions, normals;
    obj_material *materials;
    uint32_t material_count;
    int32_t default_material; /* index into materials, SCENE_NONE until needed */
    uint32_t current_material;
    int has_current_material;
} obj_state;

static int float_list_push(float_list *list, const float *values, size_t count)
{
    if (list->count + count > list->capacity) {
        size_t capacity = list->capacity ? list->capacity * 2 : 256;
        while (capacity < list->count + count)
            capacity *= 2;
        float *grown = realloc(list->data, capacity * sizeof *grown);
        if (!grown)
            return 0;
        list->data = grown;
        list->capacity = capacity;
    }
    memcpy(list->data + list->count, values, count * sizeof *values);
    list->count += count;
    return 1;
}

/*
 * Reads up to `count` floats after the keyword; returns how many were read, or
 * -1 when anything but white space follows them (e.g. "Kd 0.5 oops").
 */
static int parse_floats(const char *text, float *out, int count, int *nonfinite)
{
    int read = 0;
    *nonfinite = 0;
    while (read < count) {
        char *end;
        float value = strtof(text, &end);
        if (end == text)
            break;
        if (!isfinite(value))
            *nonfinite = 1;
        out[read++] = value;
        text = end;
    }
    while (isspace((unsigned char)*text))
        text++;
    return *text ? -1 : read;
}

/* Trims leading/trailing white space in place; returns the start. */
static char *trim(char *text)
{
    while (isspace((unsigned char)*text))
        text++;
    size_t length = strlen(text);
    while (length > 0 && isspace((unsigned char)text[length - 1]))
        text[--length] = 0;
    return text;
}

static char *next_line(char **cursor)
{
    char *line = *cursor;
    if (!*line)
        return NULL;
    char *end = strchr(line, '\n');
    if (end) {
        *end = 0;
        *cursor = end + 1;
    } else {
        *cursor = line + strlen(line);
    }
    return line;
}

static pf_status add_material(obj_state *state, const char *name, obj_material **out,
                              pf_error *err)
{
    obj_material *grown =
        realloc(state->materials, (state->material_count + 1) * sizeof *state->materials);
    if (!grown)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", state->scene->path);
    state->materials = grown;
    obj_material *material = &grown[state->material_count++];
    memset(material, 0, sizeof *material);
    snprintf(material->name, sizeof material->name, "%s", name);
    material->material =
        pf_material_lambert(OBJ_DEFAULT_ALBEDO, OBJ_DEFAULT_ALBEDO, OBJ_DEFAULT_ALBEDO);
    *out = material;
    return PF_OK;
}

/* Properties of one newmtl block, resolved into a pf_material when it ends. */
typedef struct mtl_block {
    obj_material *target;
    float kd[3], ks[3], ke[3], tf[3];
    int has_kd, has_ks, has_tf;
    int illum;
    float ni, dissolve;
    int has_ni;
} mtl_block;

static void mtl_block_finish(const mtl_block *block)
{
    if (!block->target)
        return;
    pf_material *material = &block->target->material;
    int glass = block->illum == 4 || block->illum == 6 || block->illum == 7 ||
                block->illum == 9 || block->dissolve < 1.0f;
    int mirror = block->illum == 3 || block->illum == 5 || block->illum == 8;
    if (glass) {
        const float *tint = block->has_tf ? block->tf : (const float[3]){1, 1, 1};
        float ior = block->has_ni && block->ni >= 1.0f ? block->ni : OBJ_DEFAULT_IOR;
        *material = pf_material_glass(ior, tint[0], tint[1], tint[2]);
    } else if (mirror) {
        const float *tint = block->has_ks ? block->ks : (const float[3]){1, 1, 1};
        *material = pf_material_mirror(tint[0], tint[1], tint[2]);
    } else if (block->has_kd) {
        *material = pf_material_lambert(block->kd[0], block->kd[1], block->kd[2]);
    }
    memcpy(material->emission, block->ke, sizeof material->emission);
}

static pf_status load_mtl(obj_state *state, const char *mtl_path, pf_error *err)
{
    pf_scene *scene = state->scene;
    char *text;
    size_t size;
    pf_error file_error;
    if (scene_read_file(mtl_path, &text, &size, &file_error) != PF_OK) {
        scene_warn_once(scene, "missing mtllib",
                        "%s: mtllib %s cannot be read: default materials used", scene->path,
                        mtl_path);
        return PF_OK;
    }
    pf_status status = PF_OK;
    mtl_block block = {.dissolve = 1.0f};
    char *cursor = text;
    char *line;
    uint32_t line_number = 0;
    while (!status && (line = next_line(&cursor)) != NULL) {
        line_number++;
        line = trim(line);
        if (!*line || *line == '#')
            continue;
        char keyword[32];
        int consumed = 0;
        if (sscanf(line, "%31s%n", keyword, &consumed) != 1)
            continue;
        const char *rest = line + consumed;
        float values[3];
        int nonfinite;
        if (strcmp(keyword, "newmtl") == 0) {
            mtl_block_finish(&block);
            memset(&block, 0, sizeof block);
            block.dissolve = 1.0f;
            char *name = trim((char *)rest);
            status = add_material(state, name, &block.target, err);
        } else if (!block.target) {
            continue;
        } else if (strcmp(keyword, "Kd") == 0 || strcmp(keyword, "Ks") == 0 ||
                   strcmp(keyword, "Ke") == 0 || strcmp(keyword, "Tf") == 0) {
            int read = parse_floats(rest, values, 3, &nonfinite);
            if (read == 1)
                values[1] = values[2] = values[0];
            if ((read != 1 && read != 3) || nonfinite || values[0] < 0 || values[1] < 0 ||
                values[2] < 0) {
                status = pf_error_set(err, PF_ERR_FORMAT,
                                      "%s: line %u: %s: expected 1 or 3 non-negative numbers",
                                      mtl_path, line_number, keyword);
                break;
            }
            float *target = keyword[1] == 'd' ? block.kd
                            : keyword[1] == 's' ? block.ks
                            : keyword[1] == 'e' ? block.ke
                                                : block.tf;
            memcpy(target, values, sizeof values);
            block.has_kd |= keyword[1] == 'd';
            block.has_ks |= keyword[1] == 's';
            block.has_tf |= keyword[1] == 'f';
        } else if (strcmp(keyword, "Ni") == 0 || strcmp(keyword, "d") == 0 ||
                   strcmp(keyword, "Tr") == 0 || strcmp(keyword, "illum") == 0) {
            if (parse_floats(rest, values, 1, &nonfinite) != 1 || nonfinite) {
                status = pf_error_set(err, PF_ERR_FORMAT, "%s: line %u: %s: expected a number",
                                      mtl_path, line_number, keyword);
                break;
            }
            if (keyword[0] == 'N') {
                block.ni = values[0];
                block.has_ni = 1;
            } else if (keyword[0] == 'd') {
                block.dissolve = values[0];
            } else if (keyword[0] == 'T') {
                block.dissolve = 1.0f - values[0];
            } else {
                block.illum = (int)values[0];
            }
        } else if (strncmp(keyword, "map_", 4) == 0 || strcmp(keyword, "bump") == 0 ||
                   strcmp(keyword, "disp") == 0 || strcmp(keyword, "refl") == 0) {
            scene_warn_once(scene, "textures",
                            "%s: line %u: texture maps are not supported: using the factors",
                            mtl_path, line_number);
        }
    }
    if (!status)
        mtl_block_finish(&block);
    free(text);
    return status;
}

static int32_t find_material(const obj_state *state, const char *name)
{
    for (uint32_t k = 0; k < state->material_count; k++)
        if (strcmp(state->materials[k].name, name) == 0)
            return (int32_t)k;
    return SCENE_NONE;
}

static pf_status current_material(obj_state *state, uint32_t *out, pf_error *err)
{
    if (state->has_current_material) {
        *out = state->current_material;
        return PF_OK;
    }
    if (state->default_material == SCENE_NONE) {
        obj_material *material;
        /* A name no usemtl can produce, so files cannot collide with it. */
        pf_status status = add_material(state, "\n(default)", &material, err);
        if (status)
            return status;
        state->default_material = (int32_t)(state->material_count - 1);
    }
    *out = (uint32_t)state->default_material;
    return PF_OK;
}

/* Starts a new object (node + mesh) unless the current one is still empty. */
static pf_status begin_object(pf_scene *scene, pf_error *err)
{
    if (scene->mesh_count > 0 && scene->meshes[scene->mesh_count - 1].triangle_count == 0)
        return PF_OK;
    scene_mesh *meshes = realloc(scene->meshes, (scene->mesh_count + 1) * sizeof *meshes);
    if (!meshes)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", scene->path);
    scene->meshes = meshes;
    memset(&meshes[scene->mesh_count++], 0, sizeof *meshes);
    return PF_OK;
}

/* Resolves a 1-based (or negative, relative) OBJ index against count entries. */
static int resolve_index(long value, size_t count, uint32_t *out)
{
    long resolved = value > 0 ? value - 1 : (long)count + value;
    if (value == 0 || resolved < 0 || (size_t)resolved >= count)
        return 0;
    *out = (uint32_t)resolved;
    return 1;
}

typedef struct face_corner {
    uint32_t position;
    uint32_t normal;
    int has_normal;
} face_corner;

static pf_status add_face(obj_state *state, const char *rest, uint32_t line_number,
                          pf_error *err)
{
    pf_scene *scene = state->scene;
    size_t position_count = state->positions.count / 3, normal_count = state->normals.count / 3;
    face_corner *corners = NULL;
    size_t corner_count = 0, corner_capacity = 0;
    pf_status status = PF_OK;
    const char *cursor = rest;
    while (!status) {
        while (isspace((unsigned char)*cursor))
            cursor++;
        if (!*cursor)
            break;
        face_corner corner = {0};
        char *end;
        long position = strtol(cursor, &end, 10);
        if (end == cursor) {
            status = pf_error_set(err, PF_ERR_FORMAT, "%s: line %u: f: bad vertex \"%.20s\"",
                                  scene->path, line_number, cursor);
            break;
        }
        if (!resolve_index(position, position_count, &corner.position)) {
            status = pf_error_set(err, PF_ERR_FORMAT,
                                  "%s: line %u: f: vertex index %ld out of range (%zu vertices)",
                                  scene->path, line_number, position, position_count);
            break;
        }
        cursor = end;
        if (*cursor == '/') {
            cursor++;
            strtol(cursor, &end, 10); /* texture coordinate: not used */
            cursor = end;
            if (*cursor == '/') {
                cursor++;
                long normal = strtol(cursor, &end, 10);
                if (end != cursor) {
                    if (!resolve_index(normal, normal_count, &corner.normal)) {
                        status = pf_error_set(
                            err, PF_ERR_FORMAT,
                            "%s: line %u: f: normal index %ld out of range (%zu normals)",
                            scene->path, line_number, normal, normal_count);
                        break;
                    }
                    corner.has_normal = 1;
                }
                cursor = end;
            }
        }
        if (*cursor && !isspace((unsigned char)*cursor)) {
            status = pf_error_set(err, PF_ERR_FORMAT, "%s: line %u: f: bad vertex \"%.20s\"",
                                  scene->path, line_number, cursor);
            break;
        }
        if (corner_count == corner_capacity) {
            corner_capacity = corner_capacity ? corner_capacity * 2 : 8;
            face_corner *grown = realloc(corners, corner_capacity * sizeof *grown);
            if (!grown) {
                status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", scene->path);
                break;
            }
            corners = grown;
        }
        corners[corner_count++] = corner;
    }
    if (!status && corner_count < 3)
        status = pf_error_set(err, PF_ERR_FORMAT, "%s: line %u: f: %zu vertices (need 3 or more)",
                              scene->path, line_number, corner_count);
    uint32_t material = 0;
    if (!status)
        status = current_material(state, &material, err);
    if (!status && scene->mesh_count == 0)
        status = begin_object(scene, err);
    if (status) {
        free(corners);
        return status;
    }
    scene_mesh *mesh = &scene->meshes[scene->mesh_count - 1];
    uint32_t added = (uint32_t)(corner_count - 2);
    uint32_t total = mesh->triangle_count + added;
    float(*positions)[9] = realloc(mesh->positions, total * sizeof *positions);
    if (positions)
        mesh->positions = positions;
    float(*normals)[9] = realloc(mesh->normals, total * sizeof *normals);
    if (normals)
        mesh->normals = normals;
    uint32_t *materials = realloc(mesh->materials, total * sizeof *materials);
    if (materials)
        mesh->materials = materials;
    if (!positions || !normals || !materials) {
        free(corners);
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", scene->path);
    }
    /* Fan triangulation (0, k, k+1): exact for the convex polygons OBJ exporters write. */
    for (uint32_t t = 0; t < added; t++) {
        const face_corner *triangle[3] = {&corners[0], &corners[t + 1], &corners[t + 2]};
        float *p = mesh->positions[mesh->triangle_count];
        float *n = mesh->normals[mesh->triangle_count];
        int all_normals = 1;
        for (int c = 0; c < 3; c++) {
            memcpy(p + 3 * c, state->positions.data + 3 * (size_t)triangle[c]->position,
                   3 * sizeof *p);
            all_normals &= triangle[c]->has_normal;
        }
        if (all_normals) {
            for (int c = 0; c < 3; c++)
                memcpy(n + 3 * c, state->normals.data + 3 * (size_t)triangle[c]->normal,
                       3 * sizeof *n);
        } else {
            scene_face_normals(p, n);
        }
        mesh->materials[mesh->triangle_count++] = material;
    }
    free(corners);
    return PF_OK;
}

static pf_status parse_obj(obj_state *state, char *text, pf_error *err)
{
    pf_scene *scene = state->scene;
    pf_status status = PF_OK;
    char *cursor = text;
    char *line;
    uint32_t line_number = 0;
    while (!status && (line = next_line(&cursor)) != NULL) {
        line_number++;
        line = trim(line);
        if (!*line || *line == '#')
            continue;
        char keyword[32];
        int consumed = 0;
        if (sscanf(line, "%31s%n", keyword, &consumed) != 1)
            continue;
        char *rest = line + consumed;
        float values[4];
        int nonfinite;
        if (strcmp(keyword, "v") == 0 || strcmp(keyword, "vn") == 0) {
            /* v may carry a fourth (w) coordinate, which is ignored. */
            int read = parse_floats(rest, values, keyword[1] ? 3 : 4, &nonfinite);
            if (read != 3 && !(read == 4 && !keyword[1]))
                status = pf_error_set(err, PF_ERR_FORMAT, "%s: line %u: %s: expected 3 numbers",
                                      scene->path, line_number, keyword);
            else if (nonfinite)
                status = pf_error_set(err, PF_ERR_FORMAT, "%s: line %u: %s: value is not finite",
                                      scene->path, line_number, keyword);
            else if (!float_list_push(keyword[1] ? &state->normals : &state->positions, values, 3))
                status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", scene->path);
        } else if (strcmp(keyword, "f") == 0) {
            status = add_face(state, rest, line_number, err);
        } else if (strcmp(keyword, "o") == 0 || strcmp(keyword, "g") == 0) {
            status = begin_object(scene, err);
        } else if (strcmp(keyword, "usemtl") == 0) {
            int32_t index = find_material(state, trim(rest));
            if (index == SCENE_NONE) {
                scene_warn_once(scene, "unknown usemtl",
                                "%s: line %u: usemtl %s: no such material: default used",
                                scene->path, line_number, trim(rest));
                state->has_current_material = 0;
            } else {
                state->current_material = (uint32_t)index;
                state->has_current_material = 1;
            }
        } else if (strcmp(keyword, "mtllib") == 0) {
            const char *name = trim(rest);
            const char *slash = strrchr(scene->path, '/');
            size_t directory_length = slash ? (size_t)(slash - scene->path) + 1 : 0;
            char *mtl_path = malloc(directory_length + strlen(name) + 1);
            if (!mtl_path)
                return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", scene->path);
            memcpy(mtl_path, scene->path, directory_length);
            strcpy(mtl_path + directory_length, name);
            if (!scene_path_allowed(scene, mtl_path)) {
                free(mtl_path);
                return pf_error_set(err, PF_ERR_INVALID,
                                    "%s: line %u: mtllib \"%s\" leads outside the scene's "
                                    "directory (after resolving symbolic links): refused "
                                    "(--allow-outside-scene-dir permits it)",
                                    scene->path, line_number, name);
            }
            status = load_mtl(state, mtl_path, err);
            if (status)
                pf_error_prefix(err, "%s: line %u: mtllib", scene->path, line_number);
            free(mtl_path);
        } else if (strcmp(keyword, "l") == 0 || strcmp(keyword, "p") == 0) {
            scene_warn_once(scene, "points and lines",
                            "%s: line %u: points/lines are not supported: skipped", scene->path,
                            line_number);
        } else if (strcmp(keyword, "vt") != 0 && strcmp(keyword, "s") != 0) {
            char key[64];
            snprintf(key, sizeof key, "obj %s", keyword);
            scene_warn_once(scene, key, "%s: line %u: OBJ statement \"%s\" is not supported: "
                            "ignored", scene->path, line_number, keyword);
        }
    }
    return status;
}

pf_status scene_load_obj(pf_scene *scene, pf_error *err)
{
    char *text;
    size_t size;
    pf_status status = scene_read_file(scene->path, &text, &size, err);
    if (status)
        return status;
    if (memchr(text, 0, size)) {
        free(text);
        return pf_error_set(err, PF_ERR_FORMAT, "%s: not a text OBJ file (binary data)",
                            scene->path);
    }
    obj_state state = {.scene = scene, .default_material = SCENE_NONE};
    status = parse_obj(&state, text, err);
    free(text);
    free(state.positions.data);
    free(state.normals.data);
    if (!status && state.material_count > 0) {
        scene->materials = malloc(state.material_count * sizeof *scene->materials);
        if (!scene->materials)
            status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", scene->path);
        for (uint32_t k = 0; !status && k < state.material_count; k++)
            scene->materials[k] = state.materials[k].material;
        if (!status)
            scene->material_count = state.material_count;
    }
    free(state.materials);
    if (status)
        return status;
    /* Drop a trailing empty object (a final `g` with no faces). */
    if (scene->mesh_count > 0 && scene->meshes[scene->mesh_count - 1].triangle_count == 0) {
        scene->mesh_count--;
    }
    scene->nodes = calloc((size_t)scene->mesh_count + 1, sizeof *scene->nodes);
    scene->order = calloc((size_t)scene->mesh_count + 1, sizeof *scene->order);
    if (!scene->nodes || !scene->order)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", scene->path);
    scene->node_count = scene->order_count = scene->mesh_count;
    for (uint32_t k = 0; k < scene->mesh_count; k++) {
        scene_node *node = &scene->nodes[k];
        node->rotation[3] = 1.0f;
        node->scale[0] = node->scale[1] = node->scale[2] = 1.0f;
        node->parent = node->camera = node->light = node->skin = SCENE_NONE;
        node->mesh = (int32_t)k;
        node->in_scene = 1;
        scene->order[k] = k;
    }
    scene->fps = SCENE_DEFAULT_FPS;
    return PF_OK;
}
