/*
 * pf_generate_scenes: writes the scenes photonfarm ships, as self-contained
 * glTF 2.0 files (the binary buffer is embedded as a base64 data: URI).
 *
 *   pf_generate_scenes OUTPUT_ROOT
 *
 * writes OUTPUT_ROOT/cornell/cornell.gltf (the classic Cornell box) and
 * OUTPUT_ROOT/cornell-moving/cornell-moving.gltf (the same box with a camera
 * move, a moving block and a moving point light, 24 frames at 24 fps).
 *
 * The output is byte-identical on every run (fixed formatting, no timestamps):
 * the committed files are checked against a fresh run by ctest
 * (scenes_generated_match), so edit this program, never the .gltf files.
 *
 * Standalone on purpose (libc + libm only): the scenes must not depend on the
 * importer they are used to test.
 */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/*
 * Geometry: "Cornell Box Data", Cornell University Program of Computer Graphics,
 * https://www.graphics.cornell.edu/online/box/data.html (millimetres; the
 * published frame has +y up and the camera looking along +z from z = -800, so
 * +x is on the viewer's left: the red wall at x ~ 556 appears on the left).
 */
#define MM_TO_M 0.001

/* Camera of the published data: focal length 0.035 m, film 0.025 m x 0.025 m. */
#define CORNELL_FOCAL_LENGTH_M 0.035
#define CORNELL_FILM_SIZE_M 0.025
static const double cornell_camera_mm[3] = {278.0, 273.0, -800.0};

/*
 * The published data has a hole in the ceiling for the light at y = 548.8; like
 * most renderings of the box we keep the ceiling whole and lower the light by a
 * tenth of a millimetre so the two never coincide.
 */
#define CORNELL_LIGHT_Y_MM 548.7

/*
 * Albedos and light radiance: the RGB reductions of the published spectral data
 * used by Benedikt Bitterli's "Rendering resources" Cornell box
 * (https://benedikt-bitterli.me/resources/, CC0), as in pbrt/Tungsten/Mitsuba.
 */
static const double albedo_white[3] = {0.725, 0.71, 0.68};
static const double albedo_red[3] = {0.63, 0.065, 0.05};
static const double albedo_green[3] = {0.14, 0.45, 0.091};
static const double light_radiance[3] = {17.0, 12.0, 4.0}; /* W/(sr·m²) */

/* Animated variant: 24 frames at 24 fps; frame f is sampled at (f - 1) / fps. */
#define ANIM_FRAMES 24
#define ANIM_FPS 24.0
#define ANIM_LAST_KEY_S ((ANIM_FRAMES - 1) / ANIM_FPS)
#define DEG_TO_RAD (3.14159265358979323846 / 180.0)

#define GLTF_FLOAT 5126
#define GLTF_UNSIGNED_SHORT 5123
#define GLTF_ARRAY_BUFFER 34962
#define GLTF_ELEMENT_ARRAY_BUFFER 34963

typedef struct quad_mm {
    double corner[4][3];
} quad_mm;

static const quad_mm floor_quads[] = {
    {{{552.8, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 559.2}, {549.6, 0.0, 559.2}}}};
static const quad_mm ceiling_quads[] = {
    {{{556.0, 548.8, 0.0}, {556.0, 548.8, 559.2}, {0.0, 548.8, 559.2}, {0.0, 548.8, 0.0}}}};
static const quad_mm back_wall_quads[] = {
    {{{549.6, 0.0, 559.2}, {0.0, 0.0, 559.2}, {0.0, 548.8, 559.2}, {556.0, 548.8, 559.2}}}};
static const quad_mm red_wall_quads[] = {
    {{{552.8, 0.0, 0.0}, {549.6, 0.0, 559.2}, {556.0, 548.8, 559.2}, {556.0, 548.8, 0.0}}}};
static const quad_mm green_wall_quads[] = {
    {{{0.0, 0.0, 559.2}, {0.0, 0.0, 0.0}, {0.0, 548.8, 0.0}, {0.0, 548.8, 559.2}}}};
static const quad_mm light_quads[] = {{{{343.0, CORNELL_LIGHT_Y_MM, 227.0},
                                        {343.0, CORNELL_LIGHT_Y_MM, 332.0},
                                        {213.0, CORNELL_LIGHT_Y_MM, 332.0},
                                        {213.0, CORNELL_LIGHT_Y_MM, 227.0}}}};
static const quad_mm short_block_quads[] = {
    {{{130.0, 165.0, 65.0}, {82.0, 165.0, 225.0}, {240.0, 165.0, 272.0}, {290.0, 165.0, 114.0}}},
    {{{290.0, 0.0, 114.0}, {290.0, 165.0, 114.0}, {240.0, 165.0, 272.0}, {240.0, 0.0, 272.0}}},
    {{{130.0, 0.0, 65.0}, {130.0, 165.0, 65.0}, {290.0, 165.0, 114.0}, {290.0, 0.0, 114.0}}},
    {{{82.0, 0.0, 225.0}, {82.0, 165.0, 225.0}, {130.0, 165.0, 65.0}, {130.0, 0.0, 65.0}}},
    {{{240.0, 0.0, 272.0}, {240.0, 165.0, 272.0}, {82.0, 165.0, 225.0}, {82.0, 0.0, 225.0}}}};
static const quad_mm tall_block_quads[] = {
    {{{423.0, 330.0, 247.0}, {265.0, 330.0, 296.0}, {314.0, 330.0, 456.0}, {472.0, 330.0, 406.0}}},
    {{{423.0, 0.0, 247.0}, {423.0, 330.0, 247.0}, {472.0, 330.0, 406.0}, {472.0, 0.0, 406.0}}},
    {{{472.0, 0.0, 406.0}, {472.0, 330.0, 406.0}, {314.0, 330.0, 456.0}, {314.0, 0.0, 456.0}}},
    {{{314.0, 0.0, 456.0}, {314.0, 330.0, 456.0}, {265.0, 330.0, 296.0}, {265.0, 0.0, 296.0}}},
    {{{265.0, 0.0, 296.0}, {265.0, 330.0, 296.0}, {423.0, 330.0, 247.0}, {423.0, 0.0, 247.0}}}};

#define COUNT_OF(array) (sizeof(array) / sizeof((array)[0]))

/* Growable byte/text buffer; allocation failure ends the program (a generator). */
typedef struct strbuf {
    char *data;
    size_t length;
    size_t capacity;
} strbuf;

static void die(const char *format, ...) __attribute__((format(printf, 1, 2), noreturn));

static void die(const char *format, ...)
{
    va_list args;
    va_start(args, format);
    fputs("pf_generate_scenes: ", stderr);
    vfprintf(stderr, format, args);
    fputc('\n', stderr);
    va_end(args);
    exit(1);
}

static void sb_reserve(strbuf *sb, size_t extra)
{
    if (sb->length + extra + 1 <= sb->capacity)
        return;
    size_t capacity = sb->capacity ? sb->capacity : 4096;
    while (capacity < sb->length + extra + 1)
        capacity *= 2;
    char *data = realloc(sb->data, capacity);
    if (!data)
        die("out of memory");
    sb->data = data;
    sb->capacity = capacity;
}

static void sb_append(strbuf *sb, const void *bytes, size_t count)
{
    sb_reserve(sb, count);
    memcpy(sb->data + sb->length, bytes, count);
    sb->length += count;
    sb->data[sb->length] = '\0';
}

static void sb_printf(strbuf *sb, const char *format, ...) __attribute__((format(printf, 2, 3)));

static void sb_printf(strbuf *sb, const char *format, ...)
{
    va_list args;
    va_start(args, format);
    int needed = vsnprintf(NULL, 0, format, args);
    va_end(args);
    if (needed < 0)
        die("formatting failed");
    sb_reserve(sb, (size_t)needed);
    va_start(args, format);
    vsnprintf(sb->data + sb->length, (size_t)needed + 1, format, args);
    va_end(args);
    sb->length += (size_t)needed;
}

/* %.9g: enough digits for any float32 to read back exactly; -0 is written as 0. */
static void sb_number(strbuf *sb, double value)
{
    if (value == 0.0)
        value = 0.0;
    sb_printf(sb, "%.9g", value);
}

static void sb_numbers(strbuf *sb, const double *values, int count)
{
    sb_printf(sb, "[");
    for (int i = 0; i < count; i++) {
        if (i)
            sb_printf(sb, ", ");
        sb_number(sb, values[i]);
    }
    sb_printf(sb, "]");
}

/* Starts the next element of a one-element-per-line JSON array. */
static void sb_next_item(strbuf *sb)
{
    const char *separator = sb->length ? ",\n    " : "    ";
    sb_append(sb, separator, strlen(separator));
}

static void sb_free(strbuf *sb)
{
    free(sb->data);
    *sb = (strbuf){0};
}

/* The glTF document being assembled: each array is built as text, the buffer as bytes. */
typedef struct gltf_doc {
    strbuf bin;
    strbuf buffer_views, accessors, meshes, materials, nodes, samplers, channels;
    int view_count, accessor_count, mesh_count, material_count, node_count, sampler_count;
} gltf_doc;

static void doc_free(gltf_doc *doc)
{
    strbuf *all[] = {&doc->bin,   &doc->buffer_views, &doc->accessors, &doc->meshes,
                     &doc->materials, &doc->nodes, &doc->samplers, &doc->channels};
    for (size_t i = 0; i < COUNT_OF(all); i++)
        sb_free(all[i]);
}

/* Appends bytes to the buffer as a new bufferView, 4-byte aligned (glTF §3.6.2.4). */
static int add_buffer_view(gltf_doc *doc, const void *bytes, size_t count, int target)
{
    static const char zeros[4] = {0};
    sb_append(&doc->bin, zeros, (4 - doc->bin.length % 4) % 4);
    sb_next_item(&doc->buffer_views);
    sb_printf(&doc->buffer_views, "{\"buffer\": 0, \"byteOffset\": %zu, \"byteLength\": %zu",
              doc->bin.length, count);
    if (target)
        sb_printf(&doc->buffer_views, ", \"target\": %d", target);
    sb_printf(&doc->buffer_views, "}");
    sb_append(&doc->bin, bytes, count);
    return doc->view_count++;
}

/* Float accessor of `count` elements of `width` components; min/max when asked. */
static int add_float_accessor(gltf_doc *doc, const float *values, int count, int width,
                              int with_bounds, int target)
{
    static const char *const type_names[] = {"", "SCALAR", "VEC2", "VEC3", "VEC4"};
    int view = add_buffer_view(doc, values, sizeof(float) * (size_t)(count * width), target);
    sb_next_item(&doc->accessors);
    sb_printf(&doc->accessors,
              "{\"bufferView\": %d, \"componentType\": %d, \"count\": %d, \"type\": \"%s\"",
              view, GLTF_FLOAT, count, type_names[width]);
    if (with_bounds) {
        double lo[4], hi[4];
        for (int c = 0; c < width; c++) {
            lo[c] = hi[c] = values[c];
            for (int i = 1; i < count; i++) {
                lo[c] = fmin(lo[c], values[i * width + c]);
                hi[c] = fmax(hi[c], values[i * width + c]);
            }
        }
        sb_printf(&doc->accessors, ", \"min\": ");
        sb_numbers(&doc->accessors, lo, width);
        sb_printf(&doc->accessors, ", \"max\": ");
        sb_numbers(&doc->accessors, hi, width);
    }
    sb_printf(&doc->accessors, "}");
    return doc->accessor_count++;
}

static int add_index_accessor(gltf_doc *doc, const uint16_t *indices, int count)
{
    int view = add_buffer_view(doc, indices, sizeof(uint16_t) * (size_t)count,
                               GLTF_ELEMENT_ARRAY_BUFFER);
    sb_next_item(&doc->accessors);
    sb_printf(&doc->accessors,
              "{\"bufferView\": %d, \"componentType\": %d, \"count\": %d, \"type\": \"SCALAR\"}",
              view, GLTF_UNSIGNED_SHORT, count);
    return doc->accessor_count++;
}

/* Published millimetres (camera looking +z) to glTF metres (camera looking -z). */
static void cornell_to_gltf(const double mm[3], double out[3])
{
    /*
     * A 180° turn about +y: a proper rotation, so the image is not mirrored and
     * windings keep their orientation; it lets a glTF camera (which looks down
     * its -z) keep the identity rotation. Red stays on the viewer's left.
     */
    out[0] = -mm[0] * MM_TO_M;
    out[1] = mm[1] * MM_TO_M;
    out[2] = -mm[2] * MM_TO_M;
}

/* Centre of a set of quads' corners (glTF metres): the local origin of a block. */
static void quads_centroid(const quad_mm *quads, int quad_count, double out[3])
{
    double sum[3] = {0, 0, 0};
    for (int q = 0; q < quad_count; q++) {
        for (int k = 0; k < 4; k++) {
            double p[3];
            cornell_to_gltf(quads[q].corner[k], p);
            for (int c = 0; c < 3; c++)
                sum[c] += p[c];
        }
    }
    for (int c = 0; c < 3; c++)
        out[c] = sum[c] / (4.0 * quad_count);
}

typedef enum facing {
    FACING_TOWARD, /* front faces look at the reference point (walls, light) */
    FACING_AWAY    /* front faces look away from it (the blocks' outsides) */
} facing;

/*
 * Adds a mesh of flat-shaded quads (4 vertices each, Newell normal per quad).
 * Each quad's winding is chosen so its front face (counter-clockwise, glTF
 * §3.7.2.1) faces `facing` relative to `reference` (world metres), whatever
 * order the published data lists its corners in. Vertices are stored relative
 * to `origin` (world metres): the node places them.
 */
static int add_quad_mesh(gltf_doc *doc, const char *name, const quad_mm *quads, int quad_count,
                         const double origin[3], const double reference[3], facing facing_rule,
                         int material)
{
    float positions[4 * 8 * 3], normals[4 * 8 * 3];
    uint16_t indices[6 * 8];
    if (quad_count > 8)
        die("%s: too many quads", name);
    for (int q = 0; q < quad_count; q++) {
        double p[4][3], n[3] = {0, 0, 0}, centre[3] = {0, 0, 0};
        for (int k = 0; k < 4; k++) {
            cornell_to_gltf(quads[q].corner[k], p[k]);
            for (int c = 0; c < 3; c++)
                centre[c] += p[k][c] / 4.0;
        }
        for (int k = 0; k < 4; k++) {
            const double *a = p[k], *b = p[(k + 1) % 4];
            n[0] += (a[1] - b[1]) * (a[2] + b[2]);
            n[1] += (a[2] - b[2]) * (a[0] + b[0]);
            n[2] += (a[0] - b[0]) * (a[1] + b[1]);
        }
        double length = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        double toward = 0.0;
        for (int c = 0; c < 3; c++) {
            n[c] /= length;
            toward += n[c] * (reference[c] - centre[c]);
        }
        if (facing_rule == FACING_AWAY)
            toward = -toward;
        if (fabs(toward) < 1e-6)
            die("%s: quad %d is edge-on to its reference point", name, q);
        int flip = toward < 0.0;
        for (int k = 0; k < 4; k++) {
            /* reversed order 0,3,2,1 keeps corner 0 and flips the winding */
            int src = flip ? (4 - k) % 4 : k;
            for (int c = 0; c < 3; c++) {
                positions[(q * 4 + k) * 3 + c] = (float)(p[src][c] - origin[c]);
                normals[(q * 4 + k) * 3 + c] = (float)(flip ? -n[c] : n[c]);
            }
        }
        static const uint16_t fan[6] = {0, 1, 2, 0, 2, 3};
        for (int i = 0; i < 6; i++)
            indices[q * 6 + i] = (uint16_t)(q * 4 + fan[i]);
    }
    int vertex_count = quad_count * 4;
    int position_accessor =
        add_float_accessor(doc, positions, vertex_count, 3, 1, GLTF_ARRAY_BUFFER);
    int normal_accessor = add_float_accessor(doc, normals, vertex_count, 3, 0, GLTF_ARRAY_BUFFER);
    int index_accessor = add_index_accessor(doc, indices, quad_count * 6);
    sb_next_item(&doc->meshes);
    sb_printf(&doc->meshes,
              "{\"name\": \"%s\", \"primitives\": [{\"attributes\": {\"POSITION\": %d, "
              "\"NORMAL\": %d}, \"indices\": %d, \"material\": %d, \"mode\": 4}]}",
              name, position_accessor, normal_accessor, index_accessor, material);
    return doc->mesh_count++;
}

static int add_lambert_material(gltf_doc *doc, const char *name, const double albedo[3])
{
    sb_next_item(&doc->materials);
    sb_printf(&doc->materials,
              "{\"name\": \"%s\", \"pbrMetallicRoughness\": {\"baseColorFactor\": [", name);
    for (int c = 0; c < 3; c++) {
        sb_number(&doc->materials, albedo[c]);
        sb_printf(&doc->materials, ", ");
    }
    sb_printf(&doc->materials, "1], \"metallicFactor\": 0, \"roughnessFactor\": 1}}");
    return doc->material_count++;
}

/*
 * The ceiling light: black base colour as in Bitterli's scene (it only emits);
 * emissiveFactor is the radiance normalised to a maximum of 1 and
 * KHR_materials_emissive_strength carries the scale, since glTF clamps
 * emissiveFactor to [0, 1].
 */
static int add_emissive_material(gltf_doc *doc, const char *name, const double radiance[3])
{
    double strength = fmax(radiance[0], fmax(radiance[1], radiance[2]));
    double factor[3] = {radiance[0] / strength, radiance[1] / strength, radiance[2] / strength};
    sb_next_item(&doc->materials);
    sb_printf(&doc->materials,
              "{\"name\": \"%s\", \"pbrMetallicRoughness\": {\"baseColorFactor\": [0, 0, 0, 1], "
              "\"metallicFactor\": 0, \"roughnessFactor\": 1}, \"emissiveFactor\": ",
              name);
    sb_numbers(&doc->materials, factor, 3);
    sb_printf(&doc->materials,
              ", \"extensions\": {\"KHR_materials_emissive_strength\": {\"emissiveStrength\": ");
    sb_number(&doc->materials, strength);
    sb_printf(&doc->materials, "}}}");
    return doc->material_count++;
}

/* One node; mesh/camera/light -1 when absent, translation/rotation NULL when identity. */
static int add_node(gltf_doc *doc, const char *name, int mesh, int camera, int light,
                    const double translation[3], const double rotation[4])
{
    sb_next_item(&doc->nodes);
    sb_printf(&doc->nodes, "{\"name\": \"%s\"", name);
    if (mesh >= 0)
        sb_printf(&doc->nodes, ", \"mesh\": %d", mesh);
    if (camera >= 0)
        sb_printf(&doc->nodes, ", \"camera\": %d", camera);
    if (translation) {
        sb_printf(&doc->nodes, ", \"translation\": ");
        sb_numbers(&doc->nodes, translation, 3);
    }
    if (rotation) {
        sb_printf(&doc->nodes, ", \"rotation\": ");
        sb_numbers(&doc->nodes, rotation, 4);
    }
    if (light >= 0)
        sb_printf(&doc->nodes, ", \"extensions\": {\"KHR_lights_punctual\": {\"light\": %d}}",
                  light);
    sb_printf(&doc->nodes, "}");
    return doc->node_count++;
}

/* An animation channel driving `path` of `node` from a new sampler. */
static void add_channel(gltf_doc *doc, int node, const char *path, int input, int output,
                        const char *interpolation)
{
    sb_next_item(&doc->samplers);
    sb_printf(&doc->samplers, "{\"input\": %d, \"output\": %d, \"interpolation\": \"%s\"}", input,
              output, interpolation);
    sb_next_item(&doc->channels);
    sb_printf(&doc->channels, "{\"sampler\": %d, \"target\": {\"node\": %d, \"path\": \"%s\"}}",
              doc->sampler_count, node, path);
    doc->sampler_count++;
}

static void quat_about_y(double angle, double out[4])
{
    out[0] = 0.0;
    out[1] = sin(angle / 2.0);
    out[2] = 0.0;
    out[3] = cos(angle / 2.0);
}

typedef struct cornell_nodes {
    int short_block;
    int camera;
    double short_block_origin[3];
} cornell_nodes;

/* The box itself (walls, blocks, light, camera): shared by both scenes. */
static cornell_nodes add_cornell_box(gltf_doc *doc)
{
    cornell_nodes nodes;
    int white = add_lambert_material(doc, "white", albedo_white);
    int red = add_lambert_material(doc, "red", albedo_red);
    int green = add_lambert_material(doc, "green", albedo_green);
    int light = add_emissive_material(doc, "light", light_radiance);

    /* The box's centre is inside every wall: front faces look at it. */
    const double box_centre_mm[3] = {278.0, 274.4, 279.6};
    const double world_origin[3] = {0.0, 0.0, 0.0};
    double box_centre[3];
    cornell_to_gltf(box_centre_mm, box_centre);

    const struct {
        const char *name;
        const quad_mm *quads;
        int quad_count;
        int material;
    } walls[] = {
        {"floor", floor_quads, (int)COUNT_OF(floor_quads), white},
        {"ceiling", ceiling_quads, (int)COUNT_OF(ceiling_quads), white},
        {"back_wall", back_wall_quads, (int)COUNT_OF(back_wall_quads), white},
        {"left_wall_red", red_wall_quads, (int)COUNT_OF(red_wall_quads), red},
        {"right_wall_green", green_wall_quads, (int)COUNT_OF(green_wall_quads), green},
    };
    for (size_t i = 0; i < COUNT_OF(walls); i++) {
        int mesh = add_quad_mesh(doc, walls[i].name, walls[i].quads, walls[i].quad_count,
                                 world_origin, box_centre, FACING_TOWARD, walls[i].material);
        add_node(doc, walls[i].name, mesh, -1, -1, NULL, NULL);
    }

    /* Blocks are stored about their own centre so a node can move or turn them. */
    double origin[3];
    quads_centroid(short_block_quads, (int)COUNT_OF(short_block_quads), origin);
    origin[1] = 0.0; /* on the floor: a turn about +y keeps it standing there */
    int mesh = add_quad_mesh(doc, "short_block", short_block_quads,
                             (int)COUNT_OF(short_block_quads), origin, origin, FACING_AWAY, white);
    nodes.short_block = add_node(doc, "short_block", mesh, -1, -1, origin, NULL);
    memcpy(nodes.short_block_origin, origin, sizeof(origin));

    quads_centroid(tall_block_quads, (int)COUNT_OF(tall_block_quads), origin);
    double tall_centre[3] = {origin[0], origin[1], origin[2]};
    origin[1] = 0.0;
    mesh = add_quad_mesh(doc, "tall_block", tall_block_quads, (int)COUNT_OF(tall_block_quads),
                         origin, tall_centre, FACING_AWAY, white);
    add_node(doc, "tall_block", mesh, -1, -1, origin, NULL);

    /* The light faces down: toward the box centre below it. */
    mesh = add_quad_mesh(doc, "light", light_quads, (int)COUNT_OF(light_quads), world_origin,
                         box_centre, FACING_TOWARD, light);
    add_node(doc, "light", mesh, -1, -1, NULL, NULL);

    double camera_position[3];
    cornell_to_gltf(cornell_camera_mm, camera_position);
    nodes.camera = add_node(doc, "camera", -1, 0, -1, camera_position, NULL);
    return nodes;
}

static void base64_append(strbuf *out, const unsigned char *bytes, size_t count)
{
    static const char alphabet[] =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (size_t i = 0; i < count; i += 3) {
        uint32_t chunk = (uint32_t)bytes[i] << 16;
        if (i + 1 < count)
            chunk |= (uint32_t)bytes[i + 1] << 8;
        if (i + 2 < count)
            chunk |= bytes[i + 2];
        char quad[4] = {alphabet[(chunk >> 18) & 63], alphabet[(chunk >> 12) & 63],
                        i + 1 < count ? alphabet[(chunk >> 6) & 63] : '=',
                        i + 2 < count ? alphabet[chunk & 63] : '='};
        sb_append(out, quad, 4);
    }
}

typedef struct scene_meta {
    const char *name;
    int frames;
    const char *extensions_used; /* JSON array body */
    const char *lights;          /* KHR_lights_punctual lights array body, or NULL */
    const char *animation_name;  /* NULL when static */
} scene_meta;

static const char scene_source[] =
    "Cornell Box Data, Cornell University Program of Computer Graphics "
    "(https://www.graphics.cornell.edu/online/box/data.html); RGB albedos and light "
    "radiance from Benedikt Bitterli's rendering resources "
    "(https://benedikt-bitterli.me/resources/, CC0); generated by scenes/generate_scenes.c";
static const char scene_conversion[] =
    "millimetres to metres; turned 180 degrees about +y so the camera looks down -z "
    "(no mirroring: the red wall stays on the left); spectral data reduced to RGB; "
    "ceiling kept whole and the light lowered to y = 548.7 mm instead of a hole";

static void write_document(const gltf_doc *doc, const scene_meta *meta, const char *path)
{
    strbuf text = {0};
    double yfov = 2.0 * atan(0.5 * CORNELL_FILM_SIZE_M / CORNELL_FOCAL_LENGTH_M);
    sb_printf(&text, "{\n  \"asset\": {\"version\": \"2.0\", \"generator\": "
                     "\"photonfarm scenes/generate_scenes.c\", \"extras\": {\"frames\": %d, "
                     "\"fps\": %g, \"source\": \"%s\", \"conversion\": \"%s\"}},\n",
              meta->frames, ANIM_FPS, scene_source, scene_conversion);
    sb_printf(&text, "  \"extensionsUsed\": [%s],\n", meta->extensions_used);
    if (meta->lights)
        sb_printf(&text, "  \"extensions\": {\"KHR_lights_punctual\": {\"lights\": [%s]}},\n",
                  meta->lights);
    sb_printf(&text, "  \"scene\": 0,\n  \"scenes\": [{\"name\": \"%s\", \"nodes\": [", meta->name);
    for (int i = 0; i < doc->node_count; i++)
        sb_printf(&text, i ? ", %d" : "%d", i);
    sb_printf(&text, "]}],\n  \"nodes\": [\n%s\n  ],\n", doc->nodes.data);
    sb_printf(&text, "  \"cameras\": [{\"name\": \"camera\", \"type\": \"perspective\", "
                     "\"perspective\": {\"aspectRatio\": 1, \"yfov\": ");
    sb_number(&text, yfov);
    sb_printf(&text, ", \"znear\": 0.01}}],\n");
    sb_printf(&text, "  \"meshes\": [\n%s\n  ],\n", doc->meshes.data);
    sb_printf(&text, "  \"materials\": [\n%s\n  ],\n", doc->materials.data);
    if (meta->animation_name)
        sb_printf(&text,
                  "  \"animations\": [{\"name\": \"%s\",\n  \"samplers\": [\n%s\n  ],\n"
                  "  \"channels\": [\n%s\n  ]}],\n",
                  meta->animation_name, doc->samplers.data, doc->channels.data);
    sb_printf(&text, "  \"accessors\": [\n%s\n  ],\n", doc->accessors.data);
    sb_printf(&text, "  \"bufferViews\": [\n%s\n  ],\n", doc->buffer_views.data);
    sb_printf(&text, "  \"buffers\": [{\"byteLength\": %zu, \"uri\": "
                     "\"data:application/octet-stream;base64,",
              doc->bin.length);
    base64_append(&text, (const unsigned char *)doc->bin.data, doc->bin.length);
    sb_printf(&text, "\"}]\n}\n");

    FILE *file = fopen(path, "wb");
    if (!file)
        die("%s: cannot create: %s", path, strerror(errno));
    size_t written = fwrite(text.data, 1, text.length, file);
    if (written != text.length || fclose(file) != 0)
        die("%s: write failed: %s", path, strerror(errno));
    sb_free(&text);
}

static void write_static_cornell(const char *path)
{
    gltf_doc doc = {0};
    add_cornell_box(&doc);
    scene_meta meta = {"cornell", 1, "\"KHR_materials_emissive_strength\"", NULL, NULL};
    write_document(&doc, &meta, path);
    doc_free(&doc);
}

/* Times of `count` keys spread evenly over the 24-frame clip. */
static int add_key_times(gltf_doc *doc, int count)
{
    float times[16];
    for (int i = 0; i < count; i++)
        times[i] = (float)(ANIM_LAST_KEY_S * i / (count - 1));
    return add_float_accessor(doc, times, count, 1, 1, 0);
}

/*
 * Camera: orbits the box centre from -6° to +6° about +y while dollying in
 * from the published distance; LINEAR translation and rotation (slerp).
 */
#define CAMERA_KEYS 5
#define CAMERA_ORBIT_START_RAD (-6.0 * DEG_TO_RAD)
#define CAMERA_ORBIT_END_RAD (6.0 * DEG_TO_RAD)
#define CAMERA_DOLLY_END_M 0.98

static void animate_camera(gltf_doc *doc, int node)
{
    double target[3], camera[3];
    const double target_mm[3] = {278.0, 273.0, 279.6};
    cornell_to_gltf(target_mm, target);
    cornell_to_gltf(cornell_camera_mm, camera);
    double start_distance = camera[2] - target[2];
    float translations[CAMERA_KEYS * 3], rotations[CAMERA_KEYS * 4];
    for (int i = 0; i < CAMERA_KEYS; i++) {
        double s = (double)i / (CAMERA_KEYS - 1);
        double angle = CAMERA_ORBIT_START_RAD + s * (CAMERA_ORBIT_END_RAD - CAMERA_ORBIT_START_RAD);
        double distance = start_distance + s * (CAMERA_DOLLY_END_M - start_distance);
        double q[4];
        quat_about_y(angle, q);
        translations[i * 3 + 0] = (float)(target[0] + distance * sin(angle));
        translations[i * 3 + 1] = (float)target[1];
        translations[i * 3 + 2] = (float)(target[2] + distance * cos(angle));
        for (int c = 0; c < 4; c++)
            rotations[i * 4 + c] = (float)q[c];
    }
    int times = add_key_times(doc, CAMERA_KEYS);
    add_channel(doc, node, "translation", times,
                add_float_accessor(doc, translations, CAMERA_KEYS, 3, 0, 0), "LINEAR");
    add_channel(doc, node, "rotation", times,
                add_float_accessor(doc, rotations, CAMERA_KEYS, 4, 0, 0), "LINEAR");
}

/*
 * Short block: slides toward the camera and the red wall with ease-in/ease-out
 * (CUBICSPLINE: zero end tangents and a middle key at half way with slope
 * 1.5·d/T make it exactly smoothstep), while turning 30° about +y (LINEAR).
 * The path stays clear of the tall block and the walls.
 */
#define BLOCK_TURN_RAD (30.0 * DEG_TO_RAD)
static const double block_slide_m[3] = {-0.03, 0.0, 0.05};

static void animate_short_block(gltf_doc *doc, int node, const double origin[3])
{
    /* per key: in-tangent, value, out-tangent (glTF §3.11.4 CUBICSPLINE layout) */
    float spline[3 * 3 * 3];
    for (int key = 0; key < 3; key++) {
        double fraction = key / 2.0;
        double slope = key == 1 ? 1.5 / ANIM_LAST_KEY_S : 0.0;
        for (int c = 0; c < 3; c++) {
            spline[(key * 3 + 0) * 3 + c] = (float)(slope * block_slide_m[c]);
            spline[(key * 3 + 1) * 3 + c] = (float)(origin[c] + fraction * block_slide_m[c]);
            spline[(key * 3 + 2) * 3 + c] = (float)(slope * block_slide_m[c]);
        }
    }
    add_channel(doc, node, "translation", add_key_times(doc, 3),
                add_float_accessor(doc, spline, 9, 3, 0, 0), "CUBICSPLINE");

    double start[4], end[4];
    quat_about_y(0.0, start);
    quat_about_y(BLOCK_TURN_RAD, end);
    float rotations[8];
    for (int c = 0; c < 4; c++) {
        rotations[c] = (float)start[c];
        rotations[4 + c] = (float)end[c];
    }
    add_channel(doc, node, "rotation", add_key_times(doc, 2),
                add_float_accessor(doc, rotations, 2, 4, 0, 0), "LINEAR");
}

/*
 * Point light: circles once above the blocks (LINEAR between 9 keys: an octagon).
 * Intensity 0.05 W/sr (34.15 cd at the spec's 683 lm/W) lights the floor about
 * a quarter as much as the ceiling light (0.05 / 0.4² ≈ 0.3 W/m² against
 * 17 · 0.0137 m² / 0.55² ≈ 0.77 W/m²).
 */
#define POINT_LIGHT_KEYS 9
#define POINT_LIGHT_RADIUS_M 0.15
#define POINT_LIGHT_HEIGHT_M 0.40
static const char point_light_json[] =
    "{\"name\": \"moving_point_light\", \"type\": \"point\", \"color\": [1, 0.85, 0.7], "
    "\"intensity\": 34.15}";

static int add_moving_point_light(gltf_doc *doc)
{
    double centre[3];
    const double centre_mm[3] = {278.0, 0.0, 279.6};
    cornell_to_gltf(centre_mm, centre);
    float positions[POINT_LIGHT_KEYS * 3];
    for (int i = 0; i < POINT_LIGHT_KEYS; i++) {
        double angle = 2.0 * 3.14159265358979323846 * i / (POINT_LIGHT_KEYS - 1);
        positions[i * 3 + 0] = (float)(centre[0] + POINT_LIGHT_RADIUS_M * cos(angle));
        positions[i * 3 + 1] = (float)POINT_LIGHT_HEIGHT_M;
        positions[i * 3 + 2] = (float)(centre[2] + POINT_LIGHT_RADIUS_M * sin(angle));
    }
    const double start[3] = {centre[0] + POINT_LIGHT_RADIUS_M, POINT_LIGHT_HEIGHT_M, centre[2]};
    int node = add_node(doc, "moving_point_light", -1, -1, 0, start, NULL);
    add_channel(doc, node, "translation", add_key_times(doc, POINT_LIGHT_KEYS),
                add_float_accessor(doc, positions, POINT_LIGHT_KEYS, 3, 0, 0), "LINEAR");
    return node;
}

static void write_animated_cornell(const char *path)
{
    gltf_doc doc = {0};
    cornell_nodes nodes = add_cornell_box(&doc);
    animate_camera(&doc, nodes.camera);
    animate_short_block(&doc, nodes.short_block, nodes.short_block_origin);
    add_moving_point_light(&doc);
    scene_meta meta = {"cornell-moving", ANIM_FRAMES,
                       "\"KHR_materials_emissive_strength\", \"KHR_lights_punctual\"",
                       point_light_json, "camera_block_light"};
    write_document(&doc, &meta, path);
    doc_free(&doc);
}

static void make_directory(const char *path)
{
    if (mkdir(path, 0777) != 0 && errno != EEXIST)
        die("%s: cannot create directory: %s", path, strerror(errno));
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: pf_generate_scenes OUTPUT_ROOT\n");
        return 2;
    }
    /* glTF buffers are little-endian; the floats are copied as they are in memory. */
    const uint16_t probe = 1;
    if (*(const unsigned char *)&probe != 1)
        die("big-endian hosts are not supported");

    char path[4096];
    make_directory(argv[1]);
    snprintf(path, sizeof(path), "%s/cornell", argv[1]);
    make_directory(path);
    snprintf(path, sizeof(path), "%s/cornell/cornell.gltf", argv[1]);
    write_static_cornell(path);
    snprintf(path, sizeof(path), "%s/cornell-moving", argv[1]);
    make_directory(path);
    snprintf(path, sizeof(path), "%s/cornell-moving/cornell-moving.gltf", argv[1]);
    write_animated_cornell(path);
    return 0;
}
