/*
 * The GPU brute-force oracle (pf_raycast_brute_force and its any-hit variant)
 * against the CPU watertight test on random rays: a random triangle soup, a
 * shared scene, and a mesh past lavapipe's loop limit (the oracle must split
 * the triangles across dispatches). Validation must stay silent.
 */
#include "pf_render.h"
#include "pf_test.h"
#include "render_internal.h"
#include "render_test_env.h"

#include <stdint.h>

#define RAY_COUNT 10000u
#define SOUP_TRIANGLES 500u
/*
 * Past llvmpipe's loop limit: an invocation's loops stop after 65,535
 * iterations in all (Mesa 22.3), which a single pass over this many triangles
 * exceeds about twice; an uneven last range (not a multiple of the oracle's
 * triangles per dispatch) too.
 */
#define LARGE_TRIANGLES 150001u
#define LARGE_RAYS 400u
/* Triangle indices at and beyond this are where a capped single pass never looked. */
#define LOOP_CAP_TRIANGLES 65536u
/* Triangle size in the large strip: ~1 expected hit per ray, so hits and misses both. */
#define LARGE_TRIANGLE_SIZE 0.012f
/* Relative t tolerance: GPU division may be 2.5 ulp off (Vulkan precision rules). */
#define T_RELATIVE_TOLERANCE 1e-6

static pf_vk_context *ctx;
static pf_renderer *renderer;

static uint32_t next_random(uint32_t *state)
{
    *state ^= *state << 13;
    *state ^= *state >> 17;
    *state ^= *state << 5;
    return *state;
}

static float uniform(uint32_t *state, float low, float high)
{
    return low + (high - low) * (float)(next_random(state) >> 8) / 16777216.0f;
}

/* Closest hit on the CPU in the GPU's order (lower index wins ties). */
static pf_hit cpu_closest(const pf_scene_frame *frame, const pf_ray *ray)
{
    pf_hit hit = {-1.0f, PF_NO_HIT, 0, 0};
    float closest = ray->tmax;
    for (uint32_t i = 0; i < frame->triangle_count; i++) {
        float t, u, v;
        if (pf_ray_triangle_watertight(ray->origin, ray->direction, frame->vertices[3 * i],
                                       frame->vertices[3 * i + 1], frame->vertices[3 * i + 2],
                                       ray->tmin, closest, &t, &u, &v)) {
            closest = t;
            hit = (pf_hit){t, i, u, v};
        }
    }
    return hit;
}

static int t_close(float a, float b)
{
    return fabs((double)a - b) <= T_RELATIVE_TOLERANCE * fmax(fabs(a), fabs(b));
}

/* Counts GPU/CPU disagreements; prints the first few. */
static uint32_t compare_closest(const pf_scene_frame *frame, const pf_ray *rays,
                                const pf_hit *gpu, uint32_t count, uint32_t *hit_count)
{
    uint32_t mismatches = 0;
    *hit_count = 0;
    for (uint32_t r = 0; r < count; r++) {
        pf_hit cpu = cpu_closest(frame, &rays[r]);
        int ok;
        if (cpu.triangle == PF_NO_HIT) {
            ok = gpu[r].triangle == PF_NO_HIT && gpu[r].t == -1.0f;
        } else if (gpu[r].triangle == cpu.triangle) {
            ok = t_close(gpu[r].t, cpu.t) && fabsf(gpu[r].u - cpu.u) <= 1e-5f &&
                 fabsf(gpu[r].v - cpu.v) <= 1e-5f;
        } else {
            /* A tie: the GPU's triangle must be hit at an equal t. */
            float t = 0, u, v;
            ok = gpu[r].triangle < frame->triangle_count && t_close(gpu[r].t, cpu.t) &&
                 pf_ray_triangle_watertight(rays[r].origin, rays[r].direction,
                                            frame->vertices[3 * gpu[r].triangle],
                                            frame->vertices[3 * gpu[r].triangle + 1],
                                            frame->vertices[3 * gpu[r].triangle + 2],
                                            rays[r].tmin, rays[r].tmax, &t, &u, &v) &&
                 t_close(t, cpu.t);
        }
        *hit_count += cpu.triangle != PF_NO_HIT;
        if (!ok && mismatches++ < 5)
            fprintf(stderr, "ray %u: gpu (tri %u, t %.9g) cpu (tri %u, t %.9g)\n", r,
                    gpu[r].triangle, gpu[r].t, cpu.triangle, cpu.t);
    }
    return mismatches;
}

/* Any-hit: a hit exactly when the closest-hit CPU query finds one, on a triangle really hit. */
static uint32_t compare_any(const pf_scene_frame *frame, const pf_ray *rays, const pf_hit *gpu,
                            uint32_t count)
{
    uint32_t mismatches = 0;
    for (uint32_t r = 0; r < count; r++) {
        pf_hit cpu = cpu_closest(frame, &rays[r]);
        int ok;
        if (cpu.triangle == PF_NO_HIT) {
            ok = gpu[r].triangle == PF_NO_HIT;
        } else {
            float t = 0, u, v;
            ok = gpu[r].triangle < frame->triangle_count &&
                 pf_ray_triangle_watertight(rays[r].origin, rays[r].direction,
                                            frame->vertices[3 * gpu[r].triangle],
                                            frame->vertices[3 * gpu[r].triangle + 1],
                                            frame->vertices[3 * gpu[r].triangle + 2],
                                            rays[r].tmin, rays[r].tmax, &t, &u, &v) &&
                 t_close(t, gpu[r].t);
        }
        if (!ok && mismatches++ < 5)
            fprintf(stderr, "any-hit ray %u: gpu (tri %u, t %.9g) cpu closest (tri %u)\n", r,
                    gpu[r].triangle, gpu[r].t, cpu.triangle);
    }
    return mismatches;
}

/* Random rays aimed into [lo, hi]^3 from around it; every fourth has a finite tmax. */
static void random_rays(uint32_t *state, const float lo[3], const float hi[3], pf_ray *rays,
                        uint32_t count)
{
    for (uint32_t r = 0; r < count; r++) {
        float target[3];
        for (int k = 0; k < 3; k++) {
            float margin = 0.5f * (hi[k] - lo[k]);
            rays[r].origin[k] = uniform(state, lo[k] - margin, hi[k] + margin);
            target[k] = uniform(state, lo[k], hi[k]);
            rays[r].direction[k] = target[k] - rays[r].origin[k];
        }
        rays[r].tmin = r % 8 == 1 ? 0.3f : 0.0f;
        rays[r].tmax = r % 4 == 0 ? uniform(state, 0.2f, 1.5f) : INFINITY;
    }
}

static void check_oracle(const pf_scene_frame *frame, uint32_t seed, const char *what)
{
    pf_ray *rays = malloc(RAY_COUNT * sizeof *rays);
    pf_hit *hits = malloc(RAY_COUNT * sizeof *hits);
    PF_REQUIRE(rays && hits);
    uint32_t state = seed;
    random_rays(&state, frame->bounds_min, frame->bounds_max, rays, RAY_COUNT);
    pf_error err = {0};
    PF_CHECK_OK(pf_raycast_brute_force(renderer, frame, rays, RAY_COUNT, hits, &err), &err);
    uint32_t hit_count = 0;
    uint32_t mismatches = compare_closest(frame, rays, hits, RAY_COUNT, &hit_count);
    PF_CHECK_MSG(mismatches == 0, "%s: %u of %u closest hits disagree", what, mismatches, RAY_COUNT);
    PF_CHECK_MSG(hit_count > RAY_COUNT / 10 && hit_count < RAY_COUNT,
                 "%s: %u hits: the rays must exercise both hits and misses", what, hit_count);
    PF_CHECK_OK(pf_raycast_brute(renderer, frame, rays, RAY_COUNT, 1, hits, &err), &err);
    mismatches = compare_any(frame, rays, hits, RAY_COUNT);
    PF_CHECK_MSG(mismatches == 0, "%s: %u of %u any-hit results disagree", what, mismatches, RAY_COUNT);
    free(rays);
    free(hits);
}

PF_TEST(oracle_matches_cpu_on_triangle_soup)
{
    pf_scene_frame frame = {0};
    frame.triangle_count = SOUP_TRIANGLES;
    frame.vertices = calloc(3 * SOUP_TRIANGLES, sizeof *frame.vertices);
    PF_REQUIRE(frame.vertices != NULL);
    uint32_t state = 2024;
    for (uint32_t i = 0; i < SOUP_TRIANGLES; i++) {
        float centre[3] = {uniform(&state, -1, 1), uniform(&state, -1, 1), uniform(&state, -1, 1)};
        for (int corner = 0; corner < 3; corner++)
            for (int k = 0; k < 3; k++)
                frame.vertices[3 * i + corner][k] = centre[k] + uniform(&state, -0.2f, 0.2f);
    }
    /* Exact duplicates make ties: the tie rule must hold too. */
    memcpy(frame.vertices[3 * 7], frame.vertices[3 * 3], 3 * sizeof *frame.vertices);
    for (int k = 0; k < 3; k++) {
        frame.bounds_min[k] = -1.2f;
        frame.bounds_max[k] = 1.2f;
    }
    check_oracle(&frame, 17, "triangle soup");
    free(frame.vertices);
}

PF_TEST(oracle_matches_cpu_on_shared_scene)
{
    char path[1024];
    pf_scene *scene = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_scene_load(pf_test_shared_scene("cornell-anim", path, sizeof path), &scene,
                                &err),
                  &err);
    pf_scene_frame frame = {0};
    PF_REQUIRE_OK(pf_scene_eval(scene, pf_scene_frame_time(scene, 20), &frame, &err), &err);
    check_oracle(&frame, 4242, "cornell-anim frame 20");
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

/*
 * A strip of LARGE_TRIANGLES small triangles whose centre x grows with the
 * index, crossed by rays close to the y axis: each ray meets only triangles
 * of nearby indices, so the rays at large x can be answered only by the
 * triangles past LOOP_CAP_TRIANGLES — closest and any hit.
 */
PF_TEST(oracle_is_exact_past_the_loop_limit)
{
    pf_scene_frame frame = {0};
    frame.triangle_count = LARGE_TRIANGLES;
    frame.vertices = calloc(3 * (size_t)LARGE_TRIANGLES, sizeof *frame.vertices);
    pf_ray *rays = malloc(LARGE_RAYS * sizeof *rays);
    pf_hit *hits = malloc(LARGE_RAYS * sizeof *hits);
    PF_REQUIRE(frame.vertices && rays && hits);
    uint32_t state = 31337;
    for (uint32_t i = 0; i < LARGE_TRIANGLES; i++) {
        float centre[3] = {-1.0f + 2.0f * ((float)i + 0.5f) / (float)LARGE_TRIANGLES,
                           uniform(&state, -1, 1), uniform(&state, -1, 1)};
        for (int corner = 0; corner < 3; corner++)
            for (int k = 0; k < 3; k++)
                frame.vertices[3 * i + corner][k] =
                    centre[k] + uniform(&state, -LARGE_TRIANGLE_SIZE, LARGE_TRIANGLE_SIZE);
    }
    /* Exact duplicates past the cap make ties there too. */
    for (uint32_t i = LOOP_CAP_TRIANGLES; i + 1 < LARGE_TRIANGLES; i += 4099)
        memcpy(frame.vertices[3 * (i + 1)], frame.vertices[3 * i], 3 * sizeof *frame.vertices);
    for (uint32_t r = 0; r < LARGE_RAYS; r++) {
        pf_ray *ray = &rays[r];
        ray->origin[0] = uniform(&state, -1, 1);
        ray->origin[1] = -2.0f;
        ray->origin[2] = uniform(&state, -1, 1);
        ray->direction[0] = uniform(&state, -0.01f, 0.01f);
        ray->direction[1] = 1.0f;
        ray->direction[2] = uniform(&state, -0.01f, 0.01f);
        ray->tmin = 0.0f;
        ray->tmax = r % 4 == 0 ? uniform(&state, 1.0f, 3.0f) : INFINITY;
    }
    /* Every fifth ray aimed exactly at a triangle's centroid past the cap: a sure hit there. */
    for (uint32_t r = 0; r < LARGE_RAYS; r += 5) {
        uint32_t t = LOOP_CAP_TRIANGLES + next_random(&state) % (LARGE_TRIANGLES - LOOP_CAP_TRIANGLES);
        for (int k = 0; k < 3; k++) {
            float centroid = (frame.vertices[3 * t][k] + frame.vertices[3 * t + 1][k] +
                              frame.vertices[3 * t + 2][k]) / 3.0f;
            rays[r].direction[k] = centroid - rays[r].origin[k];
        }
        rays[r].tmax = INFINITY;
    }
    for (int k = 0; k < 3; k++) {
        frame.bounds_min[k] = -1.0f - LARGE_TRIANGLE_SIZE;
        frame.bounds_max[k] = 1.0f + LARGE_TRIANGLE_SIZE;
    }
    pf_error err = {0};
    double start = pf_time_ms();
    PF_CHECK_OK(pf_raycast_brute_force(renderer, &frame, rays, LARGE_RAYS, hits, &err), &err);
    double gpu_ms = pf_time_ms() - start;
    uint32_t hit_count = 0, past_cap = 0;
    uint32_t mismatches = compare_closest(&frame, rays, hits, LARGE_RAYS, &hit_count);
    for (uint32_t r = 0; r < LARGE_RAYS; r++)
        past_cap += hits[r].triangle != PF_NO_HIT && hits[r].triangle >= LOOP_CAP_TRIANGLES;
    PF_CHECK_MSG(mismatches == 0, "%u triangles: %u of %u closest hits disagree", LARGE_TRIANGLES,
                 mismatches, LARGE_RAYS);
    PF_CHECK_MSG(hit_count > LARGE_RAYS / 4 && hit_count < LARGE_RAYS,
                 "%u hits: the rays must exercise both hits and misses", hit_count);
    /* Agreeing answers past the cap are what shows a capped loop would have been caught. */
    PF_CHECK_MSG(mismatches > 0 || past_cap > LARGE_RAYS / 5,
                 "only %u closest hits past triangle %u: the test would not see a capped loop",
                 past_cap, LOOP_CAP_TRIANGLES);
    PF_CHECK_OK(pf_raycast_brute(renderer, &frame, rays, LARGE_RAYS, 1, hits, &err), &err);
    mismatches = compare_any(&frame, rays, hits, LARGE_RAYS);
    PF_CHECK_MSG(mismatches == 0, "%u triangles: %u of %u any-hit results disagree",
                 LARGE_TRIANGLES, mismatches, LARGE_RAYS);
    printf("%u triangles, %u rays: %u hits, %u past triangle %u; closest-hit oracle %.0f ms\n",
           LARGE_TRIANGLES, LARGE_RAYS, hit_count, past_cap, LOOP_CAP_TRIANGLES, gpu_ms);
    free(frame.vertices);
    free(rays);
    free(hits);
}

PF_TEST(zero_triangles_every_ray_misses)
{
    pf_scene_frame frame = {0};
    pf_ray rays[100];
    pf_hit hits[100];
    uint32_t state = 5;
    float lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
    random_rays(&state, lo, hi, rays, 100);
    pf_error err = {0};
    PF_REQUIRE_OK(pf_raycast_brute_force(renderer, &frame, rays, 100, hits, &err), &err);
    for (int r = 0; r < 100; r++)
        PF_CHECK(hits[r].triangle == PF_NO_HIT && hits[r].t == -1.0f);
    PF_REQUIRE_OK(pf_raycast_brute(renderer, &frame, rays, 100, 1, hits, &err), &err);
    for (int r = 0; r < 100; r++)
        PF_CHECK(hits[r].triangle == PF_NO_HIT);
    PF_CHECK_OK(pf_raycast_brute_force(renderer, &frame, rays, 0, hits, &err), &err);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(oracle_matches_cpu_on_triangle_soup);
    PF_RUN(oracle_matches_cpu_on_shared_scene);
    PF_RUN(oracle_is_exact_past_the_loop_limit);
    PF_RUN(zero_triangles_every_ray_misses);
    return render_test_finish(ctx, renderer);
}
