/*
 * Quaternions, interpolation and the 4×4 transforms that the node hierarchy
 * needs. Matrices are column-major (m[column * 4 + row]) as glTF stores them.
 */
#include "scene_internal.h"

#include <math.h>
#include <string.h>

/* Above this |cos| the two rotations are so close that slerp's sin(θ) divisor
 * loses precision; normalised lerp is then indistinguishable from slerp. */
#define SLERP_NLERP_THRESHOLD 0.9995f

void scene_mat4_identity(float m[16])
{
    memset(m, 0, 16 * sizeof *m);
    m[0] = m[5] = m[10] = m[15] = 1.0f;
}

void scene_mat4_from_trs(const float t[3], const float r[4], const float s[3], float m[16])
{
    float x = r[0], y = r[1], z = r[2], w = r[3];
    float rot[9] = {
        1 - 2 * (y * y + z * z), 2 * (x * y + z * w),     2 * (x * z - y * w),
        2 * (x * y - z * w),     1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
        2 * (x * z + y * w),     2 * (y * z - x * w),     1 - 2 * (x * x + y * y),
    };
    for (int column = 0; column < 3; column++)
        for (int row = 0; row < 3; row++)
            m[column * 4 + row] = rot[column * 3 + row] * s[column];
    m[3] = m[7] = m[11] = 0.0f;
    m[12] = t[0];
    m[13] = t[1];
    m[14] = t[2];
    m[15] = 1.0f;
}

void scene_mat4_mul(const float a[16], const float b[16], float out[16])
{
    float result[16];
    for (int column = 0; column < 4; column++)
        for (int row = 0; row < 4; row++) {
            float sum = 0.0f;
            for (int k = 0; k < 4; k++)
                sum += a[k * 4 + row] * b[column * 4 + k];
            result[column * 4 + row] = sum;
        }
    memcpy(out, result, sizeof result);
}

void scene_mat4_point(const float m[16], const float p[3], float out[3])
{
    float result[3];
    for (int row = 0; row < 3; row++)
        result[row] = m[row] * p[0] + m[4 + row] * p[1] + m[8 + row] * p[2] + m[12 + row];
    memcpy(out, result, sizeof result);
}

void scene_mat4_vector(const float m[16], const float v[3], float out[3])
{
    float result[3];
    for (int row = 0; row < 3; row++)
        result[row] = m[row] * v[0] + m[4 + row] * v[1] + m[8 + row] * v[2];
    memcpy(out, result, sizeof result);
}

float scene_mat4_normal_matrix(const float m[16], float out[9])
{
    /* Cofactor matrix of the upper 3×3: equals det · inverse-transpose, so it maps
     * normals correctly even for singular (zero-scale) transforms, where the
     * inverse does not exist. Normals are renormalised after. Layout: M(r, c) =
     * m[c * 4 + r]. */
    float a = m[0], b = m[4], c = m[8];
    float d = m[1], e = m[5], f = m[9];
    float g = m[2], h = m[6], i = m[10];
    float cof[9] = {
        e * i - f * h, -(d * i - f * g), d * h - e * g,
        -(b * i - c * h), a * i - c * g, -(a * h - b * g),
        b * f - c * e, -(a * f - c * d), a * e - b * d,
    };
    float det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
    /* cofactor = det · inverse-transpose: a mirroring transform (det < 0) would
     * flip the normals, so the sign of det is divided back out. */
    float sign = det < 0.0f ? -1.0f : 1.0f;
    for (int column = 0; column < 3; column++)
        for (int row = 0; row < 3; row++)
            out[column * 3 + row] = sign * cof[row * 3 + column];
    return det;
}

void scene_mat3_vector(const float m[9], const float v[3], float out[3])
{
    float result[3];
    for (int row = 0; row < 3; row++)
        result[row] = m[row] * v[0] + m[3 + row] * v[1] + m[6 + row] * v[2];
    memcpy(out, result, sizeof result);
}

void scene_quat_normalize(float q[4])
{
    float length = sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (length > 0.0f && isfinite(length)) {
        for (int k = 0; k < 4; k++)
            q[k] /= length;
    } else {
        q[0] = q[1] = q[2] = 0.0f;
        q[3] = 1.0f;
    }
}

float scene_vec3_normalize(float v[3])
{
    float length = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (length > 0.0f && isfinite(length)) {
        v[0] /= length;
        v[1] /= length;
        v[2] /= length;
    }
    return length;
}

void scene_cross(const float a[3], const float b[3], float out[3])
{
    float result[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                       a[0] * b[1] - a[1] * b[0]};
    memcpy(out, result, sizeof result);
}

void pf_quat_slerp(const float a[4], const float b[4], float t, float out[4])
{
    float other[4] = {b[0], b[1], b[2], b[3]};
    float cos_theta = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    /* q and -q are the same rotation: take the shorter arc (glTF §3.11.2). */
    if (cos_theta < 0.0f) {
        cos_theta = -cos_theta;
        for (int k = 0; k < 4; k++)
            other[k] = -other[k];
    }
    float weight_a, weight_b;
    if (cos_theta > SLERP_NLERP_THRESHOLD) {
        weight_a = 1.0f - t;
        weight_b = t;
    } else {
        float theta = acosf(cos_theta);
        float sin_theta = sinf(theta);
        weight_a = sinf((1.0f - t) * theta) / sin_theta;
        weight_b = sinf(t * theta) / sin_theta;
    }
    for (int k = 0; k < 4; k++)
        out[k] = weight_a * a[k] + weight_b * other[k];
    scene_quat_normalize(out);
}

float pf_cubic_hermite(float v0, float out_tangent0, float v1, float in_tangent1, float dt,
                       float t)
{
    /* glTF 2.0 Appendix C "Cubic Spline Interpolation": tangents are per second,
     * so they are scaled by the keyframe interval dt. */
    float t2 = t * t, t3 = t2 * t;
    float h00 = 2 * t3 - 3 * t2 + 1;
    float h10 = t3 - 2 * t2 + t;
    float h01 = -2 * t3 + 3 * t2;
    float h11 = t3 - t2;
    return h00 * v0 + h10 * dt * out_tangent0 + h01 * v1 + h11 * dt * in_tangent1;
}

/* Index k of the last key with times[k] <= time (0 if time is before all). */
static uint32_t find_key(const float *times, uint32_t key_count, double time)
{
    uint32_t low = 0, high = key_count - 1;
    while (low < high) {
        uint32_t middle = low + (high - low + 1) / 2;
        if ((double)times[middle] <= time)
            low = middle;
        else
            high = middle - 1;
    }
    return low;
}

void scene_channel_sample(const scene_channel *channel, double time, float *out)
{
    uint32_t components = channel->components;
    uint32_t stride = channel->interpolation == SCENE_INTERP_CUBICSPLINE ? 3 * components
                                                                         : components;
    /* The value (not a tangent) of key k; CUBICSPLINE stores in, value, out. */
    uint32_t value_offset = channel->interpolation == SCENE_INTERP_CUBICSPLINE ? components : 0;
    const float *times = channel->times;
    uint32_t last = channel->key_count - 1;

    if (time <= (double)times[0] || channel->key_count == 1) {
        memcpy(out, channel->values + value_offset, components * sizeof *out);
        return;
    }
    if (time >= (double)times[last]) {
        memcpy(out, channel->values + (size_t)last * stride + value_offset,
               components * sizeof *out);
        return;
    }
    uint32_t key = find_key(times, channel->key_count, time);
    const float *before = channel->values + (size_t)key * stride;
    const float *after = channel->values + (size_t)(key + 1) * stride;
    float dt = times[key + 1] - times[key];
    float u = dt > 0.0f ? (float)((time - (double)times[key]) / (double)dt) : 1.0f;

    switch (channel->interpolation) {
    case SCENE_INTERP_STEP:
        memcpy(out, before, components * sizeof *out);
        return;
    case SCENE_INTERP_LINEAR:
        if (channel->path == SCENE_PATH_ROTATION) {
            pf_quat_slerp(before, after, u, out);
        } else {
            for (uint32_t k = 0; k < components; k++)
                out[k] = before[k] + (after[k] - before[k]) * u;
        }
        return;
    default:
        for (uint32_t k = 0; k < components; k++)
            out[k] = pf_cubic_hermite(before[components + k], before[2 * components + k],
                                      after[components + k], after[k], dt, u);
        if (channel->path == SCENE_PATH_ROTATION)
            scene_quat_normalize(out);
        return;
    }
}

void scene_triangle_normal(const float a[3], const float b[3], const float c[3], float out[3])
{
    float edge1[3], edge2[3];
    for (int k = 0; k < 3; k++) {
        edge1[k] = b[k] - a[k];
        edge2[k] = c[k] - a[k];
    }
    scene_cross(edge1, edge2, out);
    scene_vec3_normalize(out);
}

void scene_face_normals(const float p[9], float n[9])
{
    float geometric[3];
    scene_triangle_normal(p, p + 3, p + 6, geometric);
    for (int corner = 0; corner < 3; corner++)
        memcpy(n + 3 * corner, geometric, sizeof geometric);
}
