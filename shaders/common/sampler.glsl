// Low-discrepancy samples for the reference path tracer: shuffled,
// Owen-scrambled 4D Sobol points (Burley 2020, "Practical Hash-based Owen
// Scrambling", JCGT 9(4)). A path draws its random numbers in groups of four
// dimensions; each group is an independent 4D Sobol sequence whose sample
// order is shuffled per (pixel, group) and whose values are Owen-scrambled
// per (pixel, group, dimension), all by hashing, so nothing is stored and the
// same (seed, pixel, sample) always gives the same numbers.
#ifndef PF_SAMPLER_GLSL
#define PF_SAMPLER_GLSL

#include "rng.glsl"
#include "pixel_filter.glsl"

// The 4D Sobol points, kept in the bit-reversed domain where the Owen scramble works
// (below), so neither the shuffled index nor the coordinates are reversed back and forth:
// dimension 0 is van der Corput (the bit reversal of the index: reversed, the index itself);
// dimensions 1..3 are Joe & Kuo (2008) new-joe-kuo-6.21201 dimensions 2..4 (s, a, m:
// (1, 0, {1}), (2, 1, {1, 3}), (3, 1, {1, 3, 1})).
//
// Dimension 1's generator matrix is Pascal's triangle mod 2: reversed, bit j of the point
// is the parity of the index's bits at every k that holds j's bits (binomial(k, j) is odd
// iff j's bits are k's, Lucas), a superset sum over the 5-bit positions in five shifts.
uint sobol_pascal_reversed(uint index)
{
    index ^= (index >> 1u) & 0x55555555u;
    index ^= (index >> 2u) & 0x33333333u;
    index ^= (index >> 4u) & 0x0F0F0F0Fu;
    index ^= (index >> 8u) & 0x00FF00FFu;
    index ^= (index >> 16u) & 0x0000FFFFu;
    return index;
}

// Dimensions 2 and 3, reversed: entry j is bitfieldReverse of the direction number of the
// index's bit 31 - j, so that bit j of the reversed index (reversed_index below) selects it.
const uvec2 SOBOL_REVERSED_23[32] = uvec2[32](
    uvec2(0xaaaa00a3u, 0xc900a00au), uvec2(0x77770071u, 0x45004004u),
    uvec2(0x3939003au, 0x2e003003u), uvec2(0x16160017u, 0x1f001001u),
    uvec2(0x09a30009u, 0x0a000b6du), uvec2(0x06710006u, 0x0400079eu),
    uvec2(0x033a0003u, 0x030002a7u), uvec2(0x01170001u, 0x0100011au),
    uvec2(0x00a3aaaau, 0x00b6dba4u), uvec2(0x00717777u, 0x0079e7dbu),
    uvec2(0x003a3939u, 0x002a7289u), uvec2(0x00171616u, 0x0011a105u),
    uvec2(0x000909a3u, 0x000c9baeu), uvec2(0x00060671u, 0x000457dfu),
    uvec2(0x0003033au, 0x0002e28au), uvec2(0x00010117u, 0x0001f104u),
    uvec2(0x0000aa09u, 0x0000a0c3u), uvec2(0x00007706u, 0x00004041u),
    uvec2(0x00003903u, 0x0000302du), uvec2(0x00001601u, 0x0000101eu),
    uvec2(0x000009aau, 0x00000b67u), uvec2(0x00000677u, 0x0000079au),
    uvec2(0x00000339u, 0x000002a4u), uvec2(0x00000116u, 0x0000011bu),
    uvec2(0x000000a3u, 0x000000c9u), uvec2(0x00000071u, 0x00000045u),
    uvec2(0x0000003au, 0x0000002eu), uvec2(0x00000017u, 0x0000001fu),
    uvec2(0x00000009u, 0x0000000au), uvec2(0x00000006u, 0x00000004u),
    uvec2(0x00000003u, 0x00000003u), uvec2(0x00000001u, 0x00000001u)
);

// Dimensions 2 and 3 of the point whose index is bitfieldReverse(reversed_index), reversed.
// Branch-free over all 32 bits: a fixed trip count, which the compiler unrolls so that the
// direction numbers become constants (a loop that stopped at the highest set bit read the
// table with a per-lane index on llvmpipe: bench/RESULTS.md, "The sampler").
uvec2 sobol_23_reversed(uint reversed_index)
{
    uvec2 value = uvec2(0u);
    for (uint bit = 0u; bit < 32u; bit++)
        value ^= SOBOL_REVERSED_23[bit] & uvec2(0u - ((reversed_index >> bit) & 1u));
    return value;
}

// 2^-24: floats built from the top 24 bits are exact and stay below 1.
const float SAMPLER_UNIT = 1.0 / 16777216.0;

// Laine & Karras (2011) hash-based Owen permutation with Burley's improved
// constants; operates on bit-reversed values (the high bits of the result
// depend only on the high bits of the input: a nested uniform scramble).
uint sampler_laine_karras(uint x, uint seed)
{
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

// Burley's hash_combine (boost style).
uint sampler_hash_combine(uint seed, uint value)
{
    return seed ^ (value + (seed << 6u) + (seed >> 2u));
}

// The per-pixel sampler state: the pixel's seed and the sample index.
struct Sampler {
    uint pixel_seed;
    uint sample_index;
    uint group; // next 4D group to hand out
};

Sampler sampler_init(uint pixel_index, uint sample_index, uint seed_lo, uint seed_hi)
{
    return Sampler(pcg_hash(pixel_index ^ pcg_hash(seed_lo ^ pcg_hash(seed_hi))), sample_index,
                   0u);
}

// The next four dimensions of this sample, each in [0, 1): the Sobol point at the sample's
// Owen-scrambled (shuffled) index, each coordinate Owen-scrambled. Both scrambles are
// reverse(laine_karras(reverse(x))); the point is computed reversed (sobol_*_reversed), so
// only the scrambles' last reversals are made (6 reversals a group instead of 11; the same
// numbers bit for bit).
vec4 sampler_next_4d(inout Sampler state)
{
    uint group_seed = pcg_hash(sampler_hash_combine(state.pixel_seed, state.group));
    state.group++;
    uint reversed_index = sampler_laine_karras(bitfieldReverse(state.sample_index), group_seed);
    uint index = bitfieldReverse(reversed_index);
    uvec4 point = uvec4(index, sobol_pascal_reversed(index), sobol_23_reversed(reversed_index));
    vec4 result;
    for (uint dimension = 0u; dimension < 4u; dimension++) {
        uint value = bitfieldReverse(sampler_laine_karras(
            point[dimension], pcg_hash(sampler_hash_combine(group_seed, dimension))));
        result[dimension] = float(value >> 8u) * SAMPLER_UNIT;
    }
    return result;
}

#endif
