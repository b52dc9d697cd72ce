// Photon grid lookup (core/photon/pf_photon.h describes the grid): the cells
// whose photons can lie within a radius of a point, walked one distinct table
// key at a time. Every radiance estimate gathers through these functions.
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
// photon_cell_walk skip its comparison of each cell's key with the earlier
// cells', which for 27 cells takes 351 steps (~12 % of an estimate on llvmpipe,
// bench/RESULTS.md).
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

// The cells overlapping the box [x - r, x + r] (27 at most when r <= the build
// radius, 64 in far-out grids), x fastest, then y, then z, walked by
// photon_cell_walk_next. The walk computes each cell's key when it gets there
// instead of listing the keys first: llvmpipe stores and loads a private array
// with a per-lane index lane by lane (bench/RESULTS.md, "The photon grid's cells
// walked").
struct PhotonCellWalk {
    ivec3 low, high; // the box's cells (inclusive, at most 4 per axis)
    ivec3 cell;      // the next cell
    uint ordinal;    // the next cell's place in the walk
    bool left;       // whether there is a next cell
    uvec2 repeats;   // bit n of 64: cell n's key an earlier cell of the box had
};

// The cell after cell in the walk's order; false after high.
bool photon_cell_walk_step(inout ivec3 cell, ivec3 low, ivec3 high)
{
    bool wrap_x = cell.x >= high.x;
    bool wrap_y = wrap_x && cell.y >= high.y;
    bool more = !(wrap_y && cell.z >= high.z);
    cell.x = wrap_x ? low.x : cell.x + 1;
    cell.y = wrap_y ? low.y : (wrap_x ? cell.y + 1 : cell.y);
    cell.z = wrap_y ? cell.z + 1 : cell.z;
    return more;
}

PhotonCellWalk photon_cell_walk(vec3 x, float radius, PhotonGrid grid)
{
    float reach = radius * PHOTON_GRID_BOX_MARGIN;
    PhotonCellWalk walk;
    walk.low = photon_grid_cell(x - vec3(reach), grid);
    walk.high = min(photon_grid_cell(x + vec3(reach), grid), walk.low + 3);
    walk.cell = walk.low;
    walk.ordinal = 0u;
    // A dense grid holds every photon in its cells, or (rounding of the
    // host's bounding box) in a cell just outside, clamped into the border
    // cell: a query box that misses the grid by more than one cell can find
    // nothing, and skipping it keeps far queries from scanning border cells.
    walk.left = all(lessThanEqual(walk.low, walk.high)) &&
                !(grid.hashed == 0u && (any(lessThan(walk.high, ivec3(-1))) ||
                                        any(greaterThan(walk.low, ivec3(grid.dims)))));
    // A cell whose key an earlier cell had (a hash collision, or clamping at a dense
    // grid's border) is marked, so that no photon is counted twice. Only where keys
    // may repeat: elsewhere these loops run no iteration.
    walk.repeats = uvec2(0u);
    ivec3 extent = walk.high - walk.low + 1;
    uint cells = walk.left && photon_grid_keys_may_repeat(walk.low, walk.high, grid)
                     ? uint(extent.x * extent.y * extent.z)
                     : 0u;
    ivec3 cell = walk.low;
    for (uint n = 0u; n < cells; n++) {
        uint key = photon_grid_key(cell, grid);
        ivec3 earlier = walk.low;
        bool repeat = false;
        for (uint m = 0u; m < n; m++) {
            repeat = repeat || photon_grid_key(earlier, grid) == key;
            photon_cell_walk_step(earlier, walk.low, walk.high);
        }
        uint bit = repeat ? 1u << (n & 31u) : 0u;
        walk.repeats |= n < 32u ? uvec2(bit, 0u) : uvec2(0u, bit);
        photon_cell_walk_step(cell, walk.low, walk.high);
    }
    return walk;
}

// The next cell's key, and the walk moved past it; false when no cell is left.
// fresh is false for a cell whose key an earlier cell of the walk had: its
// photons were visited already.
bool photon_cell_walk_next(inout PhotonCellWalk walk, PhotonGrid grid, out uint key,
                           out bool fresh)
{
    key = 0u;
    fresh = false;
    if (!walk.left)
        return false;
    key = photon_grid_key(walk.cell, grid);
    uint n = walk.ordinal++;
    fresh = (((n < 32u ? walk.repeats.x : walk.repeats.y) >> (n & 31u)) & 1u) == 0u;
    walk.left = photon_cell_walk_step(walk.cell, walk.low, walk.high);
    return true;
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
