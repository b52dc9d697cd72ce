// Deterministic per-sample random numbers: PCG-RXS-M-XS 32 (O'Neill 2014),
// as the hash recommended by Jarzynski & Olano, "Hash Functions for GPU
// Rendering", JCGT 9(3), 2020. The same seed always gives the same image.
#ifndef PF_RNG_GLSL
#define PF_RNG_GLSL

uint pcg_hash(uint value)
{
    uint state = value * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// State for one pixel sample; the 64-bit seed enters through both halves.
uint rng_init(uint pixel_index, uint sample_index, uint seed_lo, uint seed_hi)
{
    return pcg_hash(pixel_index ^ pcg_hash(sample_index ^ pcg_hash(seed_lo ^ pcg_hash(seed_hi))));
}

// Uniform in [0, 1): the top 24 bits, so the value is exact in a float.
float rng_float(inout uint state)
{
    state = pcg_hash(state);
    return float(state >> 8u) * (1.0 / 16777216.0);
}

#endif
