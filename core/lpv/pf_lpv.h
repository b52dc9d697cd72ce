/*
 * core/lpv: cascaded light propagation volumes (Kaplanyan & Dachsbacher
 * 2010; seed thesis Růžička 2016 with REFERENCE.md's corrections). This
 * header is the module's whole interface.
 *
 * Representation. Each cascade is a cube of size³ cells of edge cell_size.
 * A cell holds the radiant intensity leaving it, I(ω) in W/sr, as 2-band
 * spherical harmonics per RGB channel (4 coefficients × 3: three vec4 per
 * cell, R then G then B; the basis and constants below). ∫ I dω over the
 * sphere is the cell's flux, c0 · Y00 · 4π.
 *
 * Injection (on the device, pf_lpv_inject_photons; pf_lpv_inject is the host's
 * reference and the path of a device without 64-bit atomics): a virtual point
 * light of reflected flux Φ on a surface of normal n is a Lambertian emitter,
 * I(ω) = (Φ/π) max(0, n·ω), so the cell gains (Φ/π) × the clamped-cosine
 * lobe's coefficients (∫ = Φ exactly). It goes into the cell that holds its
 * position moved offset_cells × cell_size along n (out of the surface it lies
 * on), in every cascade that contains that point. The device sums in 64-bit
 * fixed point, so the same VPLs give bit-identical grids in any order; the
 * photons then never leave the device (issue 44).
 *
 * Geometry volume (CPU, pf_lpv_geometry_build): the blocking potential of
 * the scene's own triangles at every face between two LPV cells, the one
 * place propagation and lookup cross. Per cascade and axis k, a grid offset
 * by half a cell along k: face cell g is the slab around LPV cell g's lower
 * face normal to k (half a cell either side of it, and the face's own
 * rectangle along the other two axes). Each triangle is clipped exactly
 * against every face cell it touches, and the clipped area A adds (A / s²)
 * × the clamped-cosine lobe of its face normal / 0.75 (0.75 is the expanded
 * lobe's peak, so a wall filling a face blocks everything at normal
 * incidence). Glass triangles are left out (they transmit). Light
 * travelling along ω meets the surfaces that face −ω, so its blocking is
 * B(ω) = clamp(GV(−ω), 0, 1), one-sided like the front faces. Tried and
 * dropped (issue note): one GV grid offset by half a cell along all three
 * axes, read bilinearly at a face (a wall's coverage is then smeared over
 * the neighbouring faces: 25% leaked round a thin wall's edges); a
 * two-sided reading (walls blocked their own VPLs' light: a closed box lost
 * half its indirect light); six exact per-axis coverages instead of the SH
 * lobe (no isotropic term, so light sliding along a wall is never
 * absorbed: the Cornell box's indirect light came out 1.6× the reference's).
 *
 * Propagation (GPU, shaders/lpv_propagate.comp; on the host's CPUs when the
 * device is the CPU, lpv_propagate_host.c): gather form, one invocation
 * per destination cell, no atomics. From each of the 6 neighbours, the flux
 * onto each of the destination's 5 faces not shared with that neighbour is
 * Δω_f × I_src(ω_f) × (1 − B(ω_f)), with ω_f from the neighbour's centre
 * to the face's centre and Δω_f the exact solid angles below, and is
 * re-emitted as a clamped-cosine lobe about the face's outward normal
 * ((Φ_f/π) × lobe: ∫ = Φ_f). In empty space Σ Δω_f over the 30
 * (neighbour, face) pairs is 4π, so a step conserves flux exactly for any
 * intensity that is non-negative everywhere. Ping-pong buffers; the
 * accumulation buffer sums the injected grid and every iteration's result;
 * a snapshot of it after snapshot_iterations (below), subtracted from it at
 * the end, gives the far field.
 *
 * Cascades: count levels, cell_size doubling per level, each centred on the
 * focus point (pf_lpv_focus) and snapped to its own cell size, so a camera
 * that moves less than a cell leaves the cascade's origin and contents
 * unchanged (no flicker). The finest cell defaults to a power of two
 * (stable across an animation's frames) sized so that the coarsest cascade
 * spans the scene and its light crosses it (pf_lpv_default_cell_size).
 */
#ifndef PF_LPV_H
#define PF_LPV_H

#include "pf_common.h"
#include "pf_scene.h"
#include "pf_vk.h"

#include <stdint.h>

/* SH basis, 2 bands, ω = (x, y, z): Y00, Y1-1 = -c y, Y10 = c z, Y11 = -c x. */
#define PF_SH_Y00 0.28209479177387814f
#define PF_SH_Y1 0.48860251190291992f
/* Clamped cosine lobe max(0, n·ω) in that basis: c0, then ±c1 × n like Y1. */
#define PF_SH_COSINE0 0.88622692545275801f
#define PF_SH_COSINE1 1.02332670794648848f
/*
 * Solid angles a destination cell's faces subtend from a neighbour's centre
 * (REFERENCE.md): the face opposite the neighbour 4·atan(√11/33), each side
 * face −π/3 + 2·atan(3√11/11). 6 × front + 24 × side = 4π. The widely copied
 * 0.4234413544 is a typo that adds energy every step.
 */
#define PF_LPV_SOLID_ANGLE_FRONT 0.40066968465f
#define PF_LPV_SOLID_ANGLE_SIDE 0.42343135440f

/* 4 coefficients × RGB per cell: three vec4 (R, G, B). */
#define PF_LPV_FLOATS_PER_CELL 12u
/* Geometry volume: one vec4 of SH coefficients per face cell, three axes per cell. */
#define PF_LPV_GV_FLOATS_PER_CELL 12u

#define PF_LPV_DEFAULT_CASCADES 4u
#define PF_LPV_DEFAULT_SIZE 32u
#define PF_LPV_DEFAULT_ITERATIONS 8u
/* Injection offset along the normal, in cells (see pf_lpv_settings). */
#define PF_LPV_DEFAULT_OFFSET_CELLS 0.5f
#define PF_LPV_MAX_CASCADES 8u
/* Cells per axis: at least 4 (a cascade needs an interior), a multiple of 4 (the workgroup). */
#define PF_LPV_MIN_SIZE 4u
#define PF_LPV_MAX_SIZE 256u
#define PF_LPV_MAX_ITERATIONS 1024u

/* Evaluates the basis at a unit direction. */
void pf_sh_basis(const float direction[3], float out[4]);
/* Coefficients of max(0, n·ω) for a unit n. */
void pf_sh_cosine_lobe(const float normal[3], float out[4]);
float pf_sh_eval(const float coefficients[4], const float direction[3]);
/* ∫ over the sphere of the expanded function: c0 · Y00 · 4π. */
double pf_sh_integral(const float coefficients[4]);

typedef struct pf_lpv_settings {
    uint32_t cascades;                           /* 0 = PF_LPV_DEFAULT_CASCADES */
    uint32_t size;                               /* cells per axis, 0 = PF_LPV_DEFAULT_SIZE */
    uint32_t iterations[PF_LPV_MAX_CASCADES];    /* per cascade, 0 = iterations[0], else default */
    float cell_size;                             /* finest cascade's cell (m), 0 = from the scene */
    float offset_cells;                          /* VPL offset along its normal, 0 = default */
    int undamped;                                /* 1: no light-bleeding dampening at lookup
                                                    (lpv_lookup.glsl; for measurements) */
    int unscaled;                                /* 1: the irradiance is not scaled to the
                                                    photons' energy (fast_shade.glsl; for
                                                    measurements) */
} pf_lpv_settings;

/* Which setting pf_lpv_settings_check refused (for the caller's message). */
typedef enum pf_lpv_setting {
    PF_LPV_SETTING_NONE = 0,
    PF_LPV_SETTING_CASCADES,
    PF_LPV_SETTING_SIZE,
    PF_LPV_SETTING_ITERATIONS,
    PF_LPV_SETTING_CELL_SIZE,
    PF_LPV_SETTING_OFFSET
} pf_lpv_setting;

/*
 * Checks explicit values (0 = default is always fine): cascades 1..
 * PF_LPV_MAX_CASCADES, size a multiple of 4 in PF_LPV_MIN_SIZE..
 * PF_LPV_MAX_SIZE and such that the largest buffer (every cascade's
 * cells × 48 bytes) fits max_buffer_bytes (0: not checked), iterations
 * 1..PF_LPV_MAX_ITERATIONS, cell size finite and > 0, offset in (0, 2].
 * PF_ERR_INVALID or PF_ERR_LIMIT naming the value and the accepted range;
 * *which (may be NULL) says which setting.
 */
pf_status pf_lpv_settings_check(const pf_lpv_settings *settings, uint64_t max_buffer_bytes,
                                pf_lpv_setting *which, pf_error *err);

typedef struct pf_lpv_cascade {
    float origin[3];       /* lower corner of cell (0, 0, 0), = origin_cell × cell_size */
    float cell_size;
    int32_t origin_cell[3];
    uint32_t iterations;
    /*
     * Iterations after which this cascade's accumulation is copied to the
     * snapshot volume: as far as the next finer cascade's light travels,
     * round(iterations_{k−1} × cell_{k−1} / cell_k), at most iterations (0
     * for cascade 0: the injected volume). A lookup in cascade k adds each
     * coarser cascade's accumulation minus its snapshot: the light from
     * beyond the reach of the finer cascades' propagation (far field), so a
     * fine cascade with few iterations loses no energy.
     */
    uint32_t snapshot_iterations;
} pf_lpv_cascade;

typedef struct pf_lpv_layout {
    uint32_t count, size;
    float offset_cells;
    float focus[3];
    pf_lpv_cascade cascades[PF_LPV_MAX_CASCADES];
    int covers_scene;      /* 1: the coarsest cascade contains the scene's box */
} pf_lpv_layout;

/*
 * The point the cascades centre on: the camera when it is inside the scene's
 * box (enlarged by a tenth of its size), else the point of the view axis
 * nearest the box's centre (a camera outside the scene looking at it:
 * centring on the camera would spend the finest cascade on empty air).
 */
void pf_lpv_focus(const pf_scene_frame *frame, float focus[3]);

/*
 * Default finest cell: the smallest power of two (in m) such that the
 * coarsest cascade centred on focus, less two cells of snapping margin,
 * reaches every face of the scene's box, and its coarsest_iterations carry
 * light across the box's largest extent (so no light is lost to a short
 * propagation; the finer cascades add detail near the focus, lpv_lookup.glsl
 * their far field). A power of two, so that an animation's moving box or
 * camera leaves it (and the snapped origins) unchanged until those
 * distances cross a power of two.
 */
float pf_lpv_default_cell_size(const pf_scene_frame *frame, const float focus[3],
                               uint32_t cascades, uint32_t size, uint32_t coarsest_iterations);

/*
 * Cascade k: cell_size = finest × 2^k (finest_cell 0: the default,
 * pf_lpv_default_cell_size, which needs frame), origin_cell = floor(focus /
 * cell) − size/2, iterations from the settings. covers_scene from frame's
 * box (frame may be NULL with an explicit cell: covers_scene = 1). Settings
 * must have passed the check.
 */
void pf_lpv_layout_make(const pf_lpv_settings *settings, const float focus[3], float finest_cell,
                        const pf_scene_frame *frame, pf_lpv_layout *out);

/* Floats of one volume over all cascades: count × size³ × floats_per_cell. */
uint64_t pf_lpv_volume_floats(const pf_lpv_layout *layout, uint32_t floats_per_cell);

/* A virtual point light: reflected flux (W, RGB) leaving a surface point. */
typedef struct pf_lpv_vpl {
    float position[3];
    float normal[3];       /* unit, on the side the light leaves */
    float flux[3];
} pf_lpv_vpl;

typedef struct pf_lpv_inject_stats {
    uint32_t injected[PF_LPV_MAX_CASCADES];  /* VPLs that landed in each cascade */
    uint32_t outside;                        /* VPLs no cascade contains */
    uint32_t rejected;                       /* non-finite or zero-normal VPLs */
} pf_lpv_inject_stats;

/*
 * Adds count VPLs to grid (pf_lpv_volume_floats(layout, 12) floats, cascade
 * after cascade, cells x fastest) in list order. stats may be NULL.
 */
void pf_lpv_inject(const pf_lpv_layout *layout, const pf_lpv_vpl *vpls, uint32_t count,
                   float *grid, pf_lpv_inject_stats *stats);

/*
 * The geometry volume of frame's non-glass triangles (see the header
 * comment; each weighed by the part its alpha factor leaves opaque) into gv
 * (pf_lpv_volume_floats(layout, PF_LPV_GV_FLOATS_PER_CELL) floats, zeroed here).
 * Returns the number of (triangle, cell) pieces accumulated.
 */
uint64_t pf_lpv_geometry_build(const pf_lpv_layout *layout, const pf_scene_frame *frame,
                               float *gv);

/*
 * Where `fast` weighs its volumes' energy (frame_fast.c, render_fast_energy.comp): count
 * points spread over the frame's diffuse (PF_MATERIAL_LAMBERT) triangles by area, each
 * PF_LPV_ENERGY_SAMPLE_FLOATS floats: position xyz, 1 where the material is double-sided
 * (either face may be lit) else 0; the face's unit normal xyz (counter-clockwise front),
 * the triangle's index as the float's bits; the point's barycentrics u, v (position =
 * (1 − u − v) a + u b + v c, the traversal's: an alpha test reads the texture there), 0, 0. The
 * same frame gives the same points. Returns the triangles' total area (m²; 0: no diffuse
 * surface, and every sample zero): each point stands for total / count of it.
 */
#define PF_LPV_ENERGY_SAMPLE_FLOATS 12u
double pf_lpv_energy_samples(const pf_scene_frame *frame, uint32_t count, float *samples);

/* Area of triangle a b c and its unit normal (counter-clockwise front), in doubles; 0 (normal
 * unset) for a degenerate one. */
double pf_lpv_triangle_normal(const float a[3], const float b[3], const float c[3],
                              double normal[3]);

/* Area of a triangle clipped to an axis-aligned box (exact up to rounding). */
double pf_lpv_clipped_area(const float a[3], const float b[3], const float c[3],
                           const float box_min[3], const float box_max[3]);

/*
 * The GPU side: the injected, ping-pong, accumulation and geometry volumes
 * of one layout shape (count × size³), and the propagation kernel.
 */
typedef struct pf_lpv pf_lpv;

pf_status pf_lpv_create(pf_vk_context *ctx, pf_lpv **out, pf_error *err);
void pf_lpv_destroy(pf_lpv *lpv);

typedef struct pf_lpv_propagate_stats {
    double gpu_ms;                           /* < 0 without timestamps, or on the host */
    /* Each cascade's share of gpu_ms, from timestamps between the cascades inside the one
     * submission (issue 44); < 0 as gpu_ms. */
    double cascade_gpu_ms[PF_LPV_MAX_CASCADES];
    uint64_t cell_updates;                   /* cells × iterations, all cascades */
    int on_host;                             /* 1: the iterations ran on the host's CPUs */
} pf_lpv_propagate_stats;

/* Where pf_lpv_propagate runs the iterations. */
typedef enum pf_lpv_site {
    PF_LPV_SITE_AUTO = 0, /* the default: the host when the device is the CPU, else the device */
    PF_LPV_SITE_HOST,     /* pf_lpv_propagate_host, then the volumes uploaded */
    PF_LPV_SITE_DEVICE    /* shaders/lpv_propagate.comp */
} pf_lpv_site;

/* Forces where later propagations run (tests cover both paths with it). */
void pf_lpv_set_site(pf_lpv *lpv, pf_lpv_site site);

/*
 * Injects count VPLs on the device (shaders/lpv_inject.comp; pf_lpv_inject is its
 * reference): the records of a photon map (pf_photon, flux in units of flux_scale, as
 * the trace left them) into every cascade of layout, in one submission. The sums are
 * 64-bit fixed point, so the volume does not depend on the order the invocations add in
 * (the same to the bit on every run). They stay on the device for the next
 * pf_lpv_propagate with injected NULL; read_back, where not NULL, also receives the
 * injected volume (pf_lpv_volume_floats(layout, 12) floats) in the same submission, for
 * the host's propagation. stats as pf_lpv_inject's; *gpu_ms the passes' device time
 * (< 0 without timestamps). Needs pf_lpv_injects_on_device: PF_ERR_UNSUPPORTED
 * otherwise; PF_ERR_NOMEM, PF_ERR_VULKAN.
 */
pf_status pf_lpv_inject_photons(pf_lpv *lpv, const pf_lpv_layout *layout,
                                pf_vk_buffer *photons, uint32_t count, float flux_scale,
                                float *read_back, pf_lpv_inject_stats *stats, double *gpu_ms,
                                pf_error *err);

/* Whether the device can inject layout's volume: 64-bit buffer atomics, and sums that
 * fit in one storage buffer (twice the bytes of the float volume). */
int pf_lpv_injects_on_device(const pf_lpv *lpv, const pf_lpv_layout *layout);

/* Whether pf_lpv_propagate runs the iterations on the host (pf_lpv_set_site, or AUTO on
 * a CPU device). */
int pf_lpv_propagates_on_host(const pf_lpv *lpv);

/*
 * Uploads the injected grid and the geometry volume (gv NULL: no occlusion)
 * for layout, then runs each cascade's iterations; afterwards the
 * accumulation volume holds injected + every iteration. Buffers are
 * (re)allocated when the layout's shape changes. On a CPU device (lavapipe)
 * the iterations run on the host (pf_lpv_propagate_host, ~3× faster there:
 * bench/RESULTS.md) and the volumes are uploaded. injected NULL on the device: the
 * volume pf_lpv_inject_photons left there for this layout (PF_ERR_INVALID where none is
 * kept, or on the host). PF_ERR_LIMIT when a volume exceeds the device's buffer limit,
 * PF_ERR_NOMEM, PF_ERR_VULKAN.
 */
pf_status pf_lpv_propagate(pf_lpv *lpv, const pf_lpv_layout *layout, const float *injected,
                           const float *gv, pf_lpv_propagate_stats *stats, pf_error *err);

/*
 * The same propagation on the host's CPUs, for a device that is the CPU
 * (lavapipe): accumulated receives what pf_lpv_propagate leaves in the
 * accumulation volume, snapshot the accumulation after each cascade's
 * snapshot_iterations (each pf_lpv_volume_floats(layout, 12) floats; equal
 * to the device's up to float rounding; pf_lpv_propagate's far field is
 * accumulated − snapshot). The cascades run on up to one thread per online
 * CPU. PF_ERR_NOMEM.
 */
pf_status pf_lpv_propagate_host(const pf_lpv_layout *layout, const float *injected,
                                const float *gv, float *accumulated, float *snapshot,
                                pf_error *err);

/* The accumulation volume on the device (NULL before a propagation); pf_lpv owns it. */
pf_vk_buffer *pf_lpv_accumulated(const pf_lpv *lpv);
/*
 * The far-field volume, likewise: the accumulation minus its snapshot
 * (pf_lpv_cascade.snapshot_iterations), per float, what lpv_lookup.glsl adds
 * from the coarser cascades (one volume to read where it read two).
 */
pf_vk_buffer *pf_lpv_far_fields(const pf_lpv *lpv);
/* The geometry volume of the last propagation (zeros when it had none), likewise. */
pf_vk_buffer *pf_lpv_geometry(const pf_lpv *lpv);

/* Downloads the accumulation volume (pf_lpv_volume_floats(layout, 12) floats). */
pf_status pf_lpv_download(pf_lpv *lpv, float *out, uint64_t floats, pf_error *err);

/*
 * One propagation step of a single cascade from src to dst on the device,
 * without accumulation (for tests: conservation and constant fields).
 */
pf_status pf_lpv_propagate_once(pf_lpv *lpv, uint32_t size, const float *src, const float *gv,
                                float *dst, pf_error *err);

#endif
