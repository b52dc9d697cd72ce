/*
 * core/scene: scene import (glTF 2.0 .gltf/.glb, OBJ/MTL), animation sampling,
 * and flat world-space arrays ready to upload to the GPU.
 *
 * Units follow glTF: meters; emitted radiance in W/(sr·m²)
 * (emissiveFactor × KHR_materials_emissive_strength), from the front
 * (counter-clockwise) face, or from both faces of a doubleSided material. KHR_lights_punctual
 * intensities are the spec's photometric units, candela (point, spot) and lux
 * (directional), converted at 683 lm/W to the W/sr and W/m² that pf_light
 * holds; a light whose extras.photonfarm.intensityUnits is "W/sr" ("W/m2" for
 * directional) was written radiometric and is taken as it is.
 *
 * Unsupported features produce one PF_LOG_WARN each per scene and map to the
 * nearest supported thing. Bad files fail with a message naming the file and
 * the element ("meshes[2].primitives[0].indices: index 90 out of range (30
 * vertices)"). A scene without a camera gets a default camera framing the
 * scene's bounds, with a warning.
 */
#ifndef PF_SCENE_H
#define PF_SCENE_H

#include "pf_common.h"

#include <stdint.h>

typedef struct pf_scene pf_scene;

/*
 * A material is the glTF metallic-roughness BSDF (spec Appendix B, with
 * KHR_materials_transmission, _ior, _specular and _volume's absorption), given by the parameters
 * of pf_material; shaders/common/materials.glsl evaluates and samples it.
 * Mirrors and smooth glass are its roughness -> 0 limits: at roughness <=
 * PF_MATERIAL_DELTA_ROUGHNESS the specular lobes are deltas.
 *
 * pf_material_kind is not a separate material model but a summary of the
 * parameters (pf_material_classify), for the question the photon, LPV and
 * final-gather kernels ask before they run the BSDF: is light estimated at
 * this surface, or is it passed through by sampling?
 */
typedef enum pf_material_kind {
    PF_MATERIAL_LAMBERT = 0, /* a diffuse base or a rough metal's glossy lobe: estimated there */
    PF_MATERIAL_MIRROR = 1,  /* a metal whose lobe is a delta (smooth) or too sharp for an
                              * estimate (roughness < PF_MATERIAL_GLOSSY_ROUGHNESS):
                              * passed through by sampling */
    PF_MATERIAL_GLASS = 2    /* a fully transmissive dielectric, smooth or rough (or a
                              * smooth metal and glass mix): passed through by sampling */
} pf_material_kind;

/*
 * GGX roughness at or below which a lobe is a delta: alpha = roughness² =
 * 4e-4 rad is 0.023°, the angle one pixel of a 3840-pixel-wide frame spans at
 * a 90° field of view, so a narrower lobe reflects no visible blur and would
 * only add the noise of sampling a near-delta peak.
 */
#define PF_MATERIAL_DELTA_ROUGHNESS 0.02f

/*
 * GGX roughness below which a metal's glossy lobe is too sharp to be
 * estimated from a smooth quantity: a photon density estimate, the LPV or
 * light sampling alone. Those estimates treat reflected light as the
 * irradiance times the directional albedo over pi, a Lambert lobe; at
 * roughness 0.5 (alpha 0.25) GGX's peak is ~4x Lambert's at equal albedo and
 * a light-sampled hit at most a few times the mean, below it the peak grows
 * as 1/alpha^2 (16x at the Blender room's gold, roughness 0.35) and the
 * estimate turns a reflection into a glow. Such a metal is passed through by
 * sampling its lobe (kind PF_MATERIAL_MIRROR), with next-event estimation
 * and MIS at the vertex; a dielectric's sharp coat over a diffuse base keeps
 * the base's estimate and gets MIS with a BSDF ray where it is lit.
 */
#define PF_MATERIAL_GLOSSY_ROUGHNESS 0.5f

/* A material slot without a texture: 0, so that a zeroed material has none (a slot holds
 * its texture's index + 1). */
#define PF_NO_TEXTURE 0u

/* glTF material.alphaMode. */
typedef enum pf_alpha_mode {
    PF_ALPHA_OPAQUE = 0,
    PF_ALPHA_MASK = 1, /* a hit counts where alpha >= alpha_cutoff */
    PF_ALPHA_BLEND = 2 /* a hit counts with probability alpha (stochastic transparency) */
} pf_alpha_mode;

/* std430-compatible (176 bytes): uploaded as-is (scene_types.glsl Material). */
typedef struct pf_material {
    float albedo[3];         /* glTF baseColor, linear: diffuse colour, metal F0, glass tint */
    uint32_t kind;           /* pf_material_kind, set by pf_material_classify */
    float emission[3];       /* emitted radiance, W/(sr·m²); zero if not emissive */
    float ior;               /* dielectric index of refraction; 1.5 default */
    float metallic;          /* 0 dielectric .. 1 metal */
    float roughness;         /* perceptual roughness; GGX alpha = roughness² */
    float transmission;      /* KHR_materials_transmission: 0 opaque .. 1 transmits */
    float specular;          /* KHR_materials_specular factor: the dielectric's reflection
                              * (1 glTF default; 0 leaves a pure Lambert base) */
    float specular_color[3]; /* KHR_materials_specular colour, tints the dielectric's F0 */
    uint32_t flags;          /* PF_MATERIAL_DOUBLE_SIDED, PF_MATERIAL_UNLIT */
    float absorption[3];     /* KHR_materials_volume: Beer-Lambert coefficient inside the
                              * closed mesh, 1/m (-ln(attenuationColor)/attenuationDistance);
                              * 0: clear, or thin-walled (thicknessFactor 0) */
    float alpha;             /* baseColorFactor's alpha (read only for MASK and BLEND) */
    /* Texture slots: 1 + an index into pf_scene_frame.textures, PF_NO_TEXTURE (0) if none.
     * baseColor and emissive multiply their factors (sRGB images); metallicRoughness's
     * G scales roughness and B metallic; normal is tangent space, scaled by normal_scale. */
    uint32_t base_color_texture;
    uint32_t metallic_roughness_texture;
    uint32_t normal_texture;
    uint32_t emissive_texture;
    uint32_t alpha_mode;     /* pf_alpha_mode */
    float alpha_cutoff;      /* MASK: 0.5 unless the file says */
    float normal_scale;      /* normalTexture.scale (1) */
    /* KHR_materials_clearcoat: a dielectric coat (index 1.5) over everything above, of this
     * strength (0: none) and perceptual roughness; its textures' R and G scale them. */
    float clearcoat;
    float clearcoat_roughness;
    uint32_t clearcoat_texture;
    uint32_t clearcoat_roughness_texture;
    /* KHR_materials_specular's textures: A scales specular, RGB (sRGB) specular_color. */
    uint32_t specular_texture;
    uint32_t specular_color_texture;
    /* The coat's normal at one hit, where a normal map tilts the shading normal or the
     * coat's (the kernels' surface_at sets it: the mesh's normal, or clearcoatNormalTexture's,
     * as KHR_materials_clearcoat asks); 0 in a scene's materials, where the coat follows the
     * shading normal. */
    float coat_normal[3];
    uint32_t clearcoat_normal_texture; /* tangent space, scaled as normalTexture */
    float clearcoat_normal_scale;
    /* KHR_materials_sheen: a layer of fibres over the base (under the coat) of this colour
     * (0: none) and sheen roughness, scaled by sheenColorTexture's RGB (sRGB) and
     * sheenRoughnessTexture's A. */
    uint32_t sheen_color_texture;
    uint32_t sheen_roughness_texture;
    float sheen_color[3];
    float sheen_roughness;
} pf_material;

/* glTF material.doubleSided: its emission leaves both faces (Blender's exporter
 * writes it for every material whose backface culling is off, the default). */
#define PF_MATERIAL_DOUBLE_SIDED 1u
/* KHR_materials_unlit: the camera sees the base colour (factor x texture x COLOR_0) as it is,
 * and nothing else sees the surface: rays from a surface, shadow rays and photons pass
 * through it, as Blender's importer (and Cycles) renders it (an emission only camera rays
 * see, transparent to the rest). Its albedo stays the base colour here; the kernels turn it
 * into the emission at a camera hit (scene_textures.glsl). */
#define PF_MATERIAL_UNLIT 2u

/*
 * One texture as a material slot reads it (std430, 48 bytes; scene_types.glsl
 * TextureRef): the image's mip chain in the scene's texel array, the
 * sampler, the texture-coordinate set and KHR_texture_transform.
 * Texels are RGBA8 words (R in the low byte); an sRGB slot (baseColor,
 * emissive) holds sRGB-encoded texels whose mip levels were averaged in linear
 * light, and the shader decodes each texel before filtering.
 * Level k (k < levels) is max(1, width >> k) × max(1, height >> k) texels,
 * right after level k - 1.
 */
typedef struct pf_texture_ref {
    uint32_t first_texel;  /* level 0's first texel */
    uint32_t width, height;
    uint32_t sampling;     /* PF_TEXTURE_* bits below */
    float transform[6];    /* uv' = (t0 u + t1 v + t2, t3 u + t4 v + t5) */
    uint32_t padding[2];
} pf_texture_ref;

/* pf_texture_ref.sampling: levels - 1 in bits 0..4, then the sampler and slot. */
#define PF_TEXTURE_LEVELS_MASK 0x1Fu
#define PF_TEXTURE_WRAP_S_SHIFT 5u /* 2 bits each: PF_TEXTURE_WRAP_* */
#define PF_TEXTURE_WRAP_T_SHIFT 7u
#define PF_TEXTURE_WRAP_REPEAT 0u
#define PF_TEXTURE_WRAP_CLAMP 1u
#define PF_TEXTURE_WRAP_MIRROR 2u
#define PF_TEXTURE_MAG_NEAREST (1u << 9)
#define PF_TEXTURE_MIN_NEAREST (1u << 10)
#define PF_TEXTURE_NO_MIPS (1u << 11) /* minFilter NEAREST or LINEAR: level 0 only */
#define PF_TEXTURE_SRGB (1u << 12)
#define PF_TEXTURE_TEXCOORD_1 (1u << 13)

/* The most texels (RGBA8 words, mip chains included) a scene's textures may take: 256 MiB. */
#define PF_SCENE_TEXEL_BUDGET (64u << 20)
/* The longest edge and the most pixels an image may have before it is decoded. */
#define PF_IMAGE_MAX_EDGE 16384u
#define PF_IMAGE_MAX_PIXELS (64u << 20)

/*
 * KHR_materials_sheen's directional albedo E(μ, r) and a Lambert base's share B(μ, r) under
 * it (sheen_albedo_table.c, made by sheen_albedo_gen.c): two PF_SHEEN_ALBEDO_SIZE² tables,
 * μ = k/31 by row, r = j/31 by column (materials.glsl sheen_table).
 */
#define PF_SHEEN_ALBEDO_SIZE 32u
#define PF_SHEEN_ALBEDO_ENTRIES (PF_SHEEN_ALBEDO_SIZE * PF_SHEEN_ALBEDO_SIZE)
extern const float pf_sheen_albedo[2 * PF_SHEEN_ALBEDO_ENTRIES];

/*
 * The materials buffer every kernel that reads surfaces binds (scene_geometry.glsl
 * scene_material): the sheen's tables, then the count materials. The tables travel in it
 * because a const array of their size in GLSL makes llvmpipe copy it into every
 * invocation's scratch at each look-up, and compile for minutes. pf_materials_buffer_write
 * fills pf_materials_buffer_bytes(count) bytes at out.
 */
uint64_t pf_materials_buffer_bytes(uint32_t count);
void pf_materials_buffer_write(const pf_material *materials, uint32_t count, void *out);

/* Sets material->kind from its parameters (see pf_material_kind). */
void pf_material_classify(pf_material *material);
/* Constructors of the limits tests and generated scenes use, classified. */
pf_material pf_material_lambert(float r, float g, float b); /* specular 0: diffuse only */
pf_material pf_material_mirror(float r, float g, float b);  /* metal, roughness 0, F0 = rgb */
pf_material pf_material_glass(float ior, float r, float g, float b); /* smooth, tinted */

/*
 * The scene's device bindings (set 0) in every kernel that reads surfaces:
 * shaders/common/scene_binding_numbers.glsl names the same numbers, and a
 * kernel numbers its own bindings from PF_SCENE_BINDING_COUNT on.
 */
typedef enum pf_scene_binding {
    PF_SCENE_BINDING_PARAMS = 0,   /* the kernel's parameters */
    PF_SCENE_BINDING_VERTICES,
    PF_SCENE_BINDING_NORMALS,
    PF_SCENE_BINDING_TRIANGLE_MATERIALS,
    PF_SCENE_BINDING_MATERIALS,
    PF_SCENE_BINDING_LIGHTS,
    PF_SCENE_BINDING_EMISSIVE,     /* photon_trace: its emitters */
    PF_SCENE_BINDING_CORNERS,      /* texture coordinates, colours, tangents */
    PF_SCENE_BINDING_TEXTURES,     /* the texture table */
    PF_SCENE_BINDING_TEXELS,       /* every texture's mip chain */
    PF_SCENE_BINDING_COUNT
} pf_scene_binding;

/*
 * What a frame's scene uses beyond the plain BSDF and its emitters: alpha-tested materials
 * (MASK, BLEND), per-corner attributes (textures, COLOR_0), punctual lights, transmissive
 * materials, emissive materials, specular ones (a mirror-like metal or a glass, passed
 * through by sampling: pf_material_kind), clear-coated ones. A kernel that reads surfaces has a plain variant, compiled without the first
 * two's code, and a "<kernel>_surfaces" one (shaders/pf_shaders.cmake's pf-variant) for a
 * frame with either (PF_SURFACE_TEXTURED); each pipeline is made for the frame's whole set,
 * its specialisation constants (pf_scene_spec_constants; scene_binding_numbers.glsl) saying
 * what the frame has, so that code for what it lacks is compiled out. llvmpipe runs every
 * line of a module for every invocation, masked where no lane takes it: the reference
 * wavefront's vertex kernel on the Cornell box (no punctual light, no glass) ran 15-22 %
 * faster without the lights' loop and the transmission lobes (bench/RESULTS.md); a scene lit
 * by punctual lights alone (Blender's exports) drops the emitters' sampling and MIS, and
 * one without specular materials the kernels' specular chains (their in-kernel traversal).
 */
#define PF_SURFACE_ALPHA 1u
#define PF_SURFACE_CORNERS 2u
/* The rest say what the frame lacks, so that a features word left 0 (a caller that never
 * asked pf_scene_frame_surface_features) compiles everything in. */
#define PF_SURFACE_NO_LIGHTS 4u        /* no punctual light (point, spot, directional) */
#define PF_SURFACE_NO_TRANSMISSION 8u  /* no material with transmission > 0 */
#define PF_SURFACE_NO_EMISSION 16u     /* no material with emission > 0 */
#define PF_SURFACE_NO_SPECULAR 32u     /* every material PF_MATERIAL_LAMBERT, and no
                                        * metallic-roughness texture that may make one not */
#define PF_SURFACE_NO_MANY_LIGHTS 64u  /* at most PF_DIRECT_LIGHTS_EVERY_MAX punctual lights */
#define PF_SURFACE_NO_CLEARCOAT 128u   /* no material with clearcoat > 0 */
#define PF_SURFACE_NO_SHEEN 256u       /* no material with a sheen colour > 0 */
#define PF_SURFACE_TEXTURED (PF_SURFACE_ALPHA | PF_SURFACE_CORNERS)
#define PF_SURFACE_VARIANTS 512u
/*
 * Next-event estimation (shaders/common/direct_light.glsl) casts a shadow ray to every
 * punctual light of a frame with at most this many; past it, each vertex resamples
 * PF_DIRECT_LIGHT_SAMPLES lights (a path tracer's vertex; a pixel's first vertex in the
 * presets that estimate it once a pass, PF_DIRECT_LIGHT_PIXEL_SAMPLES), each kept from
 * PF_DIRECT_LIGHT_CANDIDATES
 * picked by power (resampled importance sampling), so that a vertex's work no longer grows
 * with the lights (a frame with hundreds met llvmpipe's loop cap). The shader's constants of
 * the same names must match.
 */
#define PF_DIRECT_LIGHTS_EVERY_MAX 8u
#define PF_DIRECT_LIGHT_SAMPLES 4u
#define PF_DIRECT_LIGHT_PIXEL_SAMPLES 16u /* final's, fast's and preview's first vertex */
#define PF_DIRECT_LIGHT_CANDIDATES 8u
/* Shadow rays a vertex's direct light casts at most: the emissive sample's and a punctual
 * light's each, or the sampled ones' (direct_light.glsl's direct_light_slots). */
static inline uint32_t pf_direct_light_slots(uint32_t light_count)
{
    return 1u + (light_count > PF_DIRECT_LIGHTS_EVERY_MAX ? PF_DIRECT_LIGHT_SAMPLES : light_count);
}
#define PF_SPEC_SCENE_HAS_ALPHA 1001u
#define PF_SPEC_SCENE_HAS_CORNERS 1002u
#define PF_SPEC_SCENE_HAS_LIGHTS 1003u
#define PF_SPEC_SCENE_HAS_TRANSMISSION 1004u
#define PF_SPEC_SCENE_HAS_EMITTERS 1005u
#define PF_SPEC_SCENE_HAS_SPECULAR 1006u
#define PF_SPEC_SCENE_HAS_MANY_LIGHTS 1008u /* 1007 is the pixel filter's */
#define PF_SPEC_SCENE_HAS_CLEARCOAT 1009u
#define PF_SPEC_SCENE_HAS_SHEEN 1010u
#define PF_SCENE_SPEC_CONSTANTS 9u
/* The specialisation constants of features: constant ids and their values (0 or 1). */
void pf_scene_spec_constants(uint32_t features, uint32_t ids[PF_SCENE_SPEC_CONSTANTS],
                             uint32_t values[PF_SCENE_SPEC_CONSTANTS]);

typedef enum pf_light_kind {
    PF_LIGHT_POINT = 0,
    PF_LIGHT_SPOT = 1,
    PF_LIGHT_DIRECTIONAL = 2
} pf_light_kind;

/* std430-compatible (64 bytes). */
typedef struct pf_light {
    float position[3];     /* world space (point, spot) */
    uint32_t kind;         /* pf_light_kind */
    float direction[3];    /* unit vector the light travels along (spot, directional) */
    float range;           /* 0 = infinite */
    float intensity[3];    /* color × intensity: W/sr (point, spot), W/m² (directional) */
    float cos_inner_cone;  /* spot: full intensity inside this */
    float cos_outer_cone;  /* spot: zero outside this; smooth falloff between */
    /* The lights' alias table by power, where direct light samples them (Vose 1991: column i
     * keeps light i below pick_threshold, else gives pick_alias; pick_pdf the probability
     * of light i): the renderer fills these on upload; the scene leaves them 0. */
    float pick_threshold;
    uint32_t pick_alias;
    float pick_pdf;
} pf_light;

typedef struct pf_camera {
    float position[3];
    float forward[3];      /* unit view direction (-Z of the camera node) */
    float up[3];           /* unit, orthogonal to forward (+Y of the node) */
    float right[3];        /* unit, forward × up */
    float yfov;            /* vertical field of view, radians (perspective) */
    float aspect;          /* width/height from the file, 0 = use the image's */
    float znear, zfar;     /* zfar 0 = infinite */
    uint32_t orthographic; /* 1: parallel rays (glTF orthographic), 0: a pinhole */
    float ymag;            /* orthographic: half the view's height, world units */
} pf_camera;

/*
 * One frame's scene, world space, flat. vertices and normals hold 3 entries per
 * triangle (xyz + w padding, w = 0), so triangle t is vertices[3t..3t+2].
 * Triangles are in a stable order across frames of one scene (node order, then
 * primitive order), so per-triangle data can be compared frame to frame.
 */
/* Per-corner attributes: PF_CORNER_TEXELS RGBA32F texels a corner, 3 corners a triangle:
 * (TEXCOORD_0.uv, TEXCOORD_1.uv), COLOR_0 (rgba, 1 where absent),
 * tangent (world xyz, w = bitangent sign; 0 where absent). */
#define PF_CORNER_TEXELS 3u

typedef struct pf_scene_frame {
    uint32_t triangle_count;
    float (*vertices)[4];
    float (*normals)[4];          /* shading normals (geometric if the file has none) */
    float (*corners)[4];          /* 3 × PF_CORNER_TEXELS per triangle; NULL when no material
                                   * has a texture and no mesh has COLOR_0 */
    uint32_t *triangle_material;  /* index into materials */
    uint32_t *triangle_node;      /* index of the glTF node (or OBJ object) it came from */
    uint32_t material_count;
    pf_material *materials;
    uint32_t light_count;
    pf_light *lights;
    uint32_t emissive_triangle_count; /* triangles whose material emits */
    pf_camera camera;
    float bounds_min[3], bounds_max[3]; /* of all triangles; zero box if none */
    /* The scene's textures (owned by the scene, the same in every frame of it).
     * texture_set names them: frames with the same non-zero texture_set have the same
     * textures (every pf_scene_load gets its own; 0: a frame built by hand, never cached). */
    uint64_t texture_set;
    uint32_t texture_count;
    const pf_texture_ref *textures;
    uint64_t texel_count;
    const uint32_t *texels;
} pf_scene_frame;

/* The PF_SURFACE_* bits of frame: corners when it has them, alpha when a material tests it,
 * and the NO_ bits for what it lacks: punctual lights, a transmissive, an emissive, a specular
 * material (a mirror or a glass, or one a texture may make so). */
uint32_t pf_scene_frame_surface_features(const pf_scene_frame *frame);

/* Measures of a frame (frame_measures.c). 1 when some triangle's material is passed
 * through by sampling (a mirror, glass or a sharp metal: photons can make caustics). */
int pf_scene_frame_has_specular(const pf_scene_frame *frame);
/* The triangles' total area (m²) and the bounding box's diagonal (m). */
double pf_scene_frame_area(const pf_scene_frame *frame);
double pf_scene_frame_diagonal(const pf_scene_frame *frame);
/* The largest coordinate magnitude or extent of the frame, at least 1 (m). */
float pf_scene_frame_magnitude(const pf_scene_frame *frame);

typedef struct pf_scene_info {
    const char *path;
    uint32_t node_count;
    uint32_t mesh_count;
    uint32_t material_count;
    uint32_t light_count;          /* punctual lights */
    uint32_t animation_count;      /* in the file (all play unless one was chosen) */
    int32_t animation;             /* the one chosen to play (pf_scene_load_options), else -1 */
    uint32_t material_variant_count; /* KHR_materials_variants in the file */
    int32_t material_variant;      /* the one the primitives wear (pf_scene_load_options), else -1 */
    uint32_t triangle_count;       /* per frame (constant across frames) */
    uint32_t emissive_triangle_count;
    double fps;                    /* asset.extras.fps, else 24 */
    uint32_t frame_count;          /* asset.extras.frames, else from the animation length, >= 1 */
    uint32_t frame_offset;         /* 1 when frame f is at time f / fps (Blender's exporter), else 0 */
    double duration_seconds;       /* last keyframe time, 0 if static */
    int has_camera;                /* 0: a default camera frames the scene */
    int geometry_animated;         /* some animated node carries a mesh */
    int lights_animated;           /* some animated node carries a light */
    int camera_animated;
    int has_specular;              /* any mirror or glass material */
    uint32_t texture_count;        /* material slots with a texture */
    uint32_t image_count;          /* images decoded for them */
    uint64_t texel_count;          /* their mip chains, RGBA8 texels */
    double decode_ms;              /* decoding the images and building the mip chains */
    int has_alpha;                 /* a material with alphaMode MASK or BLEND */
    int has_emissive;
    uint32_t skin_count;
    uint32_t deformed_node_count;  /* mesh nodes skinned or morphed each frame */
    uint64_t deformed_vertex_count; /* the vertices they deform each frame */
    int deformation_animated;      /* some deformation changes over time (geometry_animated too) */
} pf_scene_info;

/*
 * Loads a scene by extension (.gltf, .glb, .obj; case-insensitive). Fails with
 * PF_ERR_IO (missing/unreadable), PF_ERR_FORMAT (malformed, truncated, wrong
 * type, NaN/Inf data, indices out of range, zero triangles) naming file and element.
 */
pf_status pf_scene_load(const char *path, pf_scene **out, pf_error *err);

typedef struct pf_scene_load_options {
    /*
     * 0 (the default): files a scene refers to (glTF buffer URIs, OBJ mtllib)
     * must lie in the scene file's directory once "../" and symbolic links
     * are resolved, so a scene on a farm's shared storage cannot make a
     * worker read what lies beside it. 1: relative references may lead
     * anywhere (absolute URIs stay refused: glTF allows none).
     */
    int allow_outside_scene_dir;
    /*
     * NULL (the default): every animation in the file plays, as its author saw them
     * (Blender writes one action per object). Else the one that plays: its name, or
     * its index in the file; the frame count is then that animation's. A name or
     * index the file lacks is PF_ERR_INVALID naming it and the file's animations.
     */
    const char *animation;
    /*
     * NULL (the default): each primitive's own material (glTF's "material"). Else the
     * KHR_materials_variants variant whose materials the primitives wear (a product's
     * colourways, which Blender exports from its glTF Variants panel): its name, or its index
     * in the file; a primitive without a mapping for it keeps its own. A name or index the
     * file lacks is PF_ERR_INVALID naming it and the file's variants.
     */
    const char *material_variant;
} pf_scene_load_options;

/* pf_scene_load with options (NULL: the defaults above). */
pf_status pf_scene_load_with(const char *path, const pf_scene_load_options *options,
                             pf_scene **out, pf_error *err);
void pf_scene_destroy(pf_scene *scene);
const pf_scene_info *pf_scene_get_info(const pf_scene *scene);

/* Frame numbers start at 1; frame f is sampled at time (f - 1 + frame_offset) / fps:
 * (f - 1) / fps, or f / fps in a file Blender exported (pf_scene_info.frame_offset). */
double pf_scene_frame_time(const pf_scene *scene, int64_t frame);

/*
 * Samples every animation at time_seconds (clamped to each sampler's range),
 * composes the node hierarchy and fills out with world-space arrays. out is
 * owned by the caller: release with pf_scene_frame_free. Thread-safe for one
 * scene used from several threads.
 */
pf_status pf_scene_eval(const pf_scene *scene, double time_seconds, pf_scene_frame *out,
                        pf_error *err);
void pf_scene_frame_free(pf_scene_frame *frame);

/* What pf_scene_deform did to a frame: the `deform` stage row's counters. */
typedef struct pf_deform_report {
    uint32_t skinned_meshes;  /* mesh nodes deformed by their skin */
    uint32_t morphed_meshes;  /* mesh nodes whose morph targets were blended */
    uint64_t vertices;        /* vertices deformed */
} pf_deform_report;

/*
 * pf_scene_eval in two halves, so that the frame pipeline can time deformation as
 * its own stage. pf_scene_eval_rigid fills everything but the vertices and normals
 * of deforming meshes (skins, morph targets: pf_scene_info.deformed_node_count), which
 * it leaves zero and out of the bounds (an inverted box, min > max, when every mesh
 * deforms); pf_scene_deform, given that frame at the same time, fills them and widens
 * and closes the bounds. Deformation is glTF's: morph targets add
 * their weighted deltas to the rest positions, normals and tangents (weights from the
 * node, else the mesh, animated by `weights` channels); a skin then blends its joint
 * matrices (joint world × inverse bind) by the vertex weights (linear blend skinning),
 * normals by the blended matrix's inverse transpose, and a skinned mesh ignores its own
 * node's transform (glTF §3.7.3.3). Thread-safe as pf_scene_eval is.
 */
pf_status pf_scene_eval_rigid(const pf_scene *scene, double time_seconds, pf_scene_frame *out,
                              pf_error *err);
pf_status pf_scene_deform(const pf_scene *scene, double time_seconds, pf_scene_frame *frame,
                          pf_deform_report *report, pf_error *err);

/*
 * Deformation's per-vertex half, which a device may do instead of the host (issue 39): one
 * deforming mesh node's rest pose and this frame's morph weights and matrices in, every
 * vertex's result out. Per vertex v: p = positions[v] + Σ_t weights[t]·target_positions[v][t]
 * (the same for normals and, into tangent, the tangent deltas); M = Σ_i joint_weights[v][i]
 * · matrices[joints[v][i]] over its influences (identity where they sum to 0), or
 * matrices[0] for every vertex when influences is 0 (a node only morphed); then
 * position = M·p, normal = cof(M)·n (unnormalised), matrix = M (3×4, column-major).
 */
/* JOINTS_0/WEIGHTS_0 and JOINTS_1/WEIGHTS_1: 8 influences a vertex at most. */
#define PF_DEFORM_MAX_INFLUENCES 8
typedef struct pf_deform_node {
    uint32_t vertex_count, target_count;
    uint32_t influences;       /* 0, 4 or 8 a vertex */
    uint32_t matrix_count;
    const float (*positions)[3];
    const float (*normals)[3];
    const float *target_positions; /* [vertex][target][3]; NULL: no such deltas */
    const float *target_normals;
    const float *target_tangents;
    const float *weights;          /* target_count */
    const uint16_t (*joints)[PF_DEFORM_MAX_INFLUENCES];
    const float (*joint_weights)[PF_DEFORM_MAX_INFLUENCES];
    const float (*matrices)[12];   /* the skin's joint world × inverse bind, or the node's */
    /* Whose rest pose this is: the scene's load (pf_scene_frame.texture_set, unique in the
     * process) and the node's index; a device keeps it under these. */
    uint64_t scene_load;
    uint32_t node;
} pf_deform_node;

/* Where the results go, vertex_count each (tangent only with target_tangents). */
typedef struct pf_deform_vertices {
    float (*position)[3];
    float (*normal)[3];
    float (*tangent)[3];
    float (*matrix)[12];
} pf_deform_vertices;

typedef pf_status (*pf_deform_fn)(void *user, const pf_deform_node *node,
                                  const pf_deform_vertices *out, pf_error *err);

/* The per-vertex half on the host's vector code (what pf_scene_deform uses). */
pf_status pf_deform_vertices_host(void *user, const pf_deform_node *node,
                                  const pf_deform_vertices *out, pf_error *err);

/* pf_scene_deform with vertices deformed by fn (NULL: pf_deform_vertices_host). */
pf_status pf_scene_deform_with(const pf_scene *scene, double time_seconds, pf_scene_frame *frame,
                               pf_deform_fn fn, void *user, pf_deform_report *report,
                               pf_error *err);

/*
 * Camera for rendering width×height: when the file gives an aspect ratio that
 * differs from the image's, yfov is kept and the image's aspect is used (glTF §3.10.3: the
 * viewport's aspect wins); an orthographic camera's larger magnification spans the image's
 * longer side, as Blender's importer reads it. Writes the half extents of the image plane
 * at distance 1 in *tan_half_x and *tan_half_y; an orthographic camera's, in world units,
 * at any distance.
 */
void pf_camera_image_plane(const pf_camera *camera, uint32_t width, uint32_t height,
                           float *tan_half_x, float *tan_half_y);
/* The camera ray through ndc (x right, y up, each -1..1 across the image) for the half
 * extents of pf_camera_image_plane: origin and unit direction (shaders/common/camera.glsl's
 * camera_ray on the host). */
void pf_camera_ray(const pf_camera *camera, float tan_half_x, float tan_half_y, double ndc_x,
                   double ndc_y, double origin[3], double direction[3]);

/*
 * Animation primitives, exposed so tests can check them against hand-computed
 * values. Quaternions are (x, y, z, w) as in glTF.
 */
void pf_quat_slerp(const float a[4], const float b[4], float t, float out[4]);
/* Cubic Hermite spline as glTF CUBICSPLINE defines it (dt = t_{k+1} - t_k). */
float pf_cubic_hermite(float v0, float out_tangent0, float v1, float in_tangent1, float dt,
                       float t);

/*
 * A point light turned into an equal-power small spherical area light, for
 * comparing `final` with the reference path tracer on scenes lit by point
 * lights (caustic-anim): a path tracer never finds the caustics of a point
 * light (L S+ D paths need to hit the light by chance), an area light it
 * can. Used by tests/render/test_final_caustic.c and bench/final.
 */
/*
 * Replaces frame->lights[light] (a point light of intensity I W/sr, power
 * 4π·I) by a closed UV sphere of `segments` × `rings` triangles (segments ≥ 3,
 * rings ≥ 2) of the given radius centred on the light, front faces outward,
 * with a new black Lambert material emitting Le = 4·I / A, A the
 * polyhedron's exact area, so its power π·Le·A equals the point light's.
 * The frame's arrays are reallocated in place (pf_scene_frame_free still
 * frees them); bounds and emissive_triangle_count are updated, the light is
 * removed from frame->lights. New triangles carry node index UINT32_MAX (no
 * glTF node). Fails with PF_ERR_INVALID (light out of range, not a point
 * light, bad sphere size) or PF_ERR_NOMEM; the frame is unchanged on
 * PF_ERR_INVALID and still freeable on PF_ERR_NOMEM.
 */
pf_status pf_scene_frame_point_light_to_sphere(pf_scene_frame *frame, uint32_t light,
                                              float radius, uint32_t segments,
                                              uint32_t rings, pf_error *err);

#endif
