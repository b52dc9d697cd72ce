/*
 * Private to the glTF loader: the context shared by gltf_load.c (container,
 * JSON, meshes, nodes, cameras, lights), gltf_accessors.c (buffers, accessors),
 * gltf_materials.c and gltf_animation.c, plus the validated JSON and accessor
 * readers they all use.
 */
#ifndef PF_GLTF_INTERNAL_H
#define PF_GLTF_INTERNAL_H

#include "scene_internal.h"

#include <cjson/cJSON.h>
#include <stddef.h>

typedef struct gltf_buffer {
    unsigned char *data; /* owned unless it points into the .glb BIN chunk; NULL for an
                          * EXT_meshopt_compression fallback buffer, which has no data */
    size_t size;         /* the buffer's byteLength (data holds at least this) */
    int owned;
} gltf_buffer;

/* A bufferView's bytes decoded from its EXT_meshopt_compression stream (gltf_meshopt.c). */
typedef struct gltf_view_data {
    unsigned char *data; /* NULL: the view reads its buffer */
    size_t size;
} gltf_view_data;

/* A compressed primitive's accessor as its decoder produced it (gltf_draco.c): while the
 * primitive loads, the accessor readers take these values instead of a bufferView's. */
typedef struct gltf_decoded_accessor {
    int32_t accessor;
    uint32_t count, components;
    double *values; /* count × components, before the accessor's normalization */
} gltf_decoded_accessor;

typedef struct gltf_context {
    pf_scene *scene;
    const char *path;
    char *file_data;
    size_t file_size;
    cJSON *root;
    const unsigned char *glb_bin; /* BIN chunk of a .glb, NULL otherwise */
    size_t glb_bin_size;
    uint32_t buffer_count;
    gltf_buffer *buffers;
    uint32_t file_material_count; /* materials in the file; a default may follow */
    int32_t default_material;     /* index of the grey default, SCENE_NONE until needed */
    /* Per images[i] and colour space (0 linear, 1 sRGB): its mip chain's first texel + 1 in
     * scene->texels (0: not decoded yet), its size and levels (gltf_textures.c). */
    uint32_t image_count;
    uint64_t (*image_chain)[2];
    uint32_t (*image_size)[3];
    /* The primitive being loaded's decoded accessors (KHR_draco_mesh_compression). */
    gltf_decoded_accessor *decoded;
    uint32_t decoded_count;
    /* Per bufferView, its decoded bytes where it is compressed (NULL when none is). */
    gltf_view_data *view_data;
    uint32_t view_count;
} gltf_context;

/* PF_ERR_FORMAT (or the given status) with "path: element: message". */
pf_status gltf_fail(gltf_context *ctx, pf_error *err, pf_status status, const char *element,
                    const char *format, ...) __attribute__((format(printf, 5, 6)));

/* Number at key (default if absent, and on failure); must be a finite number. */
pf_status gltf_number(gltf_context *ctx, const cJSON *object, const char *key, double fallback,
                      double *out, const char *element, pf_error *err);
/* Optional index at key into [0, count): *out = SCENE_NONE if absent. */
pf_status gltf_index(gltf_context *ctx, const cJSON *object, const char *key, uint32_t count,
                     int32_t *out, const char *element, pf_error *err);
/* Array of exactly n finite numbers at key; out unchanged if absent. */
pf_status gltf_floats(gltf_context *ctx, const cJSON *object, const char *key, int n,
                      float *out, const char *element, pf_error *err);
/*
 * The entry of array (count objects, each with an optional "name") that choice names (the
 * load options' --animation, --variant): the first whose name it is, else the one whose
 * decimal index it is; SCENE_NONE when none, or when choice is NULL. names gets the entries
 * as "0 'walk', 1 'run'" (cut to its size), or "none" when there are none.
 */
int32_t gltf_named_entry(const cJSON *array, uint32_t count, const char *choice, char *names,
                         size_t size);
/* Length of the array at key (0 if absent); error if present and not an array. */
pf_status gltf_array(gltf_context *ctx, const cJSON *object, const char *key,
                     const cJSON **out, uint32_t *count, const char *element, pf_error *err);

/*
 * Reads accessor `index` as floats (integer types converted, normalized ones to
 * [0,1]/[-1,1]); its component count must be `components`. All values must be
 * finite. *out (count × components) is malloc'ed and owned by the caller.
 * `element` names what refers to the accessor (for messages).
 */
pf_status gltf_read_floats(gltf_context *ctx, int32_t index, uint32_t components, float **out,
                           uint32_t *count, const char *element, pf_error *err);
/* Reads an accessor of unsigned integers (u8/u16/u32, not normalized: indices, JOINTS_n)
 * with `components` per element into malloc'ed *out. */
pf_status gltf_read_uints(gltf_context *ctx, int32_t index, uint32_t components, uint32_t **out,
                          uint32_t *count, const char *element, pf_error *err);
/* Reads an index accessor (SCALAR u8/u16/u32) into malloc'ed *out. */
pf_status gltf_read_indices(gltf_context *ctx, int32_t index, uint32_t **out, uint32_t *count,
                            const char *element, pf_error *err);

/* Little-endian u32 at bytes (GLB headers). */
uint32_t gltf_read_u32le(const unsigned char *bytes);

/* The bytes a uri names (a data: URI or a file beside the scene, as for buffers); *data is
 * malloc'ed. */
pf_status gltf_read_uri(gltf_context *ctx, const cJSON *uri, const char *element,
                        unsigned char **data, size_t *size, pf_error *err);
/* The component count of accessors[index]'s type (SCALAR 1 … MAT4 16), 0 if it has none. */
uint32_t gltf_accessor_components(gltf_context *ctx, int32_t index);
/*
 * gltf_draco.c: KHR_draco_mesh_compression. gltf_draco_decode_primitive decodes the
 * primitive's compressed stream, where it has one, into ctx->decoded (the accessors of the
 * attributes it compresses, and of its indices); gltf_draco_release frees them after the
 * primitive is loaded.
 */
pf_status gltf_draco_decode_primitive(gltf_context *ctx, const cJSON *primitive,
                                      const char *element, pf_error *err);
void gltf_draco_release(gltf_context *ctx);
/* gltf_meshopt.c: EXT_meshopt_compression. Decodes every compressed bufferView into
 * ctx->view_data (after gltf_load_buffers); gltf_meshopt_free frees them. */
pf_status gltf_meshopt_decode_views(gltf_context *ctx, pf_error *err);
void gltf_meshopt_free(gltf_context *ctx);
/* The bytes of bufferViews[view_index], checked against its buffer; *data points into it. */
pf_status gltf_view_bytes(gltf_context *ctx, int32_t view_index, const char *element,
                          const unsigned char **data, size_t *size, pf_error *err);
/*
 * gltf_textures.c: a textureInfo (index, texCoord, KHR_texture_transform) to a material slot
 * (1 + its pf_texture_ref's index; PF_NO_TEXTURE when info is NULL). The image is decoded and
 * its mip chain built once per (image, srgb). Errors name the image, its index and element.
 */
pf_status gltf_texture_slot(gltf_context *ctx, const cJSON *info, int srgb, const char *element,
                            uint32_t *slot, float *scale, pf_error *err);
void gltf_textures_free(gltf_context *ctx);
/* gltf_accessors.c: every entry of "buffers" into ctx->buffers, sizes checked. */
pf_status gltf_load_buffers(gltf_context *ctx, pf_error *err);
pf_status gltf_load_materials(gltf_context *ctx, pf_error *err);
/* KHR_materials_variants: the file's variants, and the one chosen (scene->variant_choice). */
pf_status gltf_load_material_variants(gltf_context *ctx, pf_error *err);
/* The material primitive wears: the chosen variant's where the primitive maps it, else
 * *material (its own) as read. */
pf_status gltf_primitive_variant(gltf_context *ctx, const cJSON *primitive, const char *element,
                                 int32_t *material, pf_error *err);
pf_status gltf_load_animations(gltf_context *ctx, pf_error *err);

/*
 * gltf_deform.c: skins and morph targets. gltf_mesh_deforms: some primitive of the mesh
 * has JOINTS_0 or targets, so every primitive's vertices are kept (scene_deform_mesh).
 * gltf_append_deform_vertices appends one primitive's (after append_triangles added its
 * triangles; corners index its vertices). gltf_load_mesh_weights reads mesh.weights once
 * the primitives are in; gltf_load_skins reads skins and checks the nodes' skin and
 * weights against them and their meshes (after load_nodes).
 */
int gltf_mesh_deforms(const cJSON *mesh);
pf_status gltf_append_deform_vertices(gltf_context *ctx, scene_mesh *mesh,
                                      const cJSON *primitive, const char *element,
                                      const float *positions, const float *normals,
                                      uint32_t vertex_count, const uint32_t *corners,
                                      uint32_t triangle_count, pf_error *err);
pf_status gltf_load_mesh_weights(gltf_context *ctx, const cJSON *mesh_json, scene_mesh *mesh,
                                 const char *element, pf_error *err);
pf_status gltf_load_skins(gltf_context *ctx, pf_error *err);

#endif
