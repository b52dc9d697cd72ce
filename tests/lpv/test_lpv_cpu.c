/*
 * core/lpv on the CPU: SH projection and evaluation of a cosine lobe against
 * analytic values, exact clipped areas, the geometry volume's totals, the
 * cascade layout's snapping, injection's flux, the energy points' spread over the diffuse
 * area, and settings checks.
 */
#include "lpv_test_quad.h"
#include "pf_lpv.h"
#include "pf_test.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

static void normalize3(float v[3])
{
    float length = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int i = 0; i < 3; i++)
        v[i] /= length;
}

/* Direction of the Fibonacci lattice point i of n (near-uniform on the sphere). */
static void fibonacci(int i, int n, float out[3])
{
    double z = 1.0 - (2.0 * i + 1.0) / n;
    double r = sqrt(1.0 - z * z);
    double phi = i * PI * (3.0 - sqrt(5.0));
    out[0] = (float)(r * cos(phi));
    out[1] = (float)(r * sin(phi));
    out[2] = (float)z;
}

PF_TEST(cosine_lobe_projection_matches_numerical_projection)
{
    /* Project max(0, n·ω) onto the basis by quadrature over the sphere. */
    float normal[3] = {0.3f, -0.5f, 0.8f};
    normalize3(normal);
    const int n = 200000;
    double sums[4] = {0, 0, 0, 0};
    for (int i = 0; i < n; i++) {
        float w[3], basis[4];
        fibonacci(i, n, w);
        pf_sh_basis(w, basis);
        double f = fmax(0.0, normal[0] * w[0] + normal[1] * w[1] + normal[2] * w[2]);
        for (int c = 0; c < 4; c++)
            sums[c] += f * basis[c] * 4.0 * PI / n;
    }
    float lobe[4];
    pf_sh_cosine_lobe(normal, lobe);
    for (int c = 0; c < 4; c++)
        PF_CHECK_NEAR(lobe[c], sums[c], 1e-4);
    /* Analytic: c0 = √π / 2, |c1| = √(π/3); ∫ max(0, n·ω) dω = π. */
    PF_CHECK_NEAR(lobe[0], sqrt(PI) / 2.0, 1e-6);
    PF_CHECK_NEAR(sqrt(lobe[1] * lobe[1] + lobe[2] * lobe[2] + lobe[3] * lobe[3]), sqrt(PI / 3.0),
                  1e-6);
    PF_CHECK_NEAR(pf_sh_integral(lobe), PI, 1e-5);
}

PF_TEST(cosine_lobe_evaluates_to_its_analytic_expansion)
{
    /* The 2-band expansion of max(0, cos θ) is 1/4 + cos θ / 2. */
    float normal[3] = {0.0f, 0.0f, 1.0f}, lobe[4];
    pf_sh_cosine_lobe(normal, lobe);
    for (int i = 0; i <= 8; i++) {
        double theta = PI * i / 8.0;
        float w[3] = {(float)sin(theta), 0.0f, (float)cos(theta)};
        PF_CHECK_NEAR(pf_sh_eval(lobe, w), 0.25 + 0.5 * cos(theta), 1e-6);
    }
    /* Irradiance from a lobe: ∫ (1/4 + cos/2)(max(0, cos)) = π/4 + π/3 (dot of coefficients). */
    double dot = 0.0;
    for (int c = 0; c < 4; c++)
        dot += (double)lobe[c] * lobe[c];
    PF_CHECK_NEAR(dot, PI / 4.0 + PI / 3.0, 1e-5);
}

PF_TEST(solid_angles_sum_to_the_sphere)
{
    /* The constants are floats: within their rounding of the closed forms. */
    double front = 4.0 * atan(sqrt(11.0) / 33.0);
    double side = -PI / 3.0 + 2.0 * atan(3.0 * sqrt(11.0) / 11.0);
    PF_CHECK_NEAR(front, PF_LPV_SOLID_ANGLE_FRONT, 3e-8);
    PF_CHECK_NEAR(side, PF_LPV_SOLID_ANGLE_SIDE, 3e-8);
    PF_CHECK_NEAR((6.0 * front + 24.0 * side) / (4.0 * PI), 1.0, 1e-12);
    double sum = 6.0 * PF_LPV_SOLID_ANGLE_FRONT + 24.0 * PF_LPV_SOLID_ANGLE_SIDE;
    PF_CHECK_NEAR(sum / (4.0 * PI), 1.0, 1e-7);
    /* The widely copied typo adds energy: 24 × 1e-5 sr per step. */
    PF_CHECK(6.0 * PF_LPV_SOLID_ANGLE_FRONT + 24.0 * 0.4234413544 > 4.0 * PI * (1.0 + 1e-5));
}

PF_TEST(clipped_area_is_exact)
{
    float a[3] = {-1, -1, 0.25f}, b[3] = {3, -1, 0.25f}, c[3] = {-1, 3, 0.25f};
    float lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    /* The unit square lies wholly inside the triangle (x + y <= 2 there). */
    PF_CHECK_NEAR(pf_lpv_clipped_area(a, b, c, lo, hi), 1.0, 1e-12);
    /* A triangle inside the box keeps its own area. */
    float d[3] = {0.1f, 0.1f, 0.5f}, e[3] = {0.9f, 0.1f, 0.5f}, f[3] = {0.1f, 0.9f, 0.5f};
    PF_CHECK_NEAR(pf_lpv_clipped_area(d, e, f, lo, hi), 0.5 * 0.8 * 0.8, 1e-6);
    /* Cut by x = 0.5: the part x <= 0.5 of that triangle. */
    float half_hi[3] = {0.5f, 1, 1};
    double part = 0.5 * 0.8 * 0.8 - 0.5 * 0.4 * 0.4;
    PF_CHECK_NEAR(pf_lpv_clipped_area(d, e, f, lo, half_hi), part, 1e-6);
    /* Lying in a box's upper face: counted by the box above, not this one. */
    float g[3] = {0.1f, 0.1f, 1.0f}, h[3] = {0.9f, 0.1f, 1.0f}, k[3] = {0.1f, 0.9f, 1.0f};
    float up_lo[3] = {0, 0, 1}, up_hi[3] = {1, 1, 2};
    PF_CHECK_NEAR(pf_lpv_clipped_area(g, h, k, lo, hi), 0.0, 0.0);
    PF_CHECK_NEAR(pf_lpv_clipped_area(g, h, k, up_lo, up_hi), 0.32, 1e-6);
}

static void quad_make(quad_frame *q, const float p0[3], const float p1[3], const float p2[3],
                      const float p3[3])
{
    quad_frame_init(q);
    quad_frame_add(q, p0, p1, p2, p3);
}

PF_TEST(geometry_volume_holds_the_exact_area)
{
    /* A 1.3 × 0.7 m quad facing +z at a slant through many cells. */
    float p0[3] = {0.13f, 0.21f, 0.4f}, p1[3] = {1.43f, 0.21f, 0.4f}, p2[3] = {1.43f, 0.91f, 0.4f},
          p3[3] = {0.13f, 0.91f, 0.4f};
    quad_frame q;
    quad_make(&q, p0, p1, p2, p3);
    pf_lpv_settings settings = {.cascades = 2, .size = 16};
    float focus[3] = {0.8f, 0.5f, 0.5f};
    pf_lpv_layout layout;
    pf_lpv_layout_make(&settings, focus, 0.125f, NULL, &layout);
    uint64_t floats = pf_lpv_volume_floats(&layout, PF_LPV_GV_FLOATS_PER_CELL);
    float *gv = calloc(floats, sizeof *gv);
    PF_REQUIRE(gv);
    uint64_t pieces = pf_lpv_geometry_build(&layout, &q.frame, gv);
    PF_CHECK(pieces > 2);
    uint64_t cells = (uint64_t)layout.size * layout.size * layout.size;
    for (uint32_t k = 0; k < layout.count; k++) {
        double s = layout.cascades[k].cell_size;
        for (int axis = 0; axis < 3; axis++) {
            double c0 = 0.0, cz = 0.0;
            for (uint64_t i = 0; i < cells; i++) {
                c0 += gv[(k * cells + i) * PF_LPV_GV_FLOATS_PER_CELL + 4 * axis];
                cz += gv[(k * cells + i) * PF_LPV_GV_FLOATS_PER_CELL + 4 * axis + 2];
            }
            /* Each axis's face cells tile space: Σ (A/s²)/0.75 × lobe holds the whole area. */
            PF_CHECK_NEAR(c0 * 0.75 * s * s / PF_SH_COSINE0, 1.3 * 0.7, 1e-5);
            PF_CHECK_NEAR(cz * 0.75 * s * s / PF_SH_COSINE1, 1.3 * 0.7, 1e-5);
        }
    }
    /* Tilted to the normal (0, −0.6, 0.8): the lobe's y and z terms split its area 0.6 : 0.8. */
    float t0[3] = {0.13f, 0.21f, 0.4f}, t1[3] = {1.43f, 0.21f, 0.4f}, t2[3] = {1.43f, 0.77f, 0.82f},
          t3[3] = {0.13f, 0.77f, 0.82f};
    quad_make(&q, t0, t1, t2, t3);
    pf_lpv_geometry_build(&layout, &q.frame, gv);
    double s0 = layout.cascades[0].cell_size, cy = 0.0, cz = 0.0;
    for (uint64_t i = 0; i < cells; i++) {
        cy += gv[i * PF_LPV_GV_FLOATS_PER_CELL + 1]; /* −c1 n_y */
        cz += gv[i * PF_LPV_GV_FLOATS_PER_CELL + 2]; /* c1 n_z */
    }
    PF_CHECK_NEAR(cy * 0.75 * s0 * s0 / PF_SH_COSINE1, 1.3 * 0.7 * 0.6, 1e-5);
    PF_CHECK_NEAR(cz * 0.75 * s0 * s0 / PF_SH_COSINE1, 1.3 * 0.7 * 0.8, 1e-5);
    free(gv);
}

PF_TEST(energy_points_spread_over_the_diffuse_area)
{
    /* A 1 × 1 floor (single-sided), a 1 × 3 wall (double-sided) and a 2 × 2 mirror. */
    quad_frame q;
    quad_frame_init(&q);
    float f0[3] = {0, 0, 0}, f1[3] = {1, 0, 0}, f2[3] = {1, 0, -1}, f3[3] = {0, 0, -1};
    float w0[3] = {0, 0, -1}, w1[3] = {3, 0, -1}, w2[3] = {3, 1, -1}, w3[3] = {0, 1, -1};
    float m0[3] = {0, 0, 1}, m1[3] = {0, 2, 1}, m2[3] = {0, 2, 3}, m3[3] = {0, 0, 3};
    quad_frame_add(&q, f0, f1, f2, f3);
    quad_frame_add(&q, w0, w1, w2, w3);
    quad_frame_add(&q, m0, m1, m2, m3);
    pf_material materials[3] = {q.material, q.material, q.material};
    materials[1].flags = PF_MATERIAL_DOUBLE_SIDED;
    materials[2].kind = PF_MATERIAL_MIRROR;
    q.frame.materials = materials;
    q.frame.material_count = 3;
    for (uint32_t t = 0; t < 6; t++)
        q.triangle_material[t] = t / 2;
    enum { COUNT = 1000 };
    float *points = malloc(COUNT * PF_LPV_ENERGY_SAMPLE_FLOATS * sizeof *points);
    PF_REQUIRE(points);
    PF_CHECK_NEAR(pf_lpv_energy_samples(&q.frame, COUNT, points), 4.0, 1e-9);
    int on_floor = 0, on_wall = 0;
    for (int i = 0; i < COUNT; i++) {
        const float *p = points + i * PF_LPV_ENERGY_SAMPLE_FLOATS;
        if (p[1] == 0.0f && p[2] >= -1.0f && p[2] <= 0.0f && p[0] >= 0.0f && p[0] <= 1.0f &&
            p[5] == 1.0f && p[3] == 0.0f)
            on_floor++; /* on the floor, its normal +y, one face */
        else if (p[2] == -1.0f && p[0] >= 0.0f && p[0] <= 3.0f && p[1] >= 0.0f &&
                 p[1] <= 1.0f && p[6] == 1.0f && p[3] == 1.0f)
            on_wall++;  /* on the wall, its normal +z, both faces */
    }
    /* Every point on a diffuse surface, spread by area (1 : 3), none on the mirror. */
    PF_CHECK_MSG(on_floor + on_wall == COUNT, "%d + %d points", on_floor, on_wall);
    PF_CHECK_MSG(abs(on_floor - COUNT / 4) <= 1, "%d on the floor", on_floor);
    /* The same frame, the same points. */
    float *again = malloc(COUNT * PF_LPV_ENERGY_SAMPLE_FLOATS * sizeof *again);
    PF_REQUIRE(again);
    pf_lpv_energy_samples(&q.frame, COUNT, again);
    PF_CHECK(memcmp(points, again, COUNT * PF_LPV_ENERGY_SAMPLE_FLOATS * sizeof *again) == 0);
    /* No diffuse surface: area 0 and zeroed points. */
    materials[0].kind = materials[1].kind = PF_MATERIAL_MIRROR;
    PF_CHECK(pf_lpv_energy_samples(&q.frame, COUNT, points) == 0.0);
    PF_CHECK(points[0] == 0.0f && points[5] == 0.0f);
    free(points);
    free(again);
}

PF_TEST(cascades_snap_to_their_cell_size)
{
    pf_lpv_settings settings = {.cascades = 3, .size = 32};
    float focus[3] = {0.30f, -1.02f, 2.49f};
    pf_lpv_layout a, b, c;
    pf_lpv_layout_make(&settings, focus, 0.0625f, NULL, &a);
    for (uint32_t k = 0; k < a.count; k++) {
        float s = a.cascades[k].cell_size;
        PF_CHECK_NEAR(s, 0.0625f * (1 << k), 0.0);
        for (int i = 0; i < 3; i++) {
            /* The focus sits in the central cell, and the origin is a whole number of cells. */
            PF_CHECK(a.cascades[k].origin[i] == a.cascades[k].origin_cell[i] * s);
            double centre_cell = (focus[i] - a.cascades[k].origin[i]) / s;
            PF_CHECK(centre_cell >= 16.0 && centre_cell < 17.0);
        }
        PF_CHECK(a.cascades[k].iterations == PF_LPV_DEFAULT_ITERATIONS);
    }
    /* A move inside the finest cell changes nothing; a move of one finest cell shifts it by one. */
    float inside[3] = {focus[0] + 0.01f, focus[1] + 0.01f, focus[2] + 0.005f};
    pf_lpv_layout_make(&settings, inside, 0.0625f, NULL, &b);
    PF_CHECK(!memcmp(a.cascades, b.cascades, sizeof a.cascades));
    float moved[3] = {focus[0] + 0.0625f, focus[1], focus[2]};
    pf_lpv_layout_make(&settings, moved, 0.0625f, NULL, &c);
    PF_CHECK(c.cascades[0].origin_cell[0] == a.cascades[0].origin_cell[0] + 1);
    PF_CHECK(c.cascades[0].origin_cell[1] == a.cascades[0].origin_cell[1]);
    /* Per-cascade iterations: 0 takes the first cascade's value. */
    pf_lpv_settings per = {.cascades = 3, .size = 8, .iterations = {4, 0, 12}};
    pf_lpv_layout_make(&per, focus, 0.5f, NULL, &c);
    PF_CHECK(c.cascades[0].iterations == 4 && c.cascades[1].iterations == 4 &&
             c.cascades[2].iterations == 12);
}

PF_TEST(default_cell_is_a_power_of_two_covering_the_scene)
{
    float p0[3] = {-3, 0, -2}, p1[3] = {3, 0, -2}, p2[3] = {3, 2.5f, 2}, p3[3] = {-3, 2.5f, 2};
    quad_frame q;
    quad_make(&q, p0, p1, p2, p3);
    float focus[3] = {2.5f, 1.0f, 0.0f};
    float cell = pf_lpv_default_cell_size(&q.frame, focus, 4, 32, 1000);
    PF_CHECK(cell > 0.0f && exp2f(roundf(log2f(cell))) == cell);
    pf_lpv_settings settings = {0};
    pf_lpv_layout layout;
    pf_lpv_layout_make(&settings, focus, cell, &q.frame, &layout);
    PF_CHECK(layout.covers_scene);
    /* Half that cell: the coarsest cascade no longer spans the 5.5 m from the focus. */
    pf_lpv_layout_make(&settings, focus, cell / 2.0f, &q.frame, &layout);
    PF_CHECK(!layout.covers_scene);
    /* With 8 iterations, the coarsest cell must also carry light twice across the 6 m box
     * (to the nearest power of two: 12 m × 2^±½). */
    float reach = pf_lpv_default_cell_size(&q.frame, focus, 4, 32, 8);
    PF_CHECK(reach * 8.0f * 8.0f >= 12.0f / sqrtf(2.0f) && reach * 8.0f * 8.0f <= 12.0f * sqrtf(2.0f));
}

PF_TEST(injection_keeps_the_flux_and_offsets_along_the_normal)
{
    pf_lpv_settings settings = {.cascades = 2, .size = 8, .offset_cells = 0.5f};
    float focus[3] = {0, 0, 0};
    pf_lpv_layout layout;
    pf_lpv_layout_make(&settings, focus, 0.25f, NULL, &layout);
    uint64_t floats = pf_lpv_volume_floats(&layout, PF_LPV_FLOATS_PER_CELL);
    float *grid = calloc(floats, sizeof *grid);
    PF_REQUIRE(grid);
    /* On the plane z = 0 (a cell boundary), facing +z: lands in the cell above. */
    pf_lpv_vpl vpls[3] = {{{0.1f, 0.1f, 0.0f}, {0, 0, 1}, {2.0f, 1.0f, 0.5f}},
                          {{0.1f, 0.1f, 0.0f}, {0, 0, 0}, {1, 1, 1}},          /* no normal */
                          {{50.0f, 0.0f, 0.0f}, {1, 0, 0}, {1, 1, 1}}};        /* far outside */
    pf_lpv_inject_stats stats;
    pf_lpv_inject(&layout, vpls, 3, grid, &stats);
    PF_CHECK(stats.injected[0] == 1 && stats.injected[1] == 1);
    PF_CHECK(stats.outside == 1 && stats.rejected == 1);
    uint64_t cells = 8u * 8u * 8u;
    for (uint32_t k = 0; k < 2; k++) {
        double flux[3] = {0, 0, 0};
        int occupied = 0;
        for (uint64_t i = 0; i < cells; i++) {
            const float *cell = grid + (k * cells + i) * PF_LPV_FLOATS_PER_CELL;
            if (cell[0] != 0.0f) {
                occupied++;
                /* Cell (4, 4, 4): origin_cell -4, z from 0 + half a cell. */
                PF_CHECK(i == (4u * 8u + 4u) * 8u + 4u);
            }
            for (int ch = 0; ch < 3; ch++)
                flux[ch] += pf_sh_integral(cell + 4 * ch);
        }
        PF_CHECK(occupied == 1);
        PF_CHECK_NEAR(flux[0], 2.0, 1e-5);
        PF_CHECK_NEAR(flux[1], 1.0, 1e-5);
        PF_CHECK_NEAR(flux[2], 0.5, 1e-5);
    }
    free(grid);
}

PF_TEST(settings_outside_their_ranges_are_refused)
{
    pf_error err = {0};
    pf_lpv_setting which;
    pf_lpv_settings ok = {0};
    PF_CHECK(pf_lpv_settings_check(&ok, 128u << 20, &which, &err) == PF_OK);
    pf_lpv_settings cascades = {.cascades = PF_LPV_MAX_CASCADES + 1};
    PF_CHECK(pf_lpv_settings_check(&cascades, 0, &which, &err) == PF_ERR_INVALID &&
             which == PF_LPV_SETTING_CASCADES);
    pf_lpv_settings size = {.size = 30};
    PF_CHECK(pf_lpv_settings_check(&size, 0, &which, &err) == PF_ERR_INVALID &&
             which == PF_LPV_SETTING_SIZE);
    /* 4 × 256³ × 48 bytes = 3 GiB: past lavapipe's 128 MiB buffers, with the largest that fits. */
    pf_lpv_settings big = {.size = 256};
    PF_CHECK(pf_lpv_settings_check(&big, 128u << 20, &which, &err) == PF_ERR_LIMIT &&
             which == PF_LPV_SETTING_SIZE);
    PF_CHECK_MSG(strstr(err.message, "largest that fits: 88") != NULL, "%s", err.message);
    pf_lpv_settings iterations = {.iterations = {8, PF_LPV_MAX_ITERATIONS + 1}};
    PF_CHECK(pf_lpv_settings_check(&iterations, 0, &which, &err) == PF_ERR_INVALID &&
             which == PF_LPV_SETTING_ITERATIONS);
    pf_lpv_settings cell = {.cell_size = -1.0f};
    PF_CHECK(pf_lpv_settings_check(&cell, 0, &which, &err) == PF_ERR_INVALID &&
             which == PF_LPV_SETTING_CELL_SIZE);
    cell.cell_size = INFINITY;
    PF_CHECK(pf_lpv_settings_check(&cell, 0, &which, &err) == PF_ERR_INVALID);
}

int main(void)
{
    PF_RUN(cosine_lobe_projection_matches_numerical_projection);
    PF_RUN(cosine_lobe_evaluates_to_its_analytic_expansion);
    PF_RUN(solid_angles_sum_to_the_sphere);
    PF_RUN(clipped_area_is_exact);
    PF_RUN(geometry_volume_holds_the_exact_area);
    PF_RUN(energy_points_spread_over_the_diffuse_area);
    PF_RUN(cascades_snap_to_their_cell_size);
    PF_RUN(default_cell_is_a_power_of_two_covering_the_scene);
    PF_RUN(injection_keeps_the_flux_and_offsets_along_the_normal);
    PF_RUN(settings_outside_their_ranges_are_refused);
    return pf_test_finish();
}
