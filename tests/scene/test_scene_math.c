/* Animation primitives and the camera image plane against hand-computed values. */
#include "pf_scene.h"
#include "pf_test.h"

#include <math.h>

#define PI_F 3.14159265358979f

/* Quaternion (x, y, z, w) for angle radians about the unit axis. */
static void axis_angle(float x, float y, float z, float angle, float q[4])
{
    float s = sinf(angle / 2);
    q[0] = x * s;
    q[1] = y * s;
    q[2] = z * s;
    q[3] = cosf(angle / 2);
}

PF_TEST(slerp_halfway_about_y)
{
    float a[4], b[4], expected[4], out[4];
    axis_angle(0, 1, 0, 0, a);
    axis_angle(0, 1, 0, PI_F / 2, b);
    axis_angle(0, 1, 0, PI_F / 4, expected);
    pf_quat_slerp(a, b, 0.5f, out);
    for (int k = 0; k < 4; k++)
        PF_CHECK_NEAR(out[k], expected[k], 1e-6);
    /* t = 0.25 of a 90° turn is 22.5°: slerp has constant angular speed. */
    axis_angle(0, 1, 0, PI_F / 8, expected);
    pf_quat_slerp(a, b, 0.25f, out);
    for (int k = 0; k < 4; k++)
        PF_CHECK_NEAR(out[k], expected[k], 1e-6);
    pf_quat_slerp(a, b, 1.0f, out);
    for (int k = 0; k < 4; k++)
        PF_CHECK_NEAR(out[k], b[k], 1e-6);
}

PF_TEST(slerp_takes_shortest_path)
{
    /* b is the 90° rotation written as -q (dot with a is negative): the result
     * must still be the 45° rotation, not a 315° detour through 180°. */
    float a[4], b[4], expected[4], out[4];
    axis_angle(0, 1, 0, 0, a);
    axis_angle(0, 1, 0, PI_F / 2, b);
    for (int k = 0; k < 4; k++)
        b[k] = -b[k];
    axis_angle(0, 1, 0, PI_F / 4, expected);
    pf_quat_slerp(a, b, 0.5f, out);
    float dot = 0;
    for (int k = 0; k < 4; k++)
        dot += out[k] * expected[k];
    PF_CHECK_NEAR(fabsf(dot), 1.0, 1e-6);
    /* From a 170° turn to a -170° one (20° apart the short way) about X. */
    axis_angle(1, 0, 0, 170 * PI_F / 180, a);
    axis_angle(1, 0, 0, -170 * PI_F / 180, b);
    pf_quat_slerp(a, b, 0.5f, out);
    axis_angle(1, 0, 0, PI_F, expected);
    dot = 0;
    for (int k = 0; k < 4; k++)
        dot += out[k] * expected[k];
    PF_CHECK_NEAR(fabsf(dot), 1.0, 1e-5);
}

PF_TEST(slerp_nearly_equal_is_stable)
{
    float a[4], b[4], out[4];
    axis_angle(0, 0, 1, 0.3f, a);
    axis_angle(0, 0, 1, 0.3f + 1e-6f, b);
    pf_quat_slerp(a, b, 0.5f, out);
    for (int k = 0; k < 4; k++) {
        PF_CHECK(isfinite(out[k]));
        PF_CHECK_NEAR(out[k], a[k], 1e-5);
    }
}

PF_TEST(cubic_hermite_hand_evaluated)
{
    /* v0 = 1, out-tangent 2, v1 = 3, in-tangent -1, dt = 2, s = 0.25:
     * h00 = 0.84375, h10 = 0.140625, h01 = 0.15625, h11 = -0.046875
     * p = 0.84375·1 + 0.140625·2·2 + 0.15625·3 + (-0.046875)·2·(-1) = 1.96875 */
    PF_CHECK_NEAR(pf_cubic_hermite(1, 2, 3, -1, 2, 0.25f), 1.96875, 1e-6);
    PF_CHECK_NEAR(pf_cubic_hermite(1, 2, 3, -1, 2, 0.0f), 1.0, 1e-7);
    PF_CHECK_NEAR(pf_cubic_hermite(1, 2, 3, -1, 2, 1.0f), 3.0, 1e-6);
    /* Tangents scale with dt: the same curve over dt = 1 differs at s = 0.25:
     * 0.84375 + 0.140625·2 + 0.46875 + 0.046875 = 1.640625 */
    PF_CHECK_NEAR(pf_cubic_hermite(1, 2, 3, -1, 1, 0.25f), 1.640625, 1e-6);
    /* Zero tangents: smoothstep between the values. s = 0.5 → midpoint. */
    PF_CHECK_NEAR(pf_cubic_hermite(0, 0, 10, 0, 5, 0.5f), 5.0, 1e-6);
}

PF_TEST(image_plane_uses_image_aspect)
{
    pf_camera camera = {.yfov = 0.6f, .aspect = 1.0f, .znear = 0.1f};
    float tan_x, tan_y;
    pf_camera_image_plane(&camera, 1920, 1080, &tan_x, &tan_y);
    PF_CHECK_NEAR(tan_y, tan(0.3), 1e-6);
    PF_CHECK_NEAR(tan_x, tan(0.3) * 16.0 / 9.0, 1e-6);
    pf_camera_image_plane(&camera, 512, 512, &tan_x, &tan_y);
    PF_CHECK_NEAR(tan_x, tan(0.3), 1e-6);
    PF_CHECK_NEAR(tan_y, tan(0.3), 1e-6);
    /* Portrait: yfov still vertical. */
    pf_camera_image_plane(&camera, 300, 600, &tan_x, &tan_y);
    PF_CHECK_NEAR(tan_y, tan(0.3), 1e-6);
    PF_CHECK_NEAR(tan_x, tan(0.3) * 0.5, 1e-6);
}

int main(void)
{
    PF_RUN(slerp_halfway_about_y);
    PF_RUN(slerp_takes_shortest_path);
    PF_RUN(slerp_nearly_equal_is_stable);
    PF_RUN(cubic_hermite_hand_evaluated);
    PF_RUN(image_plane_uses_image_aspect);
    return pf_test_finish();
}
