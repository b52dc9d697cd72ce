#version 460
// The split film becomes the image (issue 43): each pixel's sums over its
// samples (split_film.c's layout: direct RGB + coverage, indirect RGB + kept
// samples, caustic RGB; the AOV film's albedo RGB + depth, normal XYZ + its
// own sample count) divided into means and written as the image's interleaved
// channels (R G B A, direct, indirect, caustic, then albedo, normal, depth;
// the channels of later stages' layers after them are zeroed).
// The host reads the image back as it lies, instead of dividing 80 bytes a
// pixel on one core (110 ms at 1920x1080 on this VM); the arithmetic is the
// host loop's it replaced, operation for operation.
layout(local_size_x = 64, local_size_y = 1) in;

layout(push_constant) uniform Push {
    uint width;
    uint height;        // the band's rows
    uint aovs;          // 1: albedo, normal and depth follow (20 channels, else 13)
    uint aov_own_count; // 1: the AOV means divide by the AOV film's own count
    uint row_first;     // the band's first row of the image (the film is the image's)
    uint channels;      // the image's: 13 or 20, and the layers later stages fill (zero here)
} push;

layout(std430, binding = 0) readonly buffer Film { vec4 film[]; };
layout(std430, binding = 1) readonly buffer FilmAov { vec4 film_aov[]; };
layout(std430, binding = 2) writeonly buffer Image { float pixels[]; }; // the band's rows

void main()
{
    uint x = gl_GlobalInvocationID.x, y = gl_GlobalInvocationID.y;
    if (x >= push.width || y >= push.height)
        return;
    uint p = (push.row_first + y) * push.width + x;
    vec4 direct_sum = film[3u * p], indirect_sum = film[3u * p + 1u],
         caustic_sum = film[3u * p + 2u];
    float kept = indirect_sum.w;
    float inverse = kept > 0.0 ? 1.0 / kept : 0.0;
    uint o = (y * push.width + x) * push.channels;
    for (uint c = push.aovs != 0u ? 20u : 13u; c < push.channels; c++)
        pixels[o + c] = 0.0;
    for (uint c = 0u; c < 3u; c++) {
        // precise: no fused multiply-add, so the sum rounds as the host's did.
        precise float direct = direct_sum[c] * inverse;
        precise float indirect = indirect_sum[c] * inverse;
        precise float beauty = direct + indirect;
        pixels[o + c] = beauty;
        pixels[o + 4u + c] = direct;
        pixels[o + 7u + c] = indirect;
        pixels[o + 10u + c] = caustic_sum[c] * inverse;
    }
    pixels[o + 3u] = direct_sum.w * inverse;
    if (push.aovs == 0u)
        return;
    vec4 albedo_depth = film_aov[2u * p], normal_count = film_aov[2u * p + 1u];
    float aov_inverse = push.aov_own_count == 0u ? inverse
                        : normal_count.w > 0.0   ? 1.0 / normal_count.w
                                                 : 0.0;
    for (uint c = 0u; c < 3u; c++) {
        pixels[o + 13u + c] = albedo_depth[c] * aov_inverse;
        pixels[o + 16u + c] = normal_count[c] * aov_inverse;
    }
    pixels[o + 19u] = albedo_depth.w * aov_inverse;
}
