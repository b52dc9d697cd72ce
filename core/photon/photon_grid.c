/*
 * The GPU photon grid (pf_photon_grid_* in pf_photon.h): host side of its
 * counting sort (shaders/photon_grid_keys.comp, prefix_sum.comp,
 * photon_grid_finish.comp); pf_photon_grid_gather runs
 * shaders/photon_gather_probe.comp.
 */
#include "pf_photon.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define GRID_GROUP_SIZE 256u
#define GATHER_GROUP_SIZE 64u
/*
 * The cell is 2^-6 larger than the build radius (see photon_grid.glsl: the
 * gather widens its box by 2^-8 r, and the box must span at most 3 cells).
 */
#define CELL_MARGIN (1.0f + 1.0f / 64.0f)
/* What a job of a batch builds (build_jobs): nothing (this submission), its map and the
 * map's points, or the points of a map built before. */
enum { WORK_NONE = 0, WORK_MAP = 1, WORK_POINTS = 2 };
/* Modes of photon_grid_finish.comp. */
enum { FINISH_CLEAR = 0, FINISH_SCATTER = 1 };
/* Modes of photon_irradiance_probe.comp. */
enum { ESTIMATE_FIXED = 0, ESTIMATE_KNN = 1, ESTIMATE_LOOKUP = 2 };
/* Push constants of photon_irradiance_mark.comp and photon_irradiance_precompute.comp
 * (48 bytes). */
typedef struct precompute_push {
    pf_photon_grid_push grid;
    uint32_t photons;
    uint32_t capacity; /* slots of the point list and the unsorted points (record_points) */
    float radius;
} precompute_push;

_Static_assert(sizeof(precompute_push) == 48, "precompute_push must match its shader's Push");

/* Push constants of every photon grid shader (photon_grid_push.glsl, 48 bytes). */
typedef struct photon_grid_push {
    pf_photon_grid_push grid;
    uint32_t count;
    uint32_t capacity;
    uint32_t mode;
} photon_grid_push;

_Static_assert(sizeof(photon_grid_push) == 48, "photon_grid_push must match photon_grid_push.glsl");

struct pf_photon_grid {
    pf_vk_context *ctx;
    pf_vk_pipeline *keys_pipeline;
    pf_vk_pipeline *scan_pipeline;       /* prefix_sum.comp (pf_bih_prefix_sum_record) */
    pf_vk_pipeline *finish_pipeline;
    pf_vk_pipeline *gather_pipeline;
    pf_vk_pipeline *irradiance_pipeline;
    pf_vk_pipeline *mark_pipeline;       /* photon_irradiance_mark.comp (points grids) */
    pf_vk_pipeline *precompute_pipeline; /* photon_irradiance_precompute.comp (points grids) */
    pf_vk_buffer *sorted_records; /* photons in cell order: x, y, z, directions (16 bytes) */
    pf_vk_buffer *sorted_flux;    /* their flux, same order (a word each) */
    pf_vk_buffer *original;       /* cell order -> index given to the build */
    pf_vk_buffer *ranges;         /* [start, end) per cell or bucket */
    pf_photon_grid_info info;
    double gpu_ms;
    int built;
};

static void release(pf_vk_context *ctx, pf_vk_buffer **buffer)
{
    if (*buffer)
        pf_vk_buffer_destroy(ctx, *buffer);
    *buffer = NULL;
}

static void release_grid(pf_photon_grid *grid)
{
    release(grid->ctx, &grid->sorted_records);
    release(grid->ctx, &grid->sorted_flux);
    release(grid->ctx, &grid->original);
    release(grid->ctx, &grid->ranges);
    grid->built = 0;
}

/* A probe pipeline (buffers bindings, the grid's push), created the first time it is asked for. */
static pf_status probe_pipeline(pf_photon_grid *grid, const char *shader, uint32_t buffers,
                                pf_vk_pipeline **slot, pf_error *err)
{
    if (*slot)
        return PF_OK;
    return pf_vk_pipeline_create_named(grid->ctx, shader, buffers, sizeof(photon_grid_push), NULL,
                                       0, slot, err);
}

pf_status pf_photon_grid_create(pf_vk_context *ctx, pf_photon_grid **out, pf_error *err)
{
    *out = NULL;
    pf_photon_grid *grid = calloc(1, sizeof *grid);
    if (!grid)
        return pf_error_set(err, PF_ERR_NOMEM, "photon grid: out of memory");
    grid->ctx = ctx;
    pf_status status = pf_vk_pipeline_create_named(ctx, "photon_grid_keys", 4,
                                                   sizeof(photon_grid_push), NULL, 0,
                                                   &grid->keys_pipeline, err);
    if (status == PF_OK)
        status = pf_bih_prefix_sum_pipeline(ctx, &grid->scan_pipeline, err);
    if (status == PF_OK)
        status = pf_vk_pipeline_create_named(ctx, "photon_grid_finish", 8,
                                             sizeof(photon_grid_push), NULL, 0,
                                             &grid->finish_pipeline, err);
    /* The probes (gather, irradiance) serve tests and benchmarks: made at their first use. */
    if (status != PF_OK) {
        pf_photon_grid_destroy(grid);
        return status;
    }
    *out = grid;
    return PF_OK;
}

void pf_photon_grid_destroy(pf_photon_grid *grid)
{
    if (!grid)
        return;
    release_grid(grid);
    pf_vk_pipeline *pipelines[] = {grid->keys_pipeline,   grid->scan_pipeline,
                                   grid->finish_pipeline, grid->gather_pipeline,
                                   grid->irradiance_pipeline, grid->mark_pipeline,
                                   grid->precompute_pipeline};
    for (size_t i = 0; i < sizeof pipelines / sizeof pipelines[0]; i++) {
        if (pipelines[i])
            pf_vk_pipeline_destroy(grid->ctx, pipelines[i]);
    }
    free(grid);
}

static uint32_t groups_for(uint64_t items, uint32_t group_size)
{
    uint64_t groups = (items + group_size - 1) / group_size;
    return groups ? (uint32_t)groups : 1u;
}

/*
 * Chooses the grid for photons inside [lo, hi]: cell, origin, dense dims or
 * hash table size. Dense when the box needs at most
 * PF_PHOTON_GRID_DENSE_FACTOR cells per photon, else a power-of-two hash
 * table with one bucket per photon or more.
 */
static void plan_grid(const float lo[3], const float hi[3], uint32_t count, float radius,
                      pf_photon_grid_info *info)
{
    memset(info, 0, sizeof *info);
    info->photon_count = count;
    info->cell_size = radius * CELL_MARGIN;
    memcpy(info->origin, lo, sizeof info->origin);
    double cells = 1.0;
    uint32_t dims[3];
    for (int k = 0; k < 3; k++) {
        double extent = floor(((double)hi[k] - lo[k]) / info->cell_size) + 1.0;
        cells *= extent;
        dims[k] = extent < 4294967295.0 ? (uint32_t)extent : 0u;
    }
    uint32_t wanted = count > 1 ? count : 1;
    if (cells <= (double)PF_PHOTON_GRID_DENSE_FACTOR * wanted) {
        memcpy(info->dims, dims, sizeof dims);
        info->table_size = (uint32_t)cells;
        return;
    }
    info->hashed = 1;
    info->table_size = 1;
    while (info->table_size < wanted)
        info->table_size <<= 1;
}

/* The photons' bounding box; PF_ERR_INVALID naming the first non-finite position. */
static pf_status photon_bounds(const pf_photon *photons, uint32_t count, float lo[3], float hi[3],
                               pf_error *err)
{
    for (int k = 0; k < 3; k++)
        lo[k] = hi[k] = 0.0f;
    for (uint32_t i = 0; i < count; i++) {
        for (int k = 0; k < 3; k++) {
            float p = photons[i].position[k];
            if (!isfinite(p))
                return pf_error_set(err, PF_ERR_INVALID,
                                    "photon %u: position component %d is not finite", i, k);
            lo[k] = i == 0 || p < lo[k] ? p : lo[k];
            hi[k] = i == 0 || p > hi[k] ? p : hi[k];
        }
    }
    return PF_OK;
}

pf_photon_grid_push pf_photon_grid_push_of(const pf_photon_grid_info *info)
{
    pf_photon_grid_push push;
    memcpy(push.origin, info->origin, sizeof push.origin);
    push.inv_cell = 1.0f / info->cell_size;
    memcpy(push.dims, info->dims, sizeof push.dims);
    push.hashed = info->hashed;
    push.table_size = info->table_size;
    return push;
}

static photon_grid_push push_for(const pf_photon_grid_info *info, uint32_t count, uint32_t mode)
{
    photon_grid_push push;
    memset(&push, 0, sizeof push);
    push.grid = pf_photon_grid_push_of(info);
    push.count = count;
    push.mode = mode;
    return push;
}

/* The ranges' bytes: shaders read them as texels of two ranges (photon_texel_range), so an
 * odd table gets an empty last one. */
static uint64_t range_bytes_of(uint32_t table_size)
{
    return ((uint64_t)table_size + 1) / 2 * 16;
}

/* PF_ERR_LIMIT when the grid's largest buffer exceeds the device's limit. */
static pf_status check_fits(pf_vk_context *ctx, const pf_photon_grid_info *info, pf_error *err)
{
    const pf_vk_device_info *device = pf_vk_info(ctx);
    uint32_t count = info->photon_count;
    uint64_t photon_bytes = (uint64_t)(count ? count : 1) * sizeof(pf_photon);
    uint64_t range_bytes = range_bytes_of(info->table_size);
    uint64_t largest = photon_bytes > range_bytes ? photon_bytes : range_bytes;
    if (largest > device->max_storage_buffer_range)
        return pf_error_set(err, PF_ERR_LIMIT,
                            "photon grid: %u photons need a %llu-byte buffer; device '%s' allows %llu (at most %llu photons per map)",
                            count, (unsigned long long)largest, device->name,
                            (unsigned long long)device->max_storage_buffer_range,
                            (unsigned long long)(device->max_storage_buffer_range / 8 /
                                                 PF_PHOTON_GRID_DENSE_FACTOR));
    return PF_OK;
}

/* A recorded build's scratch buffers, released once its submission is done. */
typedef struct grid_scratch {
    pf_vk_buffer *keys, *ranks, *starts;
} grid_scratch;

static void release_scratch(pf_vk_context *ctx, grid_scratch *scratch)
{
    release(ctx, &scratch->keys);
    release(ctx, &scratch->ranks);
    release(ctx, &scratch->starts);
}

/*
 * Records the grid's build over the records input[0 .. records) lying in [lo, hi] (a device
 * buffer the caller keeps until the submission is done), its table planned for planned
 * photons, with timestamps around it (*begin, *end; < 0 without). The grid's buffers are
 * made here; its info holds photon_count = records until the caller sets it.
 */
static pf_status record_grid(pf_photon_grid *grid, pf_vk_commands *cmds, pf_vk_buffer *input,
                             uint32_t records, uint32_t planned, const float lo[3],
                             const float hi[3], float radius, grid_scratch *scratch, int *begin,
                             int *end, pf_error *err)
{
    pf_photon_grid_info info;
    plan_grid(lo, hi, planned, radius, &info);
    info.photon_count = records;
    *begin = *end = -1;
    pf_vk_context *ctx = grid->ctx;
    pf_status status = check_fits(ctx, &info, err);
    if (status != PF_OK)
        return status;
    uint32_t count = records;
    uint64_t record_bytes = (uint64_t)(count ? count : 1) * 16;
    uint64_t range_bytes = range_bytes_of(info.table_size);
    uint64_t index_bytes = (uint64_t)(count ? count : 1) * 4;
    /* The counts, then each key's first slot: the cells, the records without a photon, the
     * total (pf_bih_prefix_sum_record), and the prefix sum's block sums after them. */
    uint64_t scan_entries = (uint64_t)info.table_size + 2;
    status = pf_vk_buffer_create(ctx, record_bytes, "photon records (cell order)",
                                 &grid->sorted_records, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, index_bytes, "photon flux (cell order)",
                                     &grid->sorted_flux, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, index_bytes, "photon grid original indices",
                                     &grid->original, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, range_bytes, "photon grid ranges", &grid->ranges, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, index_bytes, "photon grid keys", &scratch->keys, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, index_bytes, "photon grid ranks", &scratch->ranks, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, 4 * pf_bih_prefix_sum_words(info.table_size + 1),
                                     "photon grid counts", &scratch->starts, err);
    if (status != PF_OK)
        return status;
    *begin = pf_vk_cmd_timestamp(cmds);
    pf_vk_buffer *finish_buffers[] = {scratch->keys,    scratch->ranks,    input,
                                      grid->sorted_records, grid->ranges, grid->sorted_flux,
                                      scratch->starts,  grid->original};
    photon_grid_push push = push_for(&info, count, FINISH_CLEAR);
    status = pf_vk_cmd_dispatch(cmds, grid->finish_pipeline, finish_buffers, 8, &push,
                                sizeof push, groups_for(scan_entries, GRID_GROUP_SIZE), 1, 1,
                                err);
    pf_vk_cmd_barrier(cmds);
    if (status == PF_OK && count > 0) {
        pf_vk_buffer *key_buffers[] = {input, scratch->keys, scratch->ranks, scratch->starts};
        status = pf_vk_cmd_dispatch(cmds, grid->keys_pipeline, key_buffers, 4, &push, sizeof push,
                                    groups_for(count, GRID_GROUP_SIZE), 1, 1, err);
        /* Counts to first slots. */
        if (status == PF_OK)
            status = pf_bih_prefix_sum_record(cmds, grid->scan_pipeline, scratch->starts,
                                              info.table_size + 1, err);
        push.mode = FINISH_SCATTER;
        if (status == PF_OK)
            status = pf_vk_cmd_dispatch(cmds, grid->finish_pipeline, finish_buffers, 8, &push,
                                        sizeof push, groups_for(count, GRID_GROUP_SIZE), 1, 1,
                                        err);
        pf_vk_cmd_barrier(cmds);
    }
    *end = status == PF_OK ? pf_vk_cmd_timestamp(cmds) : -1;
    grid->info = info;
    return status;
}

static pf_status build_jobs(pf_vk_context *ctx, pf_photon_grid_job *jobs, uint32_t count,
                            int what, const float lo[3], const float hi[3], pf_error *err);

static pf_status check_radius(float radius, pf_error *err)
{
    if (!(radius > 0.0f) || !isfinite(radius))
        return pf_error_set(err, PF_ERR_INVALID, "photon grid build: radius %g must be finite and > 0",
                            (double)radius);
    return PF_OK;
}

pf_status pf_photon_grid_build(pf_photon_grid *grid, const pf_photon *photons, uint32_t count,
                               float radius, pf_error *err)
{
    if (!grid || (count > 0 && !photons))
        return pf_error_set(err, PF_ERR_INVALID, "photon grid build: NULL argument");
    pf_status status = check_radius(radius, err);
    if (status != PF_OK)
        return status;
    release_grid(grid);
    float lo[3], hi[3];
    status = photon_bounds(photons, count, lo, hi, err);
    if (status != PF_OK)
        return status;
    pf_photon_grid_info info;
    plan_grid(lo, hi, count, radius, &info);
    status = check_fits(grid->ctx, &info, err);
    if (status != PF_OK)
        return status;
    uint64_t photon_bytes = (uint64_t)(count ? count : 1) * sizeof(pf_photon);
    pf_vk_buffer *input = NULL;
    status = pf_vk_buffer_create(grid->ctx, photon_bytes, "photons (unsorted)", &input, err);
    if (status == PF_OK && count > 0)
        status = pf_vk_buffer_upload(grid->ctx, input, 0, photons,
                                     (uint64_t)count * sizeof(pf_photon), err);
    pf_photon_grid_job job = {.grid = grid, .photons = input, .count = count, .radius = radius};
    if (status == PF_OK)
        status = build_jobs(grid->ctx, &job, 1, WORK_MAP, lo, hi, err);
    if (status != PF_OK)
        pf_error_prefix(err, "photon grid build (%u photons, radius %g)", count, (double)radius);
    release(grid->ctx, &input);
    return status;
}

pf_status pf_photon_grid_build_device(pf_photon_grid *grid, pf_vk_buffer *photons, uint32_t count,
                                      const float bounds_min[3], const float bounds_max[3],
                                      float radius, pf_error *err)
{
    pf_status status = check_radius(radius, err);
    if (status != PF_OK)
        return status;
    pf_photon_grid_job job = {.grid = grid, .photons = photons, .count = count, .radius = radius};
    status = build_jobs(grid->ctx, &job, 1, WORK_MAP, bounds_min, bounds_max, err);
    if (status != PF_OK)
        pf_error_prefix(err, "photon grid build (%u photons, radius %g)", count, (double)radius);
    return status;
}

double pf_photon_grid_gpu_ms(const pf_photon_grid *grid)
{
    return grid->gpu_ms;
}

pf_photon_grid_info pf_photon_grid_get_info(const pf_photon_grid *grid)
{
    return grid->info;
}

pf_photon_grid_view pf_photon_grid_view_get(const pf_photon_grid *grid)
{
    pf_photon_grid_view view = {NULL, NULL, NULL};
    if (grid->built) {
        view.records = grid->sorted_records;
        view.flux = grid->sorted_flux;
        view.ranges = grid->ranges;
    }
    return view;
}

pf_status pf_photon_grid_stats(pf_photon_grid *grid, pf_photon_grid_info *info, pf_error *err)
{
    if (!grid->built)
        return pf_error_set(err, PF_ERR_INVALID, "photon grid stats: no grid built");
    *info = grid->info;
    uint32_t (*ranges)[2] = malloc((size_t)info->table_size * sizeof *ranges);
    if (!ranges)
        return pf_error_set(err, PF_ERR_NOMEM, "photon grid stats: out of memory");
    pf_status status = pf_vk_buffer_download(grid->ctx, grid->ranges, 0, ranges,
                                             (uint64_t)info->table_size * sizeof *ranges, err);
    for (uint32_t i = 0; status == PF_OK && i < info->table_size; i++) {
        uint32_t size = ranges[i][1] - ranges[i][0];
        info->occupied += size > 0;
        info->largest = size > info->largest ? size : info->largest;
    }
    free(ranges);
    return status;
}

pf_status pf_photon_grid_gather(pf_photon_grid *grid, const float (*queries)[4],
                                uint32_t query_count, uint32_t capacity, uint32_t *counts,
                                uint32_t *indices, pf_error *err)
{
    if (!grid->built)
        return pf_error_set(err, PF_ERR_INVALID, "photon gather: no grid built");
    if (query_count == 0)
        return PF_OK;
    pf_vk_context *ctx = grid->ctx;
    uint64_t index_bytes = (uint64_t)query_count * (capacity ? capacity : 1) * 4;
    pf_vk_buffer *query_buffer = NULL, *count_buffer = NULL, *index_buffer = NULL;
    pf_status status = pf_vk_buffer_create(ctx, (uint64_t)query_count * 16, "gather queries",
                                           &query_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, (uint64_t)query_count * 4, "gather counts",
                                     &count_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, index_bytes, "gather indices", &index_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_upload(ctx, query_buffer, 0, queries, (uint64_t)query_count * 16,
                                     err);
    if (status == PF_OK)
        status = probe_pipeline(grid, "photon_gather_probe", 6, &grid->gather_pipeline, err);
    pf_vk_commands *cmds = NULL;
    if (status == PF_OK)
        status = pf_vk_commands_begin(ctx, &cmds, err);
    photon_grid_push push = push_for(&grid->info, query_count, 0);
    push.capacity = capacity;
    pf_vk_buffer *buffers[] = {grid->sorted_records, grid->original, grid->ranges,
                               query_buffer,         count_buffer,   index_buffer};
    if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, grid->gather_pipeline, buffers, 6, &push, sizeof push,
                                    groups_for(query_count, GATHER_GROUP_SIZE), 1, 1, err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    pf_vk_commands_destroy(cmds);
    if (status == PF_OK)
        status = pf_vk_buffer_download(ctx, count_buffer, 0, counts, (uint64_t)query_count * 4,
                                       err);
    if (status == PF_OK && capacity > 0)
        status = pf_vk_buffer_download(ctx, index_buffer, 0, indices, index_bytes, err);
    release(ctx, &index_buffer);
    release(ctx, &count_buffer);
    release(ctx, &query_buffer);
    return status;
}

/* Runs photon_irradiance_probe.comp in mode (ESTIMATE_*) and reports truncated queries. */
static pf_status run_estimate(pf_photon_grid *grid, uint32_t mode, uint32_t k,
                              const float (*queries)[4], const float (*normals)[4],
                              uint32_t query_count, float (*irradiance)[4], pf_error *err)
{
    const char *name = mode == ESTIMATE_KNN      ? "photon k-NN irradiance"
                       : mode == ESTIMATE_LOOKUP ? "irradiance lookup"
                                                 : "photon irradiance";
    if (!grid->built)
        return pf_error_set(err, PF_ERR_INVALID, "%s: no grid built", name);
    if (query_count == 0)
        return PF_OK;
    pf_vk_context *ctx = grid->ctx;
    uint64_t bytes = (uint64_t)query_count * 16;
    uint64_t flag_bytes = (uint64_t)query_count * 4;
    pf_vk_buffer *query_buffer = NULL, *normal_buffer = NULL, *result_buffer = NULL,
                 *flag_buffer = NULL;
    uint32_t *flags = malloc(flag_bytes);
    pf_status status = flags ? PF_OK : pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", name);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, bytes, "irradiance queries", &query_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, bytes, "irradiance normals", &normal_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, bytes, "irradiance results", &result_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, flag_bytes, "irradiance truncation flags",
                                     &flag_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_upload(ctx, query_buffer, 0, queries, bytes, err);
    if (status == PF_OK)
        status = pf_vk_buffer_upload(ctx, normal_buffer, 0, normals, bytes, err);
    if (status == PF_OK)
        status = probe_pipeline(grid, "photon_irradiance_probe", 7, &grid->irradiance_pipeline,
                                err);
    pf_vk_commands *cmds = NULL;
    if (status == PF_OK)
        status = pf_vk_commands_begin(ctx, &cmds, err);
    photon_grid_push push = push_for(&grid->info, query_count, mode);
    push.capacity = k;
    pf_vk_buffer *buffers[] = {grid->sorted_records, grid->ranges, query_buffer, normal_buffer,
                               result_buffer, flag_buffer, grid->sorted_flux};
    if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, grid->irradiance_pipeline, buffers, 7, &push, sizeof push,
                                    groups_for(query_count, GATHER_GROUP_SIZE), 1, 1, err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    pf_vk_commands_destroy(cmds);
    if (status == PF_OK)
        status = pf_vk_buffer_download(ctx, result_buffer, 0, irradiance, bytes, err);
    if (status == PF_OK)
        status = pf_vk_buffer_download(ctx, flag_buffer, 0, flags, flag_bytes, err);
    uint32_t truncated = 0, first = 0;
    for (uint32_t q = 0; status == PF_OK && q < query_count; q++) {
        if (flags[q] && truncated++ == 0)
            first = q;
    }
    if (status == PF_OK && truncated > 0)
        status = pf_error_set(err, PF_ERR_LIMIT,
                              "%s: %u of %u queries stopped at the %u-iteration loop guard (first: query %u at %g %g %g, radius %g): a clustered map; their estimates cover only the photons visited",
                              name, truncated, query_count, PF_PHOTON_ESTIMATE_MAX_ITERATIONS,
                              first, (double)queries[first][0], (double)queries[first][1],
                              (double)queries[first][2], (double)queries[first][3]);
    free(flags);
    release(ctx, &flag_buffer);
    release(ctx, &result_buffer);
    release(ctx, &normal_buffer);
    release(ctx, &query_buffer);
    return status;
}

pf_status pf_photon_grid_irradiance(pf_photon_grid *grid, const float (*queries)[4],
                                    const float (*normals)[4], uint32_t query_count,
                                    float (*irradiance)[4], pf_error *err)
{
    return run_estimate(grid, ESTIMATE_FIXED, 0, queries, normals, query_count, irradiance, err);
}

pf_status pf_photon_grid_irradiance_knn(pf_photon_grid *grid, const float (*queries)[4],
                                        const float (*normals)[4], uint32_t query_count,
                                        uint32_t k, float (*irradiance)[4], pf_error *err)
{
    if (k < 1 || k > PF_PHOTON_KNN_MAX)
        return pf_error_set(err, PF_ERR_INVALID, "photon k-NN irradiance: k = %u outside [1, %u]",
                            k, PF_PHOTON_KNN_MAX);
    return run_estimate(grid, ESTIMATE_KNN, k, queries, normals, query_count, irradiance, err);
}

pf_status pf_photon_grid_irradiance_lookup(pf_photon_grid *points, const float (*queries)[4],
                                           const float (*normals)[4], uint32_t query_count,
                                           float (*irradiance)[4], pf_error *err)
{
    return run_estimate(points, ESTIMATE_LOOKUP, 0, queries, normals, query_count, irradiance,
                        err);
}

/* What a recorded points build needs until its submission is done. */
typedef struct points_scratch {
    pf_vk_buffer *counter, *list, *input;
    grid_scratch grid;
} points_scratch;

static void release_points_scratch(pf_vk_context *ctx, points_scratch *scratch)
{
    release(ctx, &scratch->counter);
    release(ctx, &scratch->list);
    release(ctx, &scratch->input);
    release_scratch(ctx, &scratch->grid);
}

/*
 * Slots for the points of a map of photons without reading their count back: the coin
 * makes one photon in PF_PHOTON_IRRADIANCE_STRIDE a point (binomial), so the expected
 * count plus 8 standard deviations and 256; every photon when that is more.
 */
static uint32_t points_capacity(uint32_t photons)
{
    double p = 1.0 / PF_PHOTON_IRRADIANCE_STRIDE;
    double bound = ceil(photons * p + 8.0 * sqrt(photons * p * (1.0 - p)) + 256.0);
    return bound < (double)photons ? (uint32_t)bound : photons;
}

/*
 * Records the irradiance points of map (built, or its build recorded before in cmds) and
 * their grid, with no readback in between (issue 44): photon_irradiance_mark.comp lists
 * up to capacity points; photon_irradiance_precompute.comp, dispatched for capacity slots
 * since the host does not know how many were listed, estimates at the listed ones and
 * fills the slots after them with records without a photon; the points' grid is built
 * over all capacity slots, its table planned for the points expected (one photon in
 * PF_PHOTON_IRRADIANCE_STRIDE), the empty slots sorted past every cell. counts (points
 * found, estimates stopped) are downloaded with the commands; finish_points checks them
 * against capacity. *begin and *end: timestamps around it all.
 */
static pf_status record_points(pf_photon_grid *points, const pf_photon_grid *map,
                               pf_vk_commands *cmds, float radius, const float lo[3],
                               const float hi[3], uint32_t capacity, points_scratch *scratch,
                               uint32_t counts[2], int *begin, int *end, pf_error *err)
{
    pf_vk_context *ctx = points->ctx;
    static const uint32_t zero[2] = {0, 0};
    uint32_t photons = map->info.photon_count;
    *begin = *end = -1;
    pf_status status = pf_vk_buffer_create(ctx, sizeof zero, "irradiance point counts",
                                           &scratch->counter, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, (uint64_t)(capacity ? capacity : 1) * 4,
                                     "irradiance point list", &scratch->list, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, (uint64_t)(capacity ? capacity : 1) * sizeof(pf_photon),
                                     "irradiance points (unsorted)", &scratch->input, err);
    if (status == PF_OK && !points->mark_pipeline)
        status = pf_vk_pipeline_create_named(ctx, "photon_irradiance_mark", 6,
                                             sizeof(precompute_push), NULL, 0,
                                             &points->mark_pipeline, err);
    if (status == PF_OK && !points->precompute_pipeline)
        status = pf_vk_pipeline_create_named(ctx, "photon_irradiance_precompute", 6,
                                             sizeof(precompute_push), NULL, 0,
                                             &points->precompute_pipeline, err);
    if (status == PF_OK)
        status = pf_vk_cmd_upload(cmds, scratch->counter, 0, zero, sizeof zero, err);
    if (status != PF_OK)
        return status;
    precompute_push push;
    memset(&push, 0, sizeof push);
    push.grid = pf_photon_grid_push_of(&map->info);
    push.photons = photons;
    push.capacity = capacity;
    push.radius = radius;
    pf_vk_buffer *buffers[] = {map->sorted_records, map->ranges,   scratch->input,
                               scratch->counter,    scratch->list, map->sorted_flux};
    *begin = pf_vk_cmd_timestamp(cmds);
    if (photons > 0) {
        status = pf_vk_cmd_dispatch(cmds, points->mark_pipeline, buffers, 6, &push, sizeof push,
                                    groups_for(photons, GATHER_GROUP_SIZE), 1, 1, err);
        pf_vk_cmd_barrier(cmds);
        if (status == PF_OK)
            status = pf_vk_cmd_dispatch(cmds, points->precompute_pipeline, buffers, 6, &push,
                                        sizeof push, groups_for(capacity, GATHER_GROUP_SIZE), 1,
                                        1, err);
        pf_vk_cmd_barrier(cmds);
    }
    uint32_t expected = (photons + PF_PHOTON_IRRADIANCE_STRIDE - 1) / PF_PHOTON_IRRADIANCE_STRIDE;
    int grid_begin, grid_end;
    if (status == PF_OK)
        status = record_grid(points, cmds, scratch->input, capacity, expected, lo, hi, radius,
                             &scratch->grid, &grid_begin, &grid_end, err);
    *end = status == PF_OK ? grid_end : -1;
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, scratch->counter, 0, counts, sizeof zero, err);
    return status;
}

/* The points' grid once its submission is done: the counts checked, its time, built.
 * PF_ERR_LIMIT when more points were found than capacity (the caller lists again). */
static pf_status finish_points(pf_photon_grid *points, const uint32_t counts[2],
                               uint32_t photons, uint32_t capacity, double gpu_ms,
                               pf_error *err)
{
    if (counts[0] > capacity && counts[0] <= photons)
        return pf_error_set(err, PF_ERR_LIMIT, "irradiance points: %u found, room for %u",
                            counts[0], capacity);
    if (counts[0] > photons || counts[1] > counts[0])
        return pf_error_set(err, PF_ERR_INTERNAL,
                            "irradiance points: %u listed (%u stopped) of %u photons", counts[0],
                            counts[1], photons);
    points->info.photon_count = counts[0];
    points->gpu_ms = gpu_ms;
    points->built = 1;
    return PF_OK;
}

/* One job of a batch while its submission runs: its scratch, timestamps and point counts. */
typedef struct grid_work {
    int what;          /* WORK_MAP: the map (and its points); WORK_POINTS: points only */
    grid_scratch map_scratch;
    points_scratch points_scratch;
    int stamps[4];     /* around the map's build, then the points' (< 0: none) */
    uint32_t found[2]; /* points listed, estimates stopped */
    uint32_t capacity; /* the points' room */
    double points_ms;  /* an earlier try's points time (a full list) */
    int full;          /* the list had no room for every point: listed again */
} grid_work;

static void release_work(pf_vk_context *ctx, grid_work *work)
{
    release_scratch(ctx, &work->map_scratch);
    release_points_scratch(ctx, &work->points_scratch);
}

/* Records job's map build (WORK_MAP) and its points (with job->points) into cmds. */
static pf_status record_job(pf_vk_commands *cmds, pf_photon_grid_job *job, grid_work *work,
                            const float lo[3], const float hi[3], pf_error *err)
{
    for (int s = 0; s < 4; s++)
        work->stamps[s] = -1;
    pf_status status = PF_OK;
    if (work->what == WORK_MAP) {
        release_grid(job->grid);
        status = record_grid(job->grid, cmds, job->photons, job->count, job->count, lo, hi,
                             job->radius, &work->map_scratch, &work->stamps[0],
                             &work->stamps[1], err);
    }
    if (status == PF_OK && job->points) {
        release_grid(job->points);
        status = record_points(job->points, job->grid, cmds, job->radius, lo, hi,
                               work->capacity, &work->points_scratch, work->found,
                               &work->stamps[2], &work->stamps[3], err);
    }
    return status;
}

/* The job's grids once their submission is done: built, timed, the points' counts checked
 * (a full list marks the work full, for a second try with room for every photon). */
static pf_status finish_job(const pf_vk_commands *cmds, pf_photon_grid_job *job,
                            grid_work *work, pf_error *err)
{
    if (work->what == WORK_MAP) {
        job->grid->gpu_ms = pf_vk_commands_elapsed_ms(cmds, work->stamps[0], work->stamps[1]);
        job->grid->built = 1;
    }
    if (!job->points)
        return PF_OK;
    double ms = pf_vk_commands_elapsed_ms(cmds, work->stamps[2], work->stamps[3]);
    if (work->full) /* the first try's time counts too */
        ms = ms >= 0.0 && work->points_ms >= 0.0 ? ms + work->points_ms : -1.0;
    uint32_t photons = job->grid->info.photon_count;
    pf_status status = finish_points(job->points, work->found, photons, work->capacity, ms, err);
    if (status == PF_ERR_LIMIT && work->capacity < photons) {
        work->full = 1;
        work->points_ms = ms;
        return PF_OK;
    }
    job->counts.points = work->found[0];
    job->counts.truncated = work->found[1];
    return status;
}

/* The jobs whose work is not WORK_NONE, recorded in one submission and finished. */
static pf_status submit_jobs(pf_vk_context *ctx, pf_photon_grid_job *jobs, grid_work *work,
                             uint32_t count, const float lo[3], const float hi[3],
                             pf_error *err)
{
    pf_vk_commands *cmds = NULL;
    pf_status status = pf_vk_commands_begin(ctx, &cmds, err);
    for (uint32_t i = 0; status == PF_OK && i < count; i++)
        if (work[i].what != WORK_NONE)
            status = record_job(cmds, &jobs[i], &work[i], lo, hi, err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    for (uint32_t i = 0; status == PF_OK && i < count; i++)
        if (work[i].what != WORK_NONE)
            status = finish_job(cmds, &jobs[i], &work[i], err);
    pf_vk_commands_destroy(cmds);
    for (uint32_t i = 0; i < count; i++)
        release_work(ctx, &work[i]);
    return status;
}

/*
 * Builds the jobs' grids (what: WORK_MAP, their maps and points; WORK_POINTS, the points
 * of maps already built) in one submission; where a points list was full, those points
 * again with room for every photon, in a second. On failure the points are left unbuilt,
 * and the maps too where this built them.
 */
static pf_status build_jobs(pf_vk_context *ctx, pf_photon_grid_job *jobs, uint32_t count,
                            int what, const float lo[3], const float hi[3], pf_error *err)
{
    grid_work *work = calloc(count ? count : 1, sizeof *work);
    if (!work)
        return pf_error_set(err, PF_ERR_NOMEM, "photon grids: out of memory (%u)", count);
    for (uint32_t i = 0; i < count; i++) {
        work[i].what = what;
        uint32_t photons = what == WORK_MAP ? jobs[i].count : jobs[i].grid->info.photon_count;
        work[i].capacity = points_capacity(photons);
        memset(&jobs[i].counts, 0, sizeof jobs[i].counts);
    }
    pf_status status = submit_jobs(ctx, jobs, work, count, lo, hi, err);
    int again = 0;
    for (uint32_t i = 0; status == PF_OK && i < count; i++) {
        work[i].what = work[i].full ? WORK_POINTS : WORK_NONE;
        if (work[i].full)
            work[i].capacity = jobs[i].grid->info.photon_count;
        again |= work[i].full;
    }
    if (status == PF_OK && again)
        status = submit_jobs(ctx, jobs, work, count, lo, hi, err);
    free(work);
    for (uint32_t i = 0; status != PF_OK && i < count; i++) {
        if (jobs[i].points)
            release_grid(jobs[i].points);
        if (what == WORK_MAP)
            release_grid(jobs[i].grid);
    }
    return status;
}

pf_status pf_photon_grid_build_batch(pf_photon_grid_job *jobs, uint32_t count,
                                     const float bounds_min[3], const float bounds_max[3],
                                     pf_error *err)
{
    if (count == 0)
        return PF_OK;
    pf_status status = PF_OK;
    for (uint32_t i = 0; status == PF_OK && i < count; i++) {
        if (!jobs[i].grid || (jobs[i].count > 0 && !jobs[i].photons))
            return pf_error_set(err, PF_ERR_INVALID, "photon grids: job %u lacks its grid or photons", i);
        status = check_radius(jobs[i].radius, err);
    }
    if (status == PF_OK)
        status = build_jobs(jobs[0].grid->ctx, jobs, count, WORK_MAP, bounds_min, bounds_max,
                            err);
    if (status != PF_OK && count > 1)
        pf_error_prefix(err, "photon grids of %u passes", count);
    return status;
}

pf_status pf_photon_grid_build_irradiance(pf_photon_grid *points, const pf_photon_grid *map,
                                          float radius, const float bounds_min[3],
                                          const float bounds_max[3],
                                          pf_photon_irradiance_counts *counts, pf_error *err)
{
    memset(counts, 0, sizeof *counts);
    pf_status status = check_radius(radius, err);
    if (status != PF_OK)
        return status;
    if (!map->built)
        return pf_error_set(err, PF_ERR_INVALID, "irradiance points: the photon map has no grid");
    if (radius > map->info.cell_size)
        return pf_error_set(err, PF_ERR_INVALID,
                            "irradiance points: radius %g exceeds the map's cell %g",
                            (double)radius, (double)map->info.cell_size);
    /* The map is only read: its build is not part of this job. */
    pf_photon_grid_job job = {.grid = (pf_photon_grid *)map, .radius = radius, .points = points};
    status = build_jobs(points->ctx, &job, 1, WORK_POINTS, bounds_min, bounds_max, err);
    if (status != PF_OK) {
        pf_error_prefix(err, "irradiance points (%u photons)", map->info.photon_count);
        return status;
    }
    *counts = job.counts;
    return PF_OK;
}

pf_status pf_photon_grid_build_with_irradiance(pf_photon_grid *map, pf_photon_grid *points,
                                               pf_vk_buffer *photons, uint32_t count,
                                               const float bounds_min[3],
                                               const float bounds_max[3], float radius,
                                               pf_photon_irradiance_counts *counts,
                                               pf_error *err)
{
    memset(counts, 0, sizeof *counts);
    pf_status status = check_radius(radius, err);
    if (status != PF_OK)
        return status;
    pf_photon_grid_job job = {.grid = map, .photons = photons, .count = count, .radius = radius,
                              .points = points};
    status = build_jobs(map->ctx, &job, 1, WORK_MAP, bounds_min, bounds_max, err);
    if (status != PF_OK) {
        pf_error_prefix(err, "photon grid and irradiance points (%u photons, radius %g)", count,
                        (double)radius);
        return status;
    }
    *counts = job.counts;
    return PF_OK;
}
