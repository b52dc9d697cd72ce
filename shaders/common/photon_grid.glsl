// Photon grid lookup (core/photon/pf_photon.h describes the grid): the cells
// whose photons can lie within a radius of a point, as distinct table keys.
// Every radiance estimate gathers through these functions.
//
// Cell coordinates are floor((p - origin) * inv_cell) with `precise`
// arithmetic: correctly rounded subtraction and multiplication are monotone,
// and so is rounding x ± r, so a photon inside the query's box lands in a
// cell of the box's cell range. The box is widened by 2^-8 r so that a photon
// accepted by the float distance test (which may round a distance just above
// r down to r) is inside it too. The host makes the cell 2^-6 larger than the
// build radius, so the box spans at most 3 cells per axis (27 keys); 4 are
// allowed for grids so large that cell coordinates lose precision.
#ifndef PF_PHOTON_GRID_GLSL
#define PF_PHOTON_GRID_GLSL

const uint PHOTON_GRID_MAX_KEYS = 64u;
const float PHOTON_GRID_BOX_MARGIN = 1.0 + 1.0 / 256.0;
// Cell coordinates are clamped to ±2^30 before conversion to int (a query
// far outside the grid then still converts without overflow).
const float PHOTON_GRID_COORD_LIMIT = 1073741824.0;

struct PhotonGrid {
    vec3 origin;
    float inv_cell;  // 1 / cell edge
    uvec3 dims;      // dense grid cells per axis
    uint hashed;     // 1: spatial hash into table_size buckets (a power of two)
    uint table_size;
};

int photon_grid_coord(float value, float origin, float inv_cell)
{
    precise float scaled = (value - origin) * inv_cell;
    return int(floor(clamp(scaled, -PHOTON_GRID_COORD_LIMIT, PHOTON_GRID_COORD_LIMIT)));
}

ivec3 photon_grid_cell(vec3 position, PhotonGrid grid)
{
    return ivec3(photon_grid_coord(position.x, grid.origin.x, grid.inv_cell),
                 photon_grid_coord(position.y, grid.origin.y, grid.inv_cell),
                 photon_grid_coord(position.z, grid.origin.z, grid.inv_cell));
}

// Teschner et al. 2003, "Optimized Spatial Hashing for Collision Detection
// of Deformable Objects" (primes as in REFERENCE.md) of the cell's 2×2×2
// block, the cell's place in its block in the key's low 3 bits; or the
// dense index with coordinates clamped into the grid (only the host's
// bounding box rounding can put a photon outside it, and then by less than
// a cell). Hashing blocks keeps a block's 8 ranges in one 64-byte line and
// its photons together: the 8 cells of a lookup touch ~3.4 lines of the
// table instead of 8, an estimate's 27 cells 8 instead of 27 (random reads
// are what estimates wait on: bench/RESULTS.md).
uint photon_grid_block_hash(uvec3 block)
{
    return (block.x * 73856093u) ^ (block.y * 19349663u) ^ (block.z * 83492791u);
}

uint photon_grid_key(ivec3 cell, PhotonGrid grid)
{
    if (grid.hashed != 0u) {
        uvec3 u = uvec3(cell);
        uvec3 block = u >> 1u;
        uint within = (u.x & 1u) | ((u.y & 1u) << 1u) | ((u.z & 1u) << 2u);
        uint hash = photon_grid_block_hash(block);
        return ((hash << 3u) | within) & (grid.table_size - 1u);
    }
    uvec3 c = uvec3(clamp(cell, ivec3(0), ivec3(grid.dims) - 1));
    return (c.z * grid.dims.y + c.y) * grid.dims.x + c.x;
}

// Whether two cells of the box low..high can share a key. In a dense grid
// only where the box reaches past the grid (cells clamped into its border).
// In a hashed one a cell's place in its 2×2×2 block is its key's low 3 bits,
// so only cells of two blocks whose hashes collide in the table can: with at
// most 3 cells per axis the box touches at most 2 blocks per axis (b0, b1),
// whose 8 combinations are compared pairwise in straight-line code (4 cells
// per axis, in far-out grids: assumed to repeat). Deciding this first lets
// photon_grid_box_keys skip its de-duplication loop, which for 27 cells took
// 351 steps (~12 % of an estimate on llvmpipe, bench/RESULTS.md).
bool photon_grid_keys_may_repeat(ivec3 low, ivec3 high, PhotonGrid grid)
{
    if (grid.hashed == 0u)
        return any(lessThan(low, ivec3(0))) || any(greaterThanEqual(high, ivec3(grid.dims)));
    // Tables under 8 buckets mask a cell's place in its block too.
    if (any(greaterThan(high - low, ivec3(2))) || grid.table_size < 8u)
        return true;
    uvec3 b0 = uvec3(low) >> 1u, b1 = uvec3(high) >> 1u;
    // Axes along which the box touches two blocks: combination i takes b1's
    // coordinate on axis a where bit a of i is set.
    uint split = (b0.x != b1.x ? 1u : 0u) | (b0.y != b1.y ? 2u : 0u) | (b0.z != b1.z ? 4u : 0u);
    uint mask = (grid.table_size - 1u) >> 3u; // the block hash's bits in a key
    uint hashes[8];
    for (uint i = 0u; i < 8u; i++) {
        uvec3 block = uvec3((i & 1u) != 0u ? b1.x : b0.x, (i & 2u) != 0u ? b1.y : b0.y,
                            (i & 4u) != 0u ? b1.z : b0.z);
        hashes[i] = photon_grid_block_hash(block) & mask;
    }
    bool repeat = false;
    for (uint i = 0u; i < 8u; i++)
        for (uint j = i + 1u; j < 8u; j++)
            repeat = repeat || (((i ^ j) & split) != 0u && hashes[i] == hashes[j]);
    return repeat;
}

// The distinct keys of the cells low..high (inclusive, at most 4 per axis);
// returns how many. A key shared by two cells (hash collision, or clamping
// at the grid's border) is listed once, so no photon is counted twice.
uint photon_grid_box_keys(ivec3 low, ivec3 high, PhotonGrid grid,
                          out uint keys[PHOTON_GRID_MAX_KEYS])
{
    uint count = 0u;
    uint compared = photon_grid_keys_may_repeat(low, high, grid) ? PHOTON_GRID_MAX_KEYS : 0u;
    // A dense grid holds every photon in its cells, or (rounding of the
    // host's bounding box) in a cell just outside, clamped into the border
    // cell: a query box that misses the grid by more than one cell can find
    // nothing, and skipping it keeps far queries from scanning border cells.
    if (grid.hashed == 0u &&
        (any(lessThan(high, ivec3(-1))) || any(greaterThan(low, ivec3(grid.dims))))) {
        return 0u;
    }
    for (int z = low.z; z <= high.z; z++) {
        for (int y = low.y; y <= high.y; y++) {
            for (int cx = low.x; cx <= high.x; cx++) {
                uint key = photon_grid_key(ivec3(cx, y, z), grid);
                bool seen = false;
                for (uint k = 0u; k < min(count, compared); k++)
                    seen = seen || keys[k] == key;
                if (!seen)
                    keys[count++] = key;
            }
        }
    }
    return count;
}

// The distinct keys of the cells overlapping the box [x - r, x + r] (27 at
// most when r <= the build radius, 64 in far-out grids).
uint photon_grid_candidate_keys(vec3 x, float radius, PhotonGrid grid,
                                out uint keys[PHOTON_GRID_MAX_KEYS])
{
    float reach = radius * PHOTON_GRID_BOX_MARGIN;
    ivec3 low = photon_grid_cell(x - vec3(reach), grid);
    ivec3 high = min(photon_grid_cell(x + vec3(reach), grid), low + 3);
    return photon_grid_box_keys(low, high, grid, keys);
}

// The 2×2×2 cells nearest to x: photon_grid_nearby_cell(low, i) for i in
// 0..7 with low = photon_grid_nearby_low(x, grid). Together they cover the
// box [x - c/2, x + c/2] (c the cell edge), so they hold every point within
// c/2 of x and some up to 1.5 c away: enough for a nearest-point lookup
// (photon_irradiance_lookup), which needs a near point, not every point
// within a radius, and visits 8 cells instead of 27.
ivec3 photon_grid_nearby_low(vec3 x, PhotonGrid grid)
{
    return photon_grid_cell(x - vec3(0.5 / grid.inv_cell), grid);
}

ivec3 photon_grid_nearby_cell(ivec3 low, uint i)
{
    return low + ivec3(i & 1u, (i >> 1u) & 1u, i >> 2u);
}

#endif
