// The 20-byte photon record (C mirror pf_photon in core/photon/pf_photon.h,
// which documents the fields; core/photon/photon_pack.c is the CPU
// reference of these functions). Buffers hold photons as uint words,
// PHOTON_WORDS per photon: a struct with a vec3 would get a 32-byte stride.
#ifndef PF_PHOTON_TYPES_GLSL
#define PF_PHOTON_TYPES_GLSL

const uint PHOTON_WORDS = 5u;

struct Photon {
    vec3 position;
    vec3 flux;      // in units of the map's flux scale
    vec3 incoming;  // direction the photon travelled
    vec3 normal;    // normal of the surface it was stored on
};

vec3 rgb9e5_unpack(uint packed)
{
    float scale = exp2(float(int(packed >> 27u)) - 24.0); // 2^(exponent - bias 15 - 9 mantissa bits)
    return vec3(float(packed & 511u), float((packed >> 9u) & 511u), float((packed >> 18u) & 511u)) *
           scale;
}

// EXT_texture_shared_exponent encoding, rounding to nearest (as pf_rgb9e5_pack).
uint rgb9e5_pack(vec3 rgb)
{
    const float max_value = 65408.0; // PF_RGB9E5_MAX
    vec3 c = vec3(rgb.r > 0.0 ? min(rgb.r, max_value) : 0.0, rgb.g > 0.0 ? min(rgb.g, max_value) : 0.0,
                  rgb.b > 0.0 ? min(rgb.b, max_value) : 0.0);
    float largest = max(c.r, max(c.g, c.b));
    if (largest == 0.0)
        return 0u;
    // floor(log2(largest)) from the exponent field (denormals give -127 and
    // are clamped with everything below 2^-16), then + bias 15 + 1.
    int floor_log2 = int((floatBitsToUint(largest) >> 23u) & 255u) - 127;
    int shared_exponent = max(floor_log2, -16) + 16;
    float scale = exp2(float(24 - shared_exponent));
    if (floor(largest * scale + 0.5) == 512.0) {
        shared_exponent += 1;
        scale *= 0.5;
    }
    uvec3 mantissa = uvec3(floor(c * scale + 0.5));
    return (uint(shared_exponent) << 27u) | mantissa.r | (mantissa.g << 9u) | (mantissa.b << 18u);
}

vec2 octahedral_sign_not_zero(vec2 v)
{
    return vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0);
}

// 8 bits per coordinate, 128 + round(127 v) (pf_octahedral_pack8: -1, 0, 1
// exact); a zero vector packs as +z.
uint octahedral_pack8(vec3 direction)
{
    float l1 = abs(direction.x) + abs(direction.y) + abs(direction.z);
    vec2 p = l1 > 0.0 ? direction.xy / l1 : vec2(0.0);
    if (l1 > 0.0 && direction.z < 0.0)
        p = (1.0 - abs(p.yx)) * octahedral_sign_not_zero(p);
    uvec2 q = uvec2(ivec2(floor(clamp(p, -1.0, 1.0) * 127.0 + 0.5)) + 128);
    return q.x | (q.y << 8u);
}

vec3 octahedral_unpack8(uint packed)
{
    vec2 p = (vec2(float(packed & 255u), float((packed >> 8u) & 255u)) - 128.0) / 127.0;
    float z = 1.0 - abs(p.x) - abs(p.y);
    if (z < 0.0)
        p = (1.0 - abs(p.yx)) * octahedral_sign_not_zero(p);
    return normalize(vec3(p, z));
}

// A record whose incoming direction (the low half of its directions word)
// is 0, which octahedral_pack8 never gives, holds no photon: the grid build
// keeps it out of every cell (photon_irradiance_precompute.comp writes one
// for each photon that is not an irradiance point).
const uint PHOTON_NO_RECORD = 0u;

bool photon_record_present(uint directions)
{
    return (directions & 0xFFFFu) != PHOTON_NO_RECORD;
}

// words[0..4] of one photon -> its fields.
Photon photon_unpack(uint w0, uint w1, uint w2, uint w3, uint w4)
{
    Photon photon;
    photon.position = vec3(uintBitsToFloat(w0), uintBitsToFloat(w1), uintBitsToFloat(w2));
    photon.flux = rgb9e5_unpack(w3);
    photon.incoming = octahedral_unpack8(w4 & 0xFFFFu);
    photon.normal = octahedral_unpack8(w4 >> 16u);
    return photon;
}

#endif
