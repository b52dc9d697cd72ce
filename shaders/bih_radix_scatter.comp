#version 460
// GPU BIH build, radix sort pass C: stable scatter. A key's slot is its
// (digit, group) base from the scanned histogram plus its rank: the number
// of keys before it in its workgroup with the same digit — so equal digits
// keep their input order and the sort stays stable across passes.
//
// The rank is counted in two levels instead of scanning up to 255 earlier
// keys: the workgroup's keys form CHUNKS chunks of CHUNK_SIZE; a shared
// table counts each digit per chunk (atomic adds: counts do not depend on
// their order), and a key's rank is the counts of its digit in the earlier
// chunks plus the same digit among the earlier keys of its own chunk. Every
// loop is at most 16 iterations (llvmpipe runs a loop until its slowest SIMD
// lane is done), and both barriers are reached by every invocation.

layout(local_size_x = 256) in;

layout(push_constant) uniform Push {
    uint count;
    uint shift;
    uint group_count;
} push;

layout(std430, set = 0, binding = 0) readonly buffer KeysIn { uint keys_in[]; };
layout(std430, set = 0, binding = 1) readonly buffer ValuesIn { uint values_in[]; };
layout(std430, set = 0, binding = 2) writeonly buffer KeysOut { uint keys_out[]; };
layout(std430, set = 0, binding = 3) writeonly buffer ValuesOut { uint values_out[]; };
layout(std430, set = 0, binding = 4) readonly buffer Histogram { uint histogram[]; };

const uint GROUP_SIZE = 256u;
const uint DIGITS = 256u;
// √256: balances the chunk-prefix loop against the in-chunk scan.
const uint CHUNK_SIZE = 16u;
const uint CHUNKS = GROUP_SIZE / CHUNK_SIZE;
// 256 marks a slot past the end: it matches no digit.
const uint NO_DIGIT = 256u;
shared uint digits[GROUP_SIZE];
shared uint chunk_counts[CHUNKS * DIGITS]; // [chunk * DIGITS + digit], 16 KiB

void main()
{
    uint lid = gl_LocalInvocationID.x;
    uint i = gl_GlobalInvocationID.x;
    bool in_range = i < push.count;
    uint key = in_range ? keys_in[i] : 0u;
    uint digit = (key >> push.shift) & 255u;
    digits[lid] = in_range ? digit : NO_DIGIT;
    for (uint c = 0u; c < CHUNKS; c++)
        chunk_counts[c * DIGITS + lid] = 0u;
    barrier();
    uint chunk = lid / CHUNK_SIZE;
    if (in_range)
        atomicAdd(chunk_counts[chunk * DIGITS + digit], 1u);
    uint rank = 0u;
    for (uint j = chunk * CHUNK_SIZE; j < lid; j++)
        rank += digits[j] == digit ? 1u : 0u;
    barrier();
    if (!in_range)
        return;
    for (uint c = 0u; c < chunk; c++)
        rank += chunk_counts[c * DIGITS + digit];
    uint slot = histogram[digit * push.group_count + gl_WorkGroupID.x] + rank;
    keys_out[slot] = key;
    values_out[slot] = values_in[i];
}
