#version 460
// bench/vk/store_bench: one 160-byte record an invocation (a wavefront path's
// state), stored as 10 vec4, as 5 u64vec4 of the same bytes, or not at all
// (one word), so the store paths of a device can be timed against each
// other (llvmpipe 22.x stores lane by lane and component by component).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

layout(local_size_x = 64) in;
// 0: 10 vec4, 1: 5 u64vec4, 2: one word.
layout(constant_id = 0) const uint STORE_PATH = 0u;

layout(std430, set = 0, binding = 0) writeonly buffer Records { vec4 records[]; };
layout(std430, set = 0, binding = 0) writeonly buffer Records64 { u64vec4 records64[]; };
layout(std430, set = 0, binding = 0) writeonly buffer Words { uint words[]; };

layout(push_constant) uniform Push {
    uint records;
} push;

u64vec2 words_of(vec4 v)
{
    return u64vec2(packUint2x32(floatBitsToUint(v.xy)), packUint2x32(floatBitsToUint(v.zw)));
}

void main()
{
    uint r = gl_GlobalInvocationID.x % push.records;
    vec4 v[10];
    for (uint k = 0u; k < 10u; k++)
        v[k] = vec4(float(r), float(k), float(r + k), float(r * k));
    if (STORE_PATH == 0u) {
        for (uint k = 0u; k < 10u; k++)
            records[10u * r + k] = v[k];
    } else if (STORE_PATH == 1u) {
        for (uint k = 0u; k < 5u; k++)
            records64[5u * r + k] = u64vec4(words_of(v[2u * k]), words_of(v[2u * k + 1u]));
    } else {
        words[40u * r] = floatBitsToUint(v[0].x + v[9].w);
    }
}
