/*
 * Private to core/scene: the loaded, format-independent scene that
 * pf_scene_eval samples. Loaders (gltf_*.c, obj_load.c) fill it; scene_eval.c
 * finalises it (hierarchy order, animated flags, counts, default camera) and
 * evaluates it. Nothing here is parsed again at eval time.
 */
#ifndef PF_SCENE_INTERNAL_H
#define PF_SCENE_INTERNAL_H

#include "pf_scene.h"

#include <stdarg.h>
#include <stdint.h>

#define SCENE_NONE (-1)

/* Frame rate when asset.extras.fps is absent (glTF has no notion of frames): 24,
 * the film convention that Blender's glTF exporter also assumes. */
#define SCENE_DEFAULT_FPS 24.0

/* A corner's attributes in the mesh: uv0 (2), uv1 (2), colour (4), tangent (4). */
#define SCENE_CORNER_FLOATS 12

/* Most joint influences a vertex may have: JOINTS_0/WEIGHTS_0 and JOINTS_1/WEIGHTS_1 (the
 * per-vertex deformers read them as pf_deform_node's rows). */
#define SCENE_MAX_INFLUENCES PF_DEFORM_MAX_INFLUENCES

/*
 * What a mesh that can deform (a skinned mesh, or one with morph targets) keeps
 * per vertex besides its flattened triangles: its primitives' vertices one after
 * the other, the vertex every corner reads, and the data deform.c blends. A
 * corner's tangent is its flattened one (mesh->corners) plus its vertex's
 * morphed tangent delta.
 */
typedef struct scene_deform_mesh {
    uint32_t vertex_count;
    uint32_t *corner_vertex;     /* 3 per triangle, in the mesh's triangle order */
    float (*positions)[3];       /* the rest (bind) pose */
    float (*normals)[3];         /* zero where the primitive has none: the face normal */
    uint32_t influences;         /* 0 (no JOINTS_0), 4 or 8 */
    uint16_t (*joints)[SCENE_MAX_INFLUENCES];
    float (*weights)[SCENE_MAX_INFLUENCES]; /* summing to 1; all 0: the vertex stays put */
    uint32_t max_joint;          /* the largest joint index a weighted influence names */
    char joints_element[192];    /* the accessor that names it, for messages */
    uint32_t target_count;
    float *target_positions;     /* [vertex][target][3] */
    float *target_normals;       /* the same layout; NULL when no target has NORMAL */
    float *target_tangents;      /* the same layout; NULL when no target has TANGENT */
    float *default_weights;      /* mesh.weights: target_count (zero where absent) */
} scene_deform_mesh;

/* Triangles of one mesh in its local space, 3 corners per triangle. */
typedef struct scene_mesh {
    uint32_t triangle_count;
    float (*positions)[9];
    float (*normals)[9];
    /* Per corner (3 a triangle): uv0, uv1, colour rgba, tangent xyzw, local space
     * (PF_CORNER_TEXELS texels of pf_scene_frame.corners); NULL when the mesh has none. */
    float (*corners)[3 * SCENE_CORNER_FLOATS];
    uint32_t *materials;
    int has_color;           /* some primitive has COLOR_0 */
    uint32_t emissive_count; /* set by scene_finalize */
    scene_deform_mesh *deform; /* NULL: a rigid mesh (no JOINTS_0, no morph targets) */
} scene_mesh;

/* A glTF skin: the joints' nodes and their inverse bind matrices (identity if absent). */
typedef struct scene_skin {
    uint32_t joint_count;
    uint32_t *joints;            /* node indices */
    float (*inverse_bind)[16];   /* column-major */
} scene_skin;
/* Where a corner has no such attribute: uv 0, white, no tangent. */
void scene_corner_defaults(float corner[SCENE_CORNER_FLOATS]);

typedef struct scene_node {
    float translation[3];
    float rotation[4]; /* x, y, z, w; unit */
    float scale[3];
    float matrix[16];  /* column-major; used when has_matrix */
    int has_matrix;
    int32_t parent;    /* SCENE_NONE for a root */
    int32_t mesh, camera, light;
    int32_t skin;      /* SCENE_NONE, or the skin that deforms this node's mesh */
    float *weights;    /* node.weights (its mesh's target_count), NULL: the mesh's */
    int has_channel;   /* an animation channel targets this node's transform */
    int has_weights_channel; /* an animation channel targets this node's morph weights */
    int deforms;       /* its mesh is skinned or morphed each frame (scene_finalize) */
    int deform_animated; /* and that changes over time: joints or weights animated */
    uint32_t first_triangle; /* its mesh's first triangle in a frame (scene_finalize) */
    int animated;      /* has_channel here or on an ancestor (scene_finalize) */
    int in_scene;      /* reached from the scene's roots */
    /* EXT_mesh_gpu_instancing: the node's instances, nodes [first_instance, + instance_count)
     * after the file's, its children each carrying its mesh under an instance's TRS. */
    uint32_t first_instance, instance_count;
} scene_node;

typedef struct scene_camera_def {
    float yfov, aspect, znear, zfar;
    uint32_t orthographic; /* pf_camera's */
    float ymag;
} scene_camera_def;

typedef struct scene_light_def {
    uint32_t kind; /* pf_light_kind */
    float intensity[3];
    float range;
    float cos_inner_cone, cos_outer_cone;
} scene_light_def;

typedef enum scene_channel_path {
    SCENE_PATH_TRANSLATION = 0,
    SCENE_PATH_ROTATION = 1,
    SCENE_PATH_SCALE = 2,
    SCENE_PATH_WEIGHTS = 3 /* morph target weights: components = the mesh's target count */
} scene_channel_path;

typedef enum scene_interpolation {
    SCENE_INTERP_STEP = 0,
    SCENE_INTERP_LINEAR = 1,
    SCENE_INTERP_CUBICSPLINE = 2
} scene_interpolation;

/* One animation channel with its sampler's data copied out of the buffers. */
typedef struct scene_channel {
    uint32_t node;
    uint32_t path;          /* scene_channel_path */
    uint32_t interpolation; /* scene_interpolation */
    uint32_t key_count;
    uint32_t components;    /* 3 (translation, scale), 4 (rotation), or the target count */
    float *times;           /* key_count, non-decreasing */
    float *values;          /* key_count × components (× 3 for CUBICSPLINE: in, value, out) */
} scene_channel;

struct pf_scene {
    pf_scene_info info;
    char *path;
    int allow_outside_dir; /* pf_scene_load_options.allow_outside_scene_dir */
    char *animation_choice; /* pf_scene_load_options.animation (NULL: every animation) */
    int32_t animation;      /* the chosen animation's index, SCENE_NONE: every one plays */
    char *variant_choice;   /* pf_scene_load_options.material_variant (NULL: none) */
    int32_t variant;        /* the chosen material variant's index, SCENE_NONE: none */
    uint32_t variant_count; /* KHR_materials_variants' variants in the file */

    uint32_t node_count;
    scene_node *nodes;
    uint32_t order_count;   /* nodes of the scene, parents before children (DFS) */
    uint32_t *order;

    uint32_t mesh_count;
    scene_mesh *meshes;
    uint32_t material_count;
    pf_material *materials;
    uint32_t texture_count;      /* material slots' textures (pf_texture_ref) */
    pf_texture_ref *textures;
    uint64_t texel_count;        /* every texture's mip chain, RGBA8 words */
    uint32_t *texels;
    int frame_corners;           /* frames carry corners: textures or COLOR_0 (scene_finalize) */
    uint64_t texture_set;        /* pf_scene_frame.texture_set: unique per load in the process */
    uint32_t camera_def_count;
    scene_camera_def *cameras;
    uint32_t light_def_count;
    scene_light_def *lights;
    uint32_t skin_count;
    scene_skin *skins;
    uint32_t channel_count;
    scene_channel *channels;
    uint32_t animation_count;

    double fps;             /* 0 until the loader sets it: SCENE_DEFAULT_FPS */
    uint32_t file_frame_count; /* asset.extras.frames, 0 if absent */
    uint32_t frame_offset;  /* pf_scene_info.frame_offset */

    int32_t camera_node;    /* first camera node in order, SCENE_NONE → default_camera */
    pf_camera default_camera;

    /* Loader-time bookkeeping for "warn once per feature per scene". */
    uint32_t warned_count;
    char **warned;
};

/* image_decode.c: PNG, JPEG or WebP bytes (told apart by signature) to RGBA8 rows,
 * *rgba malloc'ed. The header's size is checked against PF_IMAGE_MAX_EDGE and
 * PF_IMAGE_MAX_PIXELS (PF_ERR_LIMIT) before decoding; corrupt or truncated data is
 * PF_ERR_FORMAT with the decoder's reason. */
pf_status scene_image_decode(const unsigned char *data, size_t size, uint32_t *width,
                             uint32_t *height, uint8_t **rgba, pf_error *err);
/* texture_mips.c: the mip chain of a width × height RGBA8 image (scene_mip_levels
 * levels, scene_mip_chain_texels words at out), averaged in linear light; srgb: the
 * RGB channels are sRGB-encoded. */
float scene_srgb_to_linear(float c);
float scene_linear_to_srgb(float c);
uint32_t scene_mip_levels(uint32_t width, uint32_t height);
uint64_t scene_mip_chain_texels(uint32_t width, uint32_t height, uint32_t levels);
pf_status scene_mip_chain_build(const uint8_t *rgba, uint32_t width, uint32_t height,
                                uint32_t levels, int srgb, uint32_t *out, pf_error *err);
/* tangents.c: per-corner tangents (xyz, w handedness; 0 where undefined) of an indexed
 * primitive from its UV set, for normal maps when the file has none. normals may be NULL
 * (the faces' are used). *out holds 4 floats a corner, 3 corners a triangle, malloc'ed. */
pf_status scene_generate_tangents(const float *positions, const float *normals, const float *uvs,
                                  uint32_t vertex_count, const uint32_t *corners,
                                  uint32_t triangle_count, float **out, pf_error *err);
/* Loaders: fill scene (allocated, zeroed, path set) from the file. */
pf_status scene_load_gltf(pf_scene *scene, int binary_hint, pf_error *err);
pf_status scene_load_obj(pf_scene *scene, pf_error *err);

/* Completes a loaded scene: order, flags, counts, default camera, "no triangles". */
pf_status scene_finalize(pf_scene *scene, pf_error *err);

/* One PF_LOG_WARN per key per scene; the message should name the feature. */
void scene_warn_once(pf_scene *scene, const char *key, const char *format, ...)
    __attribute__((format(printf, 3, 4)));

/*
 * Whether the scene may read path, a file its scene file refers to: always
 * with allow_outside_dir, else when path stays inside the scene file's
 * directory once symbolic links are resolved (scene_paths.c). The file's
 * directory must exist and is resolved, and the file too when it exists (a
 * link to a file elsewhere is caught); a missing file inside is left for the
 * reader to report.
 */
int scene_path_allowed(const pf_scene *scene, const char *path);

/* Reads a whole file; *out is NUL-terminated (not counted in *size). PF_ERR_IO names path. */
pf_status scene_read_file(const char *path, char **out, size_t *size, pf_error *err);

/* animation_math.c */
void scene_mat4_identity(float m[16]);
void scene_mat4_from_trs(const float t[3], const float r[4], const float s[3], float m[16]);
void scene_mat4_mul(const float a[16], const float b[16], float out[16]);
void scene_mat4_point(const float m[16], const float p[3], float out[3]);
void scene_mat4_vector(const float m[16], const float v[3], float out[3]);
/* Inverse transpose of the upper 3×3 (for normals), column-major 3×3; returns its det. */
float scene_mat4_normal_matrix(const float m[16], float out[9]);
void scene_mat3_vector(const float m[9], const float v[3], float out[3]);
void scene_quat_normalize(float q[4]);
float scene_vec3_normalize(float v[3]);
void scene_cross(const float a[3], const float b[3], float out[3]);
/* The unit normal of triangle a, b, c (counter-clockwise front; 0 when degenerate). */
void scene_triangle_normal(const float a[3], const float b[3], const float c[3], float out[3]);
/* Writes the unit face normal of triangle p[0..8] (counter-clockwise front) to all three corners n[0..8]. */
void scene_face_normals(const float p[9], float n[9]);
/* Samples a channel at time (clamped to its key range); out has channel->components. */
void scene_channel_sample(const scene_channel *channel, double time, float *out);

/*
 * scene_eval.c, for the triangles it flattens and deform.c's: triangle t of frame, whose
 * world vertices and (unnormalised) normals are written, widens the frame's bounds and
 * gets unit normals, a zero or degenerate one replaced by the face normal.
 */
void scene_finish_triangle(pf_scene_frame *frame, size_t t);
/* One corner's PF_CORNER_TEXELS texels from its mesh attributes (SCENE_CORNER_FLOATS) and
 * its tangent in world space (normalised here; 0 where degenerate): a mirroring transform
 * (det < 0) flips the bitangent's sign with the winding. */
void scene_corner_texels(const float corner[SCENE_CORNER_FLOATS], const float tangent[3],
                         float det, float (*texels)[4]);

/* World matrices of every node at time_seconds (scene_eval.c; nodes outside the scene
 * stay identity); *out has node_count + 1 entries, malloc'ed. */
pf_status scene_world_matrices(const pf_scene *scene, double time_seconds, float (**out)[16],
                               pf_error *err);
/* deform.c: fills the triangles of every deforming node into frame (rest of the frame
 * already evaluated at time_seconds with those matrices) and widens its bounds. */
/* fn (NULL: pf_deform_vertices_host) deforms each node's vertices; the host gathers them. */
pf_status scene_deform_nodes(const pf_scene *scene, double time_seconds,
                             const float (*world)[16], pf_scene_frame *frame, pf_deform_fn fn,
                             void *user, pf_deform_report *report, pf_error *err);
void scene_deform_mesh_free(scene_deform_mesh *deform);

#endif
