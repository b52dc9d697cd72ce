/*
 * The photon record's packing on the CPU: the reference for
 * shaders/common/photon_types.glsl, which must produce the same bits.
 */
#include "pf_photon.h"

#include <math.h>
#include <string.h>

/* EXT_texture_shared_exponent: 9 mantissa bits, exponent bias 15, 5 exponent bits. */
#define RGB9E5_MANTISSA_BITS 9
#define RGB9E5_EXPONENT_BIAS 15
#define RGB9E5_MAX_EXPONENT 31

static float clamp_channel(float value)
{
    if (!(value > 0.0f))
        return 0.0f; /* negative, zero and NaN */
    return value < PF_RGB9E5_MAX ? value : PF_RGB9E5_MAX;
}

uint32_t pf_rgb9e5_pack(const float rgb[3])
{
    float c[3] = {clamp_channel(rgb[0]), clamp_channel(rgb[1]), clamp_channel(rgb[2])};
    float largest = fmaxf(c[0], fmaxf(c[1], c[2]));
    if (largest == 0.0f)
        return 0;
    /* floor(log2(largest)) exactly, from the float's exponent field. */
    int exponent;
    frexpf(largest, &exponent);
    int shared = exponent - 1;
    if (shared < -RGB9E5_EXPONENT_BIAS - 1)
        shared = -RGB9E5_EXPONENT_BIAS - 1;
    shared += 1 + RGB9E5_EXPONENT_BIAS;
    float scale = ldexpf(1.0f, RGB9E5_EXPONENT_BIAS + RGB9E5_MANTISSA_BITS - shared);
    if (floorf(largest * scale + 0.5f) == (float)(1 << RGB9E5_MANTISSA_BITS)) {
        shared += 1; /* rounding carried into the next power of two */
        scale *= 0.5f;
    }
    uint32_t packed = (uint32_t)shared << 27;
    for (int i = 0; i < 3; i++) {
        uint32_t mantissa = (uint32_t)floorf(c[i] * scale + 0.5f);
        packed |= mantissa << (RGB9E5_MANTISSA_BITS * i);
    }
    return packed;
}

void pf_rgb9e5_unpack(uint32_t packed, float rgb[3])
{
    int shared = (int)(packed >> 27);
    float scale = ldexpf(1.0f, shared - RGB9E5_EXPONENT_BIAS - RGB9E5_MANTISSA_BITS);
    for (int i = 0; i < 3; i++)
        rgb[i] = (float)((packed >> (RGB9E5_MANTISSA_BITS * i)) & 511u) * scale;
}

/*
 * [-1, 1] -> 1..255 as 128 + round(127 v): -1, 0 and 1 are exact, so the
 * axis-aligned normals of walls and floors pack without error.
 */
#define OCTAHEDRAL_ZERO 128
#define OCTAHEDRAL_STEPS 127.0f

static uint32_t quantize_unit(float value)
{
    float clamped = fminf(fmaxf(value, -1.0f), 1.0f);
    return (uint32_t)((int)floorf(clamped * OCTAHEDRAL_STEPS + 0.5f) + OCTAHEDRAL_ZERO);
}

static float dequantize_unit(uint32_t level)
{
    return (float)((int)level - OCTAHEDRAL_ZERO) / OCTAHEDRAL_STEPS;
}

static float sign_not_zero(float value)
{
    return value >= 0.0f ? 1.0f : -1.0f;
}

uint16_t pf_octahedral_pack8(const float direction[3])
{
    float l1 = fabsf(direction[0]) + fabsf(direction[1]) + fabsf(direction[2]);
    if (!(l1 > 0.0f))
        return (uint16_t)(quantize_unit(0.0f) | quantize_unit(0.0f) << 8); /* +z */
    float x = direction[0] / l1, y = direction[1] / l1;
    if (direction[2] < 0.0f) {
        float folded_x = (1.0f - fabsf(y)) * sign_not_zero(x);
        float folded_y = (1.0f - fabsf(x)) * sign_not_zero(y);
        x = folded_x;
        y = folded_y;
    }
    return (uint16_t)(quantize_unit(x) | quantize_unit(y) << 8);
}

void pf_octahedral_unpack8(uint16_t packed, float direction[3])
{
    float x = dequantize_unit(packed & 255u);
    float y = dequantize_unit(packed >> 8);
    float z = 1.0f - fabsf(x) - fabsf(y);
    if (z < 0.0f) {
        float unfolded_x = (1.0f - fabsf(y)) * sign_not_zero(x);
        float unfolded_y = (1.0f - fabsf(x)) * sign_not_zero(y);
        x = unfolded_x;
        y = unfolded_y;
    }
    float length = sqrtf(x * x + y * y + z * z);
    direction[0] = x / length;
    direction[1] = y / length;
    direction[2] = z / length;
}

void pf_photon_pack(const float position[3], const float flux[3], const float incoming[3],
                    const float normal[3], pf_photon *out)
{
    memcpy(out->position, position, sizeof out->position);
    out->flux = pf_rgb9e5_pack(flux);
    out->directions = (uint32_t)pf_octahedral_pack8(incoming) |
                      (uint32_t)pf_octahedral_pack8(normal) << 16;
}

void pf_photon_unpack(const pf_photon *photon, float position[3], float flux[3],
                      float incoming[3], float normal[3])
{
    memcpy(position, photon->position, sizeof photon->position);
    pf_rgb9e5_unpack(photon->flux, flux);
    pf_octahedral_unpack8((uint16_t)(photon->directions & 0xFFFFu), incoming);
    pf_octahedral_unpack8((uint16_t)(photon->directions >> 16), normal);
}
