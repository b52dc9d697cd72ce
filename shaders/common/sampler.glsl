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

// Sobol direction numbers, 32 per dimension: dimension 0 is van der Corput,
// dimensions 1..3 are Joe & Kuo (2008) new-joe-kuo-6.21201 dimensions 2..4
// (s, a, m: (1, 0, {1}), (2, 1, {1, 3}), (3, 1, {1, 3, 1})).
const uint SOBOL_DIRECTIONS[128] = uint[128](
    // dimension 0
    0x80000000u, 0x40000000u, 0x20000000u, 0x10000000u,
    0x08000000u, 0x04000000u, 0x02000000u, 0x01000000u,
    0x00800000u, 0x00400000u, 0x00200000u, 0x00100000u,
    0x00080000u, 0x00040000u, 0x00020000u, 0x00010000u,
    0x00008000u, 0x00004000u, 0x00002000u, 0x00001000u,
    0x00000800u, 0x00000400u, 0x00000200u, 0x00000100u,
    0x00000080u, 0x00000040u, 0x00000020u, 0x00000010u,
    0x00000008u, 0x00000004u, 0x00000002u, 0x00000001u,
    // dimension 1
    0x80000000u, 0xc0000000u, 0xa0000000u, 0xf0000000u,
    0x88000000u, 0xcc000000u, 0xaa000000u, 0xff000000u,
    0x80800000u, 0xc0c00000u, 0xa0a00000u, 0xf0f00000u,
    0x88880000u, 0xcccc0000u, 0xaaaa0000u, 0xffff0000u,
    0x80008000u, 0xc000c000u, 0xa000a000u, 0xf000f000u,
    0x88008800u, 0xcc00cc00u, 0xaa00aa00u, 0xff00ff00u,
    0x80808080u, 0xc0c0c0c0u, 0xa0a0a0a0u, 0xf0f0f0f0u,
    0x88888888u, 0xccccccccu, 0xaaaaaaaau, 0xffffffffu,
    // dimension 2
    0x80000000u, 0xc0000000u, 0x60000000u, 0x90000000u,
    0xe8000000u, 0x5c000000u, 0x8e000000u, 0xc5000000u,
    0x68800000u, 0x9cc00000u, 0xee600000u, 0x55900000u,
    0x80680000u, 0xc09c0000u, 0x60ee0000u, 0x90550000u,
    0xe8808000u, 0x5cc0c000u, 0x8e606000u, 0xc5909000u,
    0x6868e800u, 0x9c9c5c00u, 0xeeee8e00u, 0x5555c500u,
    0x8000e880u, 0xc0005cc0u, 0x60008e60u, 0x9000c590u,
    0xe8006868u, 0x5c009c9cu, 0x8e00eeeeu, 0xc5005555u,
    // dimension 3
    0x80000000u, 0xc0000000u, 0x20000000u, 0x50000000u,
    0xf8000000u, 0x74000000u, 0xa2000000u, 0x93000000u,
    0xd8800000u, 0x25400000u, 0x59e00000u, 0xe6d00000u,
    0x78080000u, 0xb40c0000u, 0x82020000u, 0xc3050000u,
    0x208f8000u, 0x51474000u, 0xfbea2000u, 0x75d93000u,
    0xa0858800u, 0x914e5400u, 0xdbe79e00u, 0x25db6d00u,
    0x58800080u, 0xe54000c0u, 0x79e00020u, 0xb6d00050u,
    0x800800f8u, 0xc00c0074u, 0x200200a2u, 0x50050093u
);

const uint SOBOL_BITS = 32u;
// 2^-24: floats built from the top 24 bits are exact and stay below 1.
const float SAMPLER_UNIT = 1.0 / 16777216.0;

// The four coordinates of Sobol point index (one pass over its bits;
// dimension 0, van der Corput, is the bit reversal of the index).
// Branch-free over all 32 bits: a fixed trip count, which the compiler can
// unroll so that the direction numbers become constants. The earlier loop
// (stop at the index's highest set bit, XOR only where a bit is set) read
// the table with a per-lane index on llvmpipe and ran ~31 divergent
// iterations for the Owen-scrambled indices it is given; it cost `final`'s
// and `fast`'s shade about half their time (bench/RESULTS.md, "The sampler").
uvec4 sobol_4d(uint index)
{
    uvec3 value = uvec3(0u);
    for (uint bit = 0u; bit < SOBOL_BITS; bit++) {
        uint mask = 0u - ((index >> bit) & 1u);
        value ^= uvec3(SOBOL_DIRECTIONS[SOBOL_BITS + bit], SOBOL_DIRECTIONS[2u * SOBOL_BITS + bit],
                       SOBOL_DIRECTIONS[3u * SOBOL_BITS + bit]) & mask;
    }
    return uvec4(bitfieldReverse(index), value);
}

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

uint sampler_owen_scramble(uint x, uint seed)
{
    return bitfieldReverse(sampler_laine_karras(bitfieldReverse(x), seed));
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

// The next four dimensions of this sample, each in [0, 1).
vec4 sampler_next_4d(inout Sampler state)
{
    uint group_seed = pcg_hash(sampler_hash_combine(state.pixel_seed, state.group));
    state.group++;
    uvec4 point = sobol_4d(sampler_owen_scramble(state.sample_index, group_seed));
    vec4 result;
    for (uint dimension = 0u; dimension < 4u; dimension++) {
        uint value = sampler_owen_scramble(point[dimension],
                                           pcg_hash(sampler_hash_combine(group_seed, dimension)));
        result[dimension] = float(value >> 8u) * SAMPLER_UNIT;
    }
    return result;
}

#endif
