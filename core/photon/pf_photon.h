/*
 * core/photon: photon maps (Jensen 2001; on the GPU after Galacz 2013, with
 * the fixes listed in REFERENCE.md). This header is the module's interface:
 * the compact photon record and its packing, and the GPU photon grid that
 * radiance estimates gather from.
 *
 * Photon record (20 bytes, std430 mirror in shaders/common/photon_types.glsl,
 * read there as 5 uint words since a vec3 member would pad a struct to 32):
 *   position   3 floats, world space, exact;
 *   flux       RGB9E5 (shared 5-bit exponent, 9-bit mantissas; the
 *              EXT_texture_shared_exponent encoding), in units of the map's
 *              flux scale (the caller divides by it, e.g. the power of one
 *              emitted photon, so values sit near 1 where RGB9E5 keeps 3
 *              significant digits; raw watts of a 6M-photon map would fall
 *              into the format's denormal range);
 *   directions two 16-bit octahedral unit vectors (8 bits per coordinate):
 *              low half the direction the photon travelled (incoming), high
 *              half the normal of the surface it was stored on; the gather
 *              uses both to reject photons from the wrong side of a surface
 *              or from a differently oriented one (no light leaking round corners).
 */
#ifndef PF_PHOTON_H
#define PF_PHOTON_H

#include "pf_bih.h"
#include "pf_common.h"
#include "pf_scene.h"
#include "pf_vk.h"

#include <stdint.h>

typedef struct pf_photon {
    float position[3];
    uint32_t flux;        /* RGB9E5 */
    uint32_t directions;  /* incoming (bits 0-15), surface normal (bits 16-31): octahedral 8+8 */
} pf_photon;

_Static_assert(sizeof(pf_photon) == 20, "pf_photon is the 20-byte record of photon_types.glsl");

/* Largest value RGB9E5 holds: (2^9 - 1) / 2^9 × 2^16. Larger channels clamp to it. */
#define PF_RGB9E5_MAX 65408.0f

/*
 * RGB9E5 packing, rounding to nearest: negative and NaN channels become 0,
 * channels above PF_RGB9E5_MAX clamp. Relative error ≤ 2^-9 of the largest
 * channel above 2^-15.
 */
uint32_t pf_rgb9e5_pack(const float rgb[3]);
void pf_rgb9e5_unpack(uint32_t packed, float rgb[3]);

/*
 * Octahedral unit-vector packing (Cigolle et al., "A Survey of Efficient
 * Representations for Independent Unit Vectors", JCGT 3(2), 2014) at 8 bits
 * per coordinate, each 128 + round(127 v) so that axis-aligned vectors are
 * exact: angular error below 1 degree. A zero vector packs as +z.
 */
uint16_t pf_octahedral_pack8(const float direction[3]);
void pf_octahedral_unpack8(uint16_t packed, float direction[3]);

/* Packs one photon; flux is already divided by the map's flux scale. */
void pf_photon_pack(const float position[3], const float flux[3], const float incoming[3],
                    const float normal[3], pf_photon *out);
void pf_photon_unpack(const pf_photon *photon, float position[3], float flux[3],
                      float incoming[3], float normal[3]);

/*
 * The photon grid on the GPU: photons sorted by the cell they fall in, with
 * each cell's [start, end) range, so a gather of radius r <= cell_size visits
 * the 27 cells around the query.
 *
 * Cell edge = the gather radius given at build. A dense grid (key = linear
 * cell index of the photons' bounding box) when it needs at most
 * PF_PHOTON_GRID_DENSE_FACTOR cells per photon; otherwise a spatial hash of
 * the cell's 2×2×2 block (Teschner et al. 2003 primes 73856093, 19349663,
 * 83492791; the cell's place in its block in the key's low 3 bits, so that
 * a block's ranges share a cache line) into a power-of-two table of at
 * least one bucket per photon, for sparse maps (a few lit surfaces in a large
 * scene). Hash collisions only add candidates: the gather tests every
 * candidate's distance, and visits each bucket once even when two
 * neighbouring cells share it.
 *
 * Photons are placed in cell order by a counting sort: each counts itself in
 * its key (an atomic, which also gives its rank in the cell), a blocked
 * prefix sum turns the counts into each cell's first slot, and each photon
 * moves to first slot + rank. A cell's order is the atomics' (estimates sum
 * the same photons, up to float rounding). It replaced three 8-bit radix
 * passes, 120 of the 150 ms a 184k-photon grid took on lavapipe: the Cornell
 * box's four passes of grids went from 0.65 s to 0.17-0.30 s.
 */
#define PF_PHOTON_GRID_DENSE_FACTOR 2u

typedef struct pf_photon_grid pf_photon_grid;

typedef struct pf_photon_grid_info {
    float origin[3];      /* corner of cell (0, 0, 0) */
    float cell_size;
    uint32_t dims[3];     /* dense grid cells per axis (all 0 in hash mode) */
    uint32_t hashed;      /* 1: spatial hash */
    uint32_t table_size;  /* cells (dense) or buckets (hash) */
    uint32_t photon_count;
    uint32_t occupied;    /* non-empty cells or buckets (filled by pf_photon_grid_stats) */
    uint32_t largest;     /* most photons in one cell or bucket (pf_photon_grid_stats) */
} pf_photon_grid_info;

pf_status pf_photon_grid_create(pf_vk_context *ctx, pf_photon_grid **out, pf_error *err);
void pf_photon_grid_destroy(pf_photon_grid *grid);

/*
 * Builds the grid over count photons uploaded from the host, for gathers of
 * radius <= radius. Replaces the previous grid. Zero photons give an empty
 * grid (every gather finds nothing). Fails with PF_ERR_INVALID for a radius
 * that is not finite and > 0 or non-finite photon positions, PF_ERR_LIMIT
 * when a buffer would exceed the device's maxStorageBufferRange (the message
 * says how many photons fit), PF_ERR_VULKAN.
 */
pf_status pf_photon_grid_build(pf_photon_grid *grid, const pf_photon *photons, uint32_t count,
                               float radius, pf_error *err);

/*
 * The same over a map already on the device (pf_photon_trace's output):
 * photons is read, not kept; bounds_min/max must contain every photon (the
 * scene's box: photons lie on its triangles; positions just outside by
 * rounding land in the border cells). Records its GPU time
 * (pf_photon_grid_gpu_ms).
 */
pf_status pf_photon_grid_build_device(pf_photon_grid *grid, pf_vk_buffer *photons, uint32_t count,
                                      const float bounds_min[3], const float bounds_max[3],
                                      float radius, pf_error *err);

/*
 * Loop guard of the estimates below (PHOTON_ESTIMATE_MAX_ITERATIONS as
 * shaders/photon_irradiance_probe.comp defines it; kernels default to 32768,
 * see photon_estimate.glsl): llvmpipe silently ends all loops of an
 * invocation after 65,535 iterations in total, so an estimate visits cells
 * and photons in one loop of at most this many steps and says when it
 * stops early. A clustered map (a light touching a wall: one cell holding
 * every photon) reaches it instead of giving a silently wrong value.
 */
#define PF_PHOTON_ESTIMATE_MAX_ITERATIONS 60000u

/*
 * The cone-filtered irradiance estimate of shaders/common/photon_estimate.glsl
 * at query points (xyz + radius in w, radius <= the build radius) on
 * surfaces with the given unit normals (xyz): irradiance[q] in the map's
 * flux units per m² (multiply by pf_photon_maps.flux_scale for W/m²), the
 * radius in w. Every result is written; PF_ERR_LIMIT (naming how many and the
 * first) when queries stopped at the loop guard (their estimates cover only
 * the photons visited), PF_ERR_INVALID without a grid, PF_ERR_VULKAN.
 */
pf_status pf_photon_grid_irradiance(pf_photon_grid *grid, const float (*queries)[4],
                                    const float (*normals)[4], uint32_t query_count,
                                    float (*irradiance)[4], pf_error *err);

/* Largest k of the k-nearest estimate (PHOTON_KNN_MAX in photon_estimate.glsl). */
#define PF_PHOTON_KNN_MAX 64u
/* The k-NN radius never drops below this fraction of the maximum (coincident photons). */
#define PF_PHOTON_KNN_MIN_RADIUS_FRACTION (1.0f / 1024.0f)

/*
 * The adaptive-radius estimate photon_irradiance_knn (for the caustic map):
 * at each query (xyz + maximum radius in w, <= the build radius) the k
 * nearest accepted photons within the maximum, cone-filtered over the k-th
 * distance r_k and divided by π r_k² × the cone's normalisation; with fewer
 * than k, r = the maximum; r >= PF_PHOTON_KNN_MIN_RADIUS_FRACTION × the
 * maximum. irradiance[q]: rgb as pf_photon_grid_irradiance, r in w.
 * PF_ERR_INVALID for k outside [1, PF_PHOTON_KNN_MAX]; otherwise as
 * pf_photon_grid_irradiance (a truncated query keeps the k nearest of the
 * photons visited).
 */
pf_status pf_photon_grid_irradiance_knn(pf_photon_grid *grid, const float (*queries)[4],
                                        const float (*normals)[4], uint32_t query_count,
                                        uint32_t k, float (*irradiance)[4], pf_error *err);

/*
 * Precomputed irradiance (Christensen 1999, "Faster Photon Map Global
 * Illumination"; shaders/common/photon_estimate.glsl's
 * photon_irradiance_lookup): builds `points`, a grid like any other, whose
 * records are the photons of `map` that a coin per photon (a hash of its
 * position, 1 in PF_PHOTON_IRRADIANCE_STRIDE) makes points, each carrying
 * the fixed-radius estimate at its position on its own surface from the
 * photons that are not points (photon_estimate.glsl says why), as a flux
 * word: the cone-filtered sum before the division by π r². A final gather
 * then reads one nearby value instead of summing every photon within the
 * radius. radius: the estimate's, <= map's build radius; also the points
 * grid's build radius (the lookup's reach). bounds as for
 * pf_photon_grid_build_device. The grid's records are the points
 * (photon_count = counts->points; those dropped because their estimate
 * stopped at the loop guard, counts->truncated, sit past every cell), in
 * the order a GPU listed them, then a slot without a photon for each other
 * photon of the map (the build sizes nothing by the count it has not read
 * back). One submission; records its GPU time.
 */
#define PF_PHOTON_IRRADIANCE_STRIDE 4u
typedef struct pf_photon_irradiance_counts {
    uint32_t points;
    uint32_t truncated;
} pf_photon_irradiance_counts;
pf_status pf_photon_grid_build_irradiance(pf_photon_grid *points, const pf_photon_grid *map,
                                          float radius, const float bounds_min[3],
                                          const float bounds_max[3],
                                          pf_photon_irradiance_counts *counts, pf_error *err);
/*
 * pf_photon_grid_build_device of map, then pf_photon_grid_build_irradiance of points from
 * it (radius both grids'), in one submission with no readback in between (issue 44): the
 * points' grid holds a slot for every photon of the map, those after the points without
 * a photon. Errors as the two.
 */
pf_status pf_photon_grid_build_with_irradiance(pf_photon_grid *map, pf_photon_grid *points,
                                               pf_vk_buffer *photons, uint32_t count,
                                               const float bounds_min[3],
                                               const float bounds_max[3], float radius,
                                               pf_photon_irradiance_counts *counts,
                                               pf_error *err);
/*
 * Several grids in one submission (issue 44: a frame's passes are one photon_grid): each
 * job's grid over its count records of photons (a device buffer read, not kept) at its
 * radius, and, with points, that map's irradiance points as
 * pf_photon_grid_build_with_irradiance builds them (counts filled). All lie in bounds. A
 * job whose points list was full is listed again with room for every photon, in a second
 * submission. On failure no job's grids are left built.
 */
typedef struct pf_photon_grid_job {
    pf_photon_grid *grid;
    pf_vk_buffer *photons;
    uint32_t count;
    float radius;
    pf_photon_grid *points;              /* NULL: the map alone */
    pf_photon_irradiance_counts counts;  /* out, with points */
} pf_photon_grid_job;
pf_status pf_photon_grid_build_batch(pf_photon_grid_job *jobs, uint32_t count,
                                     const float bounds_min[3], const float bounds_max[3],
                                     pf_error *err);
/*
 * photon_irradiance_lookup at query points (xyz + the points' estimate
 * radius in w) with unit normals: irradiance[q] rgb as
 * pf_photon_grid_irradiance, w 1 where a point was found, 0 where none was
 * (rgb 0). Errors as pf_photon_grid_irradiance. For tests.
 */
pf_status pf_photon_grid_irradiance_lookup(pf_photon_grid *points, const float (*queries)[4],
                                           const float (*normals)[4], uint32_t query_count,
                                           float (*irradiance)[4], pf_error *err);
/* GPU milliseconds of the last build (< 0 without timestamps). */
double pf_photon_grid_gpu_ms(const pf_photon_grid *grid);

/* The grid's parameters (valid after a build). */
pf_photon_grid_info pf_photon_grid_get_info(const pf_photon_grid *grid);
/*
 * A grid's parameters as shaders/common/photon_grid.glsl's PhotonGrid takes
 * them from push constants: vec3 origin, float inv_cell, uvec3 dims, uint
 * hashed, uint table_size (36 bytes; a kernel's Push holds it at an offset
 * that is a multiple of 16, as its vec3 needs).
 */
typedef struct pf_photon_grid_push {
    float origin[3];
    float inv_cell;
    uint32_t dims[3];
    uint32_t hashed;
    uint32_t table_size;
} pf_photon_grid_push;
_Static_assert(sizeof(pf_photon_grid_push) == 36, "pf_photon_grid_push mirrors PhotonGrid");
pf_photon_grid_push pf_photon_grid_push_of(const pf_photon_grid_info *info);

/*
 * The built grid's device buffers, for kernels that gather from it
 * (photon_estimate.glsl's grid_records, grid_flux and grid_ranges, with the
 * grid's parameters from pf_photon_grid_get_info); all NULL before a build. The
 * grid keeps ownership; a rebuild or destroy invalidates them.
 */
typedef struct pf_photon_grid_view {
    pf_vk_buffer *records; /* per photon in cell order: position bits, directions (4 words) */
    pf_vk_buffer *flux;    /* per photon in cell order: its RGB9E5 flux (a word) */
    pf_vk_buffer *ranges;  /* uvec2 [start, end) per cell or bucket (padded to an even count) */
} pf_photon_grid_view;

pf_photon_grid_view pf_photon_grid_view_get(const pf_photon_grid *grid);

/* Downloads the ranges and fills info->occupied and info->largest. */
pf_status pf_photon_grid_stats(pf_photon_grid *grid, pf_photon_grid_info *info, pf_error *err);

/*
 * Gathers on the GPU through shaders/common/photon_grid.glsl (the code every
 * radiance estimate uses): for each query (xyz + radius in w, radius <= the
 * build radius) the indices (into the photons given to the build) of every
 * photon with |p - x|² <= r², in any order. counts[q] is the true number
 * found; at most capacity indices per query are written to
 * indices[q * capacity ...]. For tests and diagnostics.
 */
pf_status pf_photon_grid_gather(pf_photon_grid *grid, const float (*queries)[4],
                                uint32_t query_count, uint32_t capacity, uint32_t *counts,
                                uint32_t *indices, pf_error *err);

/*
 * Emitters for photon emission: every punctual light and every emissive
 * triangle with its emitted power (W per RGB channel), picked by power
 * (Rec. 709 luminance of it) through one alias table, so the photons of
 * each light are proportional to its power. std430 mirror PhotonEmitter
 * (32 bytes). Powers:
 *   point        4π I
 *   spot         2π I [(1 − cos_inner) + (cos_inner − cos_outer) / 3]: the
 *                spec's squared linear falloff (lights.glsl) integrates to a
 *                third of its band (a hard edge: 2π I (1 − cos_outer))
 *   directional  E π R², R = the radius of the scene's bounding sphere: the
 *                photons start on a disk of that radius facing the light
 *   triangle     π Le A from its front face (a Lambertian emitter); 2π Le A
 *                for a double-sided material, which emits from both
 * A light's glTF range window is not part of its power: tracing applies it
 * at the photon's first hit, as the integrators' shadow rays do.
 */
typedef enum pf_photon_emitter_kind {
    PF_EMITTER_POINT = 0,
    PF_EMITTER_SPOT = 1,
    PF_EMITTER_DIRECTIONAL = 2,
    PF_EMITTER_TRIANGLE = 3
} pf_photon_emitter_kind;

typedef struct pf_photon_emitter {
    uint32_t kind;             /* pf_photon_emitter_kind */
    uint32_t index;            /* light index, or triangle index for PF_EMITTER_TRIANGLE */
    float alias_threshold;     /* alias table column (pf_alias_table_build) */
    uint32_t alias;
    float power[3];            /* W */
    float pick_probability;    /* luminance(power) / Σ luminance */
} pf_photon_emitter;

_Static_assert(sizeof(pf_photon_emitter) == 32, "pf_photon_emitter must match PhotonEmitter");

typedef struct pf_photon_emitters {
    uint32_t count;            /* emitters with power > 0 (0: nothing to trace) */
    pf_photon_emitter *entries;
    double total_power[3];     /* W, all emitters */
    float scene_center[3];     /* bounding sphere of the frame's triangles (directional lights) */
    float scene_radius;
} pf_photon_emitters;

/* Power of one punctual light (see above); scene_radius for directional lights. */
void pf_photon_light_power(const pf_light *light, float scene_radius, float power[3]);

/*
 * Lists frame's emitters with their power and builds the alias table. Lights
 * and triangles of zero power are left out. out is zeroed on failure;
 * PF_ERR_INVALID for a non-finite power, PF_ERR_NOMEM.
 */
pf_status pf_photon_emitters_build(const pf_scene_frame *frame, pf_photon_emitters *out,
                                   pf_error *err);
void pf_photon_emitters_free(pf_photon_emitters *emitters);

/*
 * Photon tracing on the GPU (shaders/common/photon_path.glsl documents emission,
 * storage rules and Russian roulette). The scene comes as the buffers the
 * renderer already uploaded for the frame (pf_scene.h layouts: vertices and
 * normals vec4 × 3 per triangle, a material index per triangle, pf_material
 * and pf_light arrays) plus the frame's BIH.
 *
 * Maps: the global map holds every photon stored at a diffuse hit other
 * than the first of its path (L (S|D)+ D: direct light comes from shadow
 * rays); the caustic map the subset whose earlier bounces were all specular
 * (L S+ D). Flux is in units of flux_scale watts (Σ luminance of the
 * emitters' power / photons emitted): an emitted photon has luminance 1.
 */
typedef struct pf_photon_scene {
    pf_vk_buffer *vertices;
    pf_vk_buffer *normals;
    pf_vk_buffer *triangle_material;
    pf_vk_buffer *materials;
    pf_vk_buffer *lights;         /* at least one element, even with no lights */
    uint32_t triangle_count;
    pf_bih_gpu_view bih;
    float ray_offset;             /* secondary rays leave surfaces this far along the normal */
    /* The scene's texture bindings (PF_SCENE_BINDING_CORNERS, _TEXTURES, _TEXELS); NULL: the
     * scene has no textures (the tracer binds a placeholder). */
    pf_vk_buffer *corners, *textures, *texels;
    uint32_t surface_features; /* PF_SURFACE_* of the frame (pf_scene_frame_surface_features) */
} pf_photon_scene;

/* Hits a photon path may have (REFERENCE.md: bound every loop). */
#define PF_PHOTON_DEFAULT_MAX_DEPTH 16u
/* Photons an invocation traces in turn on a CPU device (photon_trace.comp: a lane whose photon
 * ended starts its next, so SIMD lanes stay busy). On lavapipe, 400k photons: 1 → 8 took the
 * Cornell box 0.91 → 0.74 s and staircase2 1.72 → 1.52 s (16: 0.69 s on the Cornell box).
 * Their loop iterations add up against llvmpipe's 65,535 an invocation: 8 × 16 bounces leave
 * ~500 traversal steps a bounce, and a pass that meets the cap is traced again one photon
 * each. Other devices trace one photon per invocation: a GPU hides latency with many threads,
 * and 8 per invocation took an H100's staircase2 pass from 23 to 85 ms. */
#define PF_PHOTON_TRACE_PER_INVOCATION 8u

/* The directions arrivals are counted by (pf_photon_maps.arrival_direction_flux). */
#define PF_PHOTON_ARRIVAL_DIRECTIONS 6u

typedef struct pf_photon_trace_settings {
    uint32_t photon_count;        /* photons emitted in the pass */
    uint64_t seed;
    uint32_t max_depth;           /* hits per photon: 0 = PF_PHOTON_DEFAULT_MAX_DEPTH */
    uint32_t global_capacity;     /* 0 = as many as one buffer holds (and at most 4 per photon) */
    uint32_t caustic_capacity;    /* 0 = the same */
    int store_direct;             /* 1: first hits go to the global map too (validates the
                                     density estimate against analytic direct irradiance) */
    int global_reflected;         /* 1: global records carry the flux the surface reflects
                                     (flux ⊙ albedo), not the flux arriving: with
                                     store_direct, the virtual point lights of the LPV */
    uint32_t per_invocation;      /* photons an invocation traces in turn: 0 = the device's
                                     (PF_PHOTON_TRACE_PER_INVOCATION on a CPU device, else 1;
                                     the maps hold the same photons whatever it is, only
                                     their order differs) */
    const pf_bih *host_tree;      /* non-NULL: the host traces the photons' rays through this
                                     tree (the frame's, as the device's), in waves of a bounce
                                     each, where the device is the CPU (issue 43); the same
                                     photons, only the maps' order differs */
    const pf_bih_wide *host_wide; /* host_tree's wide view, kept by the caller (NULL: built
                                     for the pass) */
    /* Arrivals (pf_photon_maps.arrival_direction_flux) are counted strictly inside this box; all zero:
     * none. */
    float arrival_box_min[3], arrival_box_max[3];
} pf_photon_trace_settings;

typedef struct pf_photon_maps {
    pf_vk_buffer *global;         /* global_count pf_photon records */
    pf_vk_buffer *caustic;
    uint32_t global_count, caustic_count;       /* stored */
    uint32_t global_offered, caustic_offered;   /* would have been stored: more = map full */
    float flux_scale;             /* watts per unit of stored flux */
    uint32_t emitted;
    uint32_t traversal_failures;  /* photons whose BIH traversal overflowed (dropped) */
    uint32_t non_finite;          /* photons dropped for a non-finite flux or normal */
    uint32_t per_invocation;      /* photons an invocation traced: the settings', or 1 where
                                     they met the loop cap together and were traced again */
    double gpu_ms;                /* < 0 without timestamps */
    uint32_t waves;               /* with a host_tree: the dispatches of the waves */
    double host_trace_ms;         /* with a host_tree: the host's traces */
    /* Luminance flux (map units) of the photons that reached a diffuse surface, on either
     * face, inside the settings' arrival box after at least one diffuse bounce: the energy
     * the diffuse-to-diffuse light deposits there (fast's LPV is scaled to it), by the
     * direction the surfaces face, the six of the axes: +x, −x, +y, −y, +z, −z, each
     * arrival split by the squares of its normal's components. */
    double arrival_direction_flux[PF_PHOTON_ARRIVAL_DIRECTIONS];
} pf_photon_maps;

typedef struct pf_photon_tracer pf_photon_tracer;

/* The tracer's kernels are made at their first use (the flat loop's, or the waves'). */
pf_status pf_photon_tracer_create(pf_vk_context *ctx, pf_photon_tracer **out, pf_error *err);
void pf_photon_tracer_destroy(pf_photon_tracer *tracer);

/*
 * Traces one pass of photons from emitters through scene into new maps
 * (release them with pf_photon_maps_release). No emitters: empty maps.
 * Fails with PF_ERR_INVALID (bad settings), PF_ERR_LIMIT (traversal stack
 * overflow, or capacities beyond the device's buffer limit: the message
 * says how many photons fit), PF_ERR_VULKAN. A full map is not an error:
 * offered > count says how many photons were dropped.
 */
pf_status pf_photon_trace(pf_photon_tracer *tracer, const pf_photon_scene *scene,
                          const pf_photon_emitters *emitters,
                          const pf_photon_trace_settings *settings, pf_photon_maps *out,
                          pf_error *err);
/*
 * Traces count passes (settings[i] into out[i]: their own seeds, maps and counts) in one
 * submission and one wait where the device traces the rays (issue 44: a frame's passes
 * are one photon_trace), each pass in its own waves where settings[i].host_tree has the
 * host trace them. Passes whose shared invocations met the loop cap are traced again
 * together, one photon an invocation (a second submission). Each pass's maps hold what
 * pf_photon_trace would give it. On failure every out[i] is released and the error names
 * the pass, or the batch where their common submission failed.
 */
pf_status pf_photon_trace_passes(pf_photon_tracer *tracer, const pf_photon_scene *scene,
                                 const pf_photon_emitters *emitters,
                                 const pf_photon_trace_settings *settings, uint32_t count,
                                 pf_photon_maps *out, pf_error *err);
void pf_photon_maps_release(pf_vk_context *ctx, pf_photon_maps *maps);
/* The bytes a pass of these settings' maps hold on the device (both maps, at capacity). */
uint64_t pf_photon_trace_bytes(const pf_vk_device_info *info,
                               const pf_photon_trace_settings *settings);

/*
 * Photon budgets beyond one pass. A pass's maps, and the grid over each,
 * must fit one storage buffer (maxStorageBufferRange; 128 MiB on lavapipe,
 * 6.7M photons of 20 bytes), and a full map drops photons. So a budget of
 * emitted photons is split into passes whose maps cannot overflow: at most
 * stores_per_photon photons stored per emitted photon (max_depth − 1 bounds
 * the global map exactly, max_depth with store_direct; a smaller mean
 * measured on an earlier pass, global_offered / emitted, packs more per
 * pass; 0 = 4). The caller traces, grids, estimates and releases one pass at
 * a time, each with its own seed, and combines the passes' estimates in
 * watts weighted by their share of the budget,
 *     E = Σ_p (photons_p / budget) × flux_scale_p × E_p,
 * as the progressive loop accumulates its passes: memory holds one pass
 * whatever the budget. Every pass has photons_per_pass photons but the last,
 * which has the remainder.
 */
typedef struct pf_photon_pass_plan {
    uint32_t passes;
    uint32_t photons_per_pass;
    uint32_t last_pass_photons;
    uint32_t capacity;            /* global_capacity/caustic_capacity to trace each pass with */
} pf_photon_pass_plan;

/*
 * Plans budget emitted photons on ctx's device. PF_ERR_INVALID for a zero
 * budget; PF_ERR_LIMIT, with the figures, when stores_per_photon alone
 * exceeds a buffer or the budget would need more than UINT32_MAX passes.
 */
pf_status pf_photon_plan_passes(pf_vk_context *ctx, uint64_t budget, uint32_t stores_per_photon,
                                pf_photon_pass_plan *plan, pf_error *err);

/* Copies a map's records to the host (*photons malloc'ed; NULL when empty). */
pf_status pf_photon_map_download(pf_vk_context *ctx, pf_vk_buffer *map, uint32_t count,
                                 pf_photon **photons, pf_error *err);

#endif
