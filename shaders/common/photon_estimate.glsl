// Radiance estimates from a photon grid (Jensen 2001, ch. 7), the code every
// integrator that reads photon maps uses.
//
// The including shader declares, before including this file, as uniform
// texel buffers (core/vk binds them from the declarations: isamplerBuffer
// as 16-byte RGBA32 records, usamplerBuffer as R32 words):
//   uniform isamplerBuffer grid_records; // per photon in cell order: x, y, z, directions
//   uniform usamplerBuffer grid_flux;    // per photon in cell order: its RGB9E5 flux
//   uniform isamplerBuffer grid_ranges;  // [start, end) per cell key: two keys a texel
// (photon_grid_finish.comp writes that layout) and includes photon_types.glsl
// and photon_grid.glsl (or photon_grid_push.glsl).
// Texel buffers rather than storage buffers for the reason bih_traverse.glsl
// gives: llvmpipe loads a storage buffer word lane by lane in a branchy
// loop, and a texel fetch is one vector gather. The estimates' loops are
// nearly all loads (bench/RESULTS.md, "The gather's photon lookups"), and
// one 16-byte fetch costs llvmpipe about what one word's does (bench/vk
// load_bench), so what a step tests (position, directions) is one record
// and the flux, read only for what passes, lies apart.
//
// A photon counts at a surface point x with normal n only if it arrived from
// n's side (incoming · n < 0) and was stored on a surface facing the same
// way (its normal · n >= PHOTON_NORMAL_AGREEMENT): photons from the other
// side of a thin wall or round a corner would leak light (REFERENCE.md).
#ifndef PF_PHOTON_ESTIMATE_GLSL
#define PF_PHOTON_ESTIMATE_GLSL
#extension GL_EXT_control_flow_attributes : require // [[unroll]]

#include "materials.glsl"
#include "rng.glsl"

// cos 25°: wider than the 8-bit normal quantisation (< 1°), narrow enough
// that a wall meeting the floor (90°) never shares photons with it.
const float PHOTON_NORMAL_AGREEMENT = 0.9063;
// Cone filter (Jensen 2001, eq. 7.8): weight 1 − d/(k r), normalised by
// 1 − 2/(3k); k = 1.1 as REFERENCE.md gives.
const float PHOTON_CONE_K = 1.1;
const float PHOTON_CONE_NORMALISATION = 1.0 - 2.0 / (3.0 * PHOTON_CONE_K);
// llvmpipe (lavapipe) silently stops every loop of a shader invocation
// after 65,535 iterations in total, counted per SIMD group: a loop runs
// until its slowest lane is done, and nested loops over divergent lanes add
// up beyond any one lane's count. So an estimate visits its candidate cells
// and photons in ONE flat loop of at most this many steps (one per photon,
// one per cell), keeps the k-NN's loops unrolled, and reports when it stops
// early (`truncated`). Its other loops: photon_grid.glsl's marking of repeated
// cells (351 iterations for 27 cells, only where keys may repeat).
// Half the cap by default, leaving the rest to the calling kernel (its BIH
// traversals count too); a kernel that runs several estimates per
// invocation defines a smaller budget before including this file, the probe
// (one estimate) a larger one.
#ifndef PHOTON_ESTIMATE_MAX_ITERATIONS
#define PHOTON_ESTIMATE_MAX_ITERATIONS 32768u
#endif
// Largest k of photon_irradiance_knn (pf_photon.h's PF_PHOTON_KNN_MAX). A kernel
// whose k is smaller defines its own before including this file: the estimate
// keeps this many neighbours in registers and compares each photon with all of them.
#ifndef PHOTON_KNN_MAX
#define PHOTON_KNN_MAX 64u
#endif
// Smallest k-NN radius as a fraction of max_radius (coincident photons).
const float PHOTON_KNN_MIN_RADIUS_FRACTION = 1.0 / 1024.0;

// Photon i's record (x, y, z bits, directions) and flux, and the [start,
// end) range of a cell key.
uvec4 photon_texel_record(isamplerBuffer records, uint i)
{
    return uvec4(texelFetch(records, int(i)));
}

uint photon_texel_flux(usamplerBuffer flux, uint i)
{
    return texelFetch(flux, int(i)).x;
}

uvec2 photon_texel_range(isamplerBuffer ranges, uint key)
{
    uvec4 pair = uvec4(texelFetch(ranges, int(key >> 1u)));
    return (key & 1u) != 0u ? pair.zw : pair.xy;
}

// The flat loop's move to the next cell: once the photons [index, end) of
// the current cell are used up, the range of the walk's next cell (none for a
// cell whose key an earlier one had), or done = true and out of the loop after
// the last. Each estimate's loop starts with it; a macro, since it breaks and
// continues the caller's loop (whose variables walk, grid, index, end and done
// it uses).
#define PHOTON_NEXT_CELL(RANGES)                                                              \
    if (index >= end) {                                                                       \
        uint cell_key;                                                                        \
        bool fresh;                                                                           \
        if (!photon_cell_walk_next(walk, grid, cell_key, fresh)) {                            \
            done = true;                                                                      \
            break;                                                                            \
        }                                                                                     \
        uvec2 range = photon_texel_range(RANGES, cell_key);                                   \
        index = range.x;                                                                      \
        end = fresh ? range.y : range.x;                                                      \
        continue;                                                                             \
    }

Photon grid_photon(uint i)
{
    uvec4 record = photon_texel_record(grid_records, i);
    return photon_unpack(record.x, record.y, record.z, photon_texel_flux(grid_flux, i), record.w);
}

bool photon_accepted(Photon photon, vec3 normal)
{
    return dot(photon.incoming, normal) < 0.0 &&
           dot(photon.normal, normal) >= PHOTON_NORMAL_AGREEMENT;
}

// Precomputed irradiance (Christensen 1999, "Faster Photon Map Global
// Illumination"): photon_irradiance_precompute.comp estimates the irradiance
// once at about every PHOTON_IRRADIANCE_STRIDE-th photon of a map and stores
// it as a record of the photon layout (position; the cone-filtered sum of
// the estimate before its division by π r², as RGB9E5 flux; the photon's
// surface normal in the high half of the directions word). A final-gather
// ray then reads the nearest such point with an agreeing normal instead of
// summing every photon within the radius.
//
// Which photons become points is a coin per photon, a hash of its position
// (photon_is_irradiance_point; not of its index: the order of a map follows
// the tracing threads' atomic slot claims, and the same seed must give the
// same points), and a point's estimate sums only the other
// photons, the non-points, scaled by STRIDE / (STRIDE - 1). Two independent
// thinnings of the photons are independent point sets, so how near the
// points lie to a gather hit says nothing about how many photons its
// estimate found. Points estimated from every photon were biased twice: by
// the centre photon itself (+1 photon in a disc of ~5 weighted ones, +15 %)
// and, leaving that one out, by the lookup itself: the nearest point to a
// gather hit is most often one with a large empty patch around it, whose
// estimate is low (-6 % on the Cornell box's indirect light).
// A photon that is not a point, or whose estimate stopped at the loop
// guard, gets a record without a photon (photon_record_present), which the
// grid build keeps out of every cell.
const uint PHOTON_IRRADIANCE_STRIDE = 4u;

bool photon_is_irradiance_point(vec3 position)
{
    uvec3 bits = floatBitsToUint(position);
    // Teschner's primes mix the three coordinates into one word for one hash.
    return pcg_hash((bits.x * 73856093u) ^ (bits.y * 19349663u) ^ (bits.z * 83492791u)) %
               PHOTON_IRRADIANCE_STRIDE ==
           0u;
}

// The cone-filtered sum of photon_irradiance_guarded, over the photons that
// are not irradiance points when skip_points.
vec3 photon_irradiance_sum(vec3 x, vec3 normal, float radius, PhotonGrid grid, bool skip_points,
                           out bool truncated)
{
    PhotonCellWalk walk = photon_cell_walk(x, radius, grid);
    vec3 sum = vec3(0.0);
    float radius2 = radius * radius;
    uint index = 0u, end = 0u;
    bool done = false;
    for (uint step = 0u; step < PHOTON_ESTIMATE_MAX_ITERATIONS; step++) {
        PHOTON_NEXT_CELL(grid_ranges)
        Photon photon = grid_photon(index);
        vec3 d = photon.position - x;
        float distance2 = dot(d, d);
        if (distance2 <= radius2 && photon_accepted(photon, normal) &&
            !(skip_points && photon_is_irradiance_point(photon.position)))
            sum += photon.flux * (1.0 - sqrt(distance2) / (PHOTON_CONE_K * radius));
        index++;
    }
    truncated = !done;
    return sum;
}

// Irradiance at x (flux-scale units per m²) from the photons within radius
// (<= the grid's build radius), cone-filtered. truncated: the gather reached
// PHOTON_ESTIMATE_MAX_ITERATIONS (a clustered map) and the sum covers only
// the photons visited before it; the caller must count the sample as failed.
vec3 photon_irradiance_guarded(vec3 x, vec3 normal, float radius, PhotonGrid grid,
                               out bool truncated)
{
    return photon_irradiance_sum(x, normal, radius, grid, false, truncated) /
           (PHOTON_CONE_NORMALISATION * PI * radius * radius);
}

// photon_irradiance_guarded without the flag, for callers that count
// failures elsewhere: a truncated estimate is an underestimate.
vec3 photon_irradiance(vec3 x, vec3 normal, float radius, PhotonGrid grid)
{
    bool truncated;
    return photon_irradiance_guarded(x, normal, radius, grid, truncated);
}

// Adaptive-radius irradiance (Jensen 2001, eq. 7.6 with the cone filter):
// the k nearest accepted photons within max_radius (<= the grid's build
// radius; k is clamped to [1, PHOTON_KNN_MAX]), cone-filtered over the
// distance r_k of the k-th and divided by π r_k² (× the cone's
// normalisation); with fewer than k within max_radius, r = max_radius.
// radius_used returns r, never below PHOTON_KNN_MIN_RADIUS_FRACTION ×
// max_radius (k photons in one spot would otherwise divide by zero).
// truncated as for photon_irradiance_guarded: then the estimate uses the k
// nearest of the photons visited.
//
// The PHOTON_KNN_MAX nearest so far are kept sorted by distance², and a photon
// is inserted by one compare-exchange per entry, unrolled: every index is a
// constant, so the entries stay in registers. A max-heap in private arrays
// (log2 k sift steps) was over half of `fast`'s shading on staircase2 on
// llvmpipe: it stores and loads a private array lane by lane, and it runs both
// the heap's insertion and its replacement for every photon, since it runs an
// `if` for all lanes (bench/RESULTS.md, "The caustic k-NN"). Of photons at
// the same distance the one visited first is kept.
vec3 photon_irradiance_knn(vec3 x, vec3 normal, uint k, float max_radius, PhotonGrid grid,
                           out float radius_used, out bool truncated)
{
    uint wanted = clamp(k, 1u, PHOTON_KNN_MAX);
    const float infinity = uintBitsToFloat(0x7f800000u);
    float nearest_distance2[PHOTON_KNN_MAX];
    uint nearest_photon[PHOTON_KNN_MAX];
    [[unroll]] for (uint j = 0u; j < PHOTON_KNN_MAX; j++) {
        nearest_distance2[j] = infinity;
        nearest_photon[j] = 0u;
    }
    uint found = 0u;
    PhotonCellWalk walk = photon_cell_walk(x, max_radius, grid);
    float max_radius2 = max_radius * max_radius;
    uint index = 0u, end = 0u;
    bool done = false;
    for (uint step = 0u; step < PHOTON_ESTIMATE_MAX_ITERATIONS; step++) {
        PHOTON_NEXT_CELL(grid_ranges)
        uint i = index++;
        Photon photon = grid_photon(i);
        vec3 d = photon.position - x;
        float distance2 = dot(d, d);
        if (distance2 > max_radius2 || !photon_accepted(photon, normal))
            continue;
        found++;
        // The new entry sinks past the nearer ones; each farther one moves down a place.
        float carried = distance2;
        uint carried_photon = i;
        [[unroll]] for (uint j = 0u; j < PHOTON_KNN_MAX; j++) {
            bool nearer = carried < nearest_distance2[j];
            float kept = nearest_distance2[j];
            uint kept_photon = nearest_photon[j];
            nearest_distance2[j] = nearer ? carried : kept;
            nearest_photon[j] = nearer ? carried_photon : kept_photon;
            carried = nearer ? kept : carried;
            carried_photon = nearer ? kept_photon : carried_photon;
        }
    }
    truncated = !done;
    uint used = min(found, wanted);
    float kth_distance2 = 0.0;
    [[unroll]] for (uint j = 0u; j < PHOTON_KNN_MAX; j++)
        kth_distance2 = j + 1u == wanted ? nearest_distance2[j] : kth_distance2;
    float radius = found >= wanted ? sqrt(kth_distance2) : max_radius;
    radius = max(radius, PHOTON_KNN_MIN_RADIUS_FRACTION * max_radius);
    radius_used = radius;
    vec3 sum = vec3(0.0);
    [[unroll]] for (uint j = 0u; j < PHOTON_KNN_MAX; j++) {
        if (j < used) {
            Photon photon = grid_photon(nearest_photon[j]);
            sum += photon.flux * (1.0 - sqrt(nearest_distance2[j]) / (PHOTON_CONE_K * radius));
        }
    }
    return sum / (PHOTON_CONE_NORMALISATION * PI * radius * radius);
}


// The buffers of the precomputed points: those of photon_estimate's grid
// unless the including shader binds them apart (render_final.comp binds
// both the map and its points).
#ifndef PHOTON_LOOKUP_RECORDS
#define PHOTON_LOOKUP_RECORDS grid_records
#define PHOTON_LOOKUP_FLUX grid_flux
#define PHOTON_LOOKUP_RANGES grid_ranges
#endif

// Irradiance at x (as photon_irradiance_guarded's) from the nearest
// precomputed point of `points` within radius (the radius of the points'
// own estimates, <= their grid's build radius) whose normal agrees with
// normal; false when there is none (the caller estimates from the photons).
// Visits the points of the 2×2×2 cells nearest to x (photon_grid_nearby_cell)
// in one flat loop, truncated as photon_irradiance_guarded. Their keys are not made
// distinct first: a cell visited twice (a hash collision, or clamping at a
// dense grid's border) offers the same points again, which cannot change
// the nearest, and the search skips the key list and its dedup loop.
// Of two points at the same distance, the one first in position order (x,
// then y, then z bits), so that the lookup does not depend on the order in
// which the points were listed (photon_irradiance_precompute.comp).
bool photon_lookup_precedes(uvec3 a, uvec3 b)
{
    return a.x != b.x ? a.x < b.x : a.y != b.y ? a.y < b.y : a.z < b.z;
}

bool photon_irradiance_lookup(vec3 x, vec3 normal, float radius, PhotonGrid points,
                              out vec3 irradiance, out bool truncated)
{
    ivec3 low = photon_grid_nearby_low(x, points);
    float nearest2 = radius * radius;
    uint nearest = 0xFFFFFFFFu;
    uvec3 nearest_bits = uvec3(0u); // the nearest's position bits
    // The 8 cells' ranges first, in straight-line code, and then one step
    // per point: step s is point s of the cells' concatenation. A loop that
    // also stepped from cell to cell spent 8 of its steps (every step pays
    // for all its code on llvmpipe, whatever a lane does) on the ranges.
#define PHOTON_LOOKUP_CELL_RANGE(I)                                                            \
    photon_texel_range(PHOTON_LOOKUP_RANGES,                                                   \
                       photon_grid_key(photon_grid_nearby_cell(low, I), points))
    uvec2 r0 = PHOTON_LOOKUP_CELL_RANGE(0u), r1 = PHOTON_LOOKUP_CELL_RANGE(1u);
    uvec2 r2 = PHOTON_LOOKUP_CELL_RANGE(2u), r3 = PHOTON_LOOKUP_CELL_RANGE(3u);
    uvec2 r4 = PHOTON_LOOKUP_CELL_RANGE(4u), r5 = PHOTON_LOOKUP_CELL_RANGE(5u);
    uvec2 r6 = PHOTON_LOOKUP_CELL_RANGE(6u), r7 = PHOTON_LOOKUP_CELL_RANGE(7u);
#undef PHOTON_LOOKUP_CELL_RANGE
    // Where each cell's points begin in the concatenation (e8: the total).
    uint e1 = r0.y - r0.x;
    uint e2 = e1 + (r1.y - r1.x);
    uint e3 = e2 + (r2.y - r2.x);
    uint e4 = e3 + (r3.y - r3.x);
    uint e5 = e4 + (r4.y - r4.x);
    uint e6 = e5 + (r5.y - r5.x);
    uint e7 = e6 + (r6.y - r6.x);
    uint e8 = e7 + (r7.y - r7.x);
    bool done = false;
    for (uint step = 0u; step < PHOTON_ESTIMATE_MAX_ITERATIONS; step++) {
        if (step >= e8) {
            done = true;
            break;
        }
        uint point = step < e4 ? (step < e2 ? (step < e1 ? r0.x + step : r1.x + (step - e1))
                                            : (step < e3 ? r2.x + (step - e2)
                                                         : r3.x + (step - e3)))
                               : (step < e6 ? (step < e5 ? r4.x + (step - e4)
                                                         : r5.x + (step - e5))
                                            : (step < e7 ? r6.x + (step - e6)
                                                         : r7.x + (step - e7)));
        uvec4 record = photon_texel_record(PHOTON_LOOKUP_RECORDS, point);
        uvec3 bits = record.xyz;
        vec3 d = uintBitsToFloat(bits) - x;
        float distance2 = dot(d, d);
        if (distance2 > nearest2)
            continue;
        if (dot(octahedral_unpack8(record.w >> 16u), normal) >= PHOTON_NORMAL_AGREEMENT &&
            (distance2 < nearest2 || nearest == 0xFFFFFFFFu ||
             photon_lookup_precedes(bits, nearest_bits))) {
            nearest2 = distance2;
            nearest = point;
            nearest_bits = bits;
        }
    }
    truncated = !done;
    bool found = nearest != 0xFFFFFFFFu;
    irradiance = found ? rgb9e5_unpack(photon_texel_flux(PHOTON_LOOKUP_FLUX, nearest)) /
                             (PHOTON_CONE_NORMALISATION * PI * radius * radius)
                       : vec3(0.0);
    return found;
}

#endif
