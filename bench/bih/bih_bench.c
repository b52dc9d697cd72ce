/*
 * bih_bench: the BIH (core/bih) against Embree 3 on the same triangles and the
 * same rays, as issue 3's Benchmark section asks. For each shared scene and a
 * generated 1M-triangle displaced sphere it prints:
 *   - our CPU build time (ms, Mtri/s) with the global heuristic on 1 and 2
 *     threads and with binned SAH + empty-space cuts (PF_BIH_HEURISTIC_SAH)
 *     on 2, SAH cost, bytes per node, node count of both trees;
 *   - our GPU build (pf_bih_build_gpu) time and its tree's SAH;
 *   - every tree's SAH also with node boxes cut by the clip planes only
 *     (pf_bih_quality.clip_sah_cost: what traversal pays);
 *   - Embree's low-quality (Morton) and high-quality scene build times;
 *   - the SAH of a binary BVH built by Embree's own builder (rtcBuildBVH, high
 *     quality with spatial splits, leaves of at most PF_BIH_DEFAULT_LEAF_SIZE),
 *     measured with the same cost model as pf_bih_quality_measure;
 *   - for both CPU trees, Mrays/s of pf_bih_raycast, of our CPU traversal
 *     (pf_bih_trace_cpu_rays: packets of 16 consecutive rays), of its wide
 *     view one ray at a time (pf_bih_wide_trace_rays) and of Embree's
 *     single rays, rtcIntersect1/rtcOccluded1 (both CPU sides in 2 pthreads)
 *     for primary (640x480, in 4x4 pixel tiles: primary_index), shadow (any
 *     hit) and diffuse-bounce rays;
 *   - the fraction of rays where the GPU and Embree agree (t within 1e-4
 *     relative, or the same occluded answer), the same for the wide view, and
 *     the ours/Embree ratios (every CPU and Embree figure best of
 *     TIMING_REPEATS).
 * Figures are reports, never pass/fail. Usage:
 *   bih_bench [scenes_dir [only]]   (scenes_dir default $PF_SHARED_SCENES)
 * where only, when given, runs just the scene of that name ("sphere" for the
 * generated mesh), e.g. to profile one case; "sphere-build" only times the
 * builds of the generated mesh, ours (global and SAH, BENCH_THREADS threads)
 * and Embree's LOW, and our GPU build (wall time and its submissions), BUILD_ROUNDS
 * rounds each taking one of each in turn, and
 * prints the best and the median of each: build figures steady enough for an
 * A/B on a shared machine. A third argument "cpu" (bih_bench DIR SCENE cpu)
 * times only our CPU traversal of the SAH tree and Embree on the same rays,
 * CPU_ROUNDS rounds taking one of each in turn, best and median: the A/B
 * harness for core/bih's C traversal. Its "cpu-wide" rows time the wide view
 * (pf_bih_wide_trace_rays: one ray at a time, 8 boxes a step with AVX2) in
 * the same rounds, and the last line the view's build from the SAH tree.
 * "gpu" (bih_bench DIR SCENE gpu) does the
 * same for the device traversal (pf_bih_raycast of the SAH tree, its shader
 * compiled before the first round): the A/B harness for bih_traverse.glsl.
 * Run with LP_NUM_THREADS=2 so lavapipe gets the 2 threads Embree is given.
 */
#include "pf_bih.h"
#include "pf_common.h"
#include "pf_scene.h"
#include "pf_vk.h"

#include <embree3/rtcore.h>

#include <dirent.h>
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The primary-ray image size. */
#define BENCH_WIDTH 640u
#define BENCH_HEIGHT 480u
/* The thread budget for both sides. */
#define BENCH_THREADS 2
/* Generated mesh: 500 x 1000 quads = 1,000,000 triangles. */
#define SPHERE_RINGS 500u
#define SPHERE_SEGMENTS 1000u
/* Agreement tolerance on t (issue brief). */
#define T_REL_TOLERANCE 1e-4
/* Best of this many timed runs (the machine is shared: the best run is the least disturbed). */
#define TIMING_REPEATS 3
#define BUILD_ROUNDS 15
#define CPU_ROUNDS 7
/* Stand-in for an infinite tmax that both the GLSL traversal and Embree accept. */
#define RAY_FAR 1e30f
/* Ray offset from a surface, relative to the scene diagonal (avoids self-hits). */
#define SURFACE_EPS_REL 1e-4f

typedef struct bench_mesh {
    char name[64];
    pf_scene_frame frame;      /* vertices/triangle_count/bounds/camera used */
    int owns_vertices;         /* generated mesh: freed here, not by pf_scene_frame_free */
    float light[3];
} bench_mesh;

/* ---------- small vector helpers ---------- */

static void v_sub(const float *a, const float *b, float *o)
{
    o[0] = a[0] - b[0];
    o[1] = a[1] - b[1];
    o[2] = a[2] - b[2];
}

static void v_cross(const float *a, const float *b, float *o)
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

static float v_dot(const float *a, const float *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static float v_normalize(float *v)
{
    float len = sqrtf(v_dot(v, v));
    if (len > 0.0f) {
        v[0] /= len;
        v[1] /= len;
        v[2] /= len;
    }
    return len;
}

static float scene_diagonal(const pf_scene_frame *f)
{
    float d[3];
    v_sub(f->bounds_max, f->bounds_min, d);
    return sqrtf(v_dot(d, d));
}

/* PCG32 (O'Neill 2014): deterministic, so every run traces the same rays. */
static uint32_t pcg32(uint64_t *state)
{
    uint64_t old = *state;
    *state = old * 6364136223846793005ull + 1442695040888963407ull;
    uint32_t xorshifted = (uint32_t)(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = (uint32_t)(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
}

static float rand01(uint64_t *state)
{
    return (float)(pcg32(state) >> 8) * (1.0f / 16777216.0f);
}

/* ---------- meshes ---------- */

/*
 * A unit sphere whose radius is displaced by a few sines: smooth enough that
 * the triangles are well shaped, bumpy enough that the tree is not a grid.
 */
static int make_sphere(bench_mesh *m)
{
    uint32_t n = 2u * SPHERE_RINGS * SPHERE_SEGMENTS;
    float(*v)[4] = calloc((size_t)3 * n, sizeof *v);
    if (!v)
        return 0;
    const float pi = 3.14159265358979f;
#define SPHERE_POINT(r, s, out)                                                           \
    do {                                                                              \
        float th = pi * (float)(r) / (float)SPHERE_RINGS;                             \
        float ph = 2.0f * pi * (float)((s) % SPHERE_SEGMENTS) / (float)SPHERE_SEGMENTS; \
        float rad = 1.0f + 0.05f * sinf(7.0f * th) * sinf(9.0f * ph) +                \
                    0.02f * sinf(23.0f * th + 3.0f * ph);                             \
        (out)[0] = rad * sinf(th) * cosf(ph);                                         \
        (out)[1] = rad * cosf(th);                                                    \
        (out)[2] = rad * sinf(th) * sinf(ph);                                         \
        (out)[3] = 0.0f;                                                              \
    } while (0)
    uint32_t t = 0;
    for (uint32_t r = 0; r < SPHERE_RINGS; r++) {
        for (uint32_t s = 0; s < SPHERE_SEGMENTS; s++) {
            float p00[4], p01[4], p10[4], p11[4];
            SPHERE_POINT(r, s, p00);
            SPHERE_POINT(r, s + 1, p01);
            SPHERE_POINT(r + 1, s, p10);
            SPHERE_POINT(r + 1, s + 1, p11);
            memcpy(v[3 * t + 0], p00, sizeof p00);
            memcpy(v[3 * t + 1], p10, sizeof p10);
            memcpy(v[3 * t + 2], p11, sizeof p11);
            t++;
            memcpy(v[3 * t + 0], p00, sizeof p00);
            memcpy(v[3 * t + 1], p11, sizeof p11);
            memcpy(v[3 * t + 2], p01, sizeof p01);
            t++;
        }
    }
#undef SPHERE_POINT
    memset(m, 0, sizeof *m);
    snprintf(m->name, sizeof m->name, "sphere-1M (generated)");
    m->owns_vertices = 1;
    pf_scene_frame *f = &m->frame;
    f->triangle_count = n;
    f->vertices = v;
    for (int k = 0; k < 3; k++) {
        f->bounds_min[k] = 1e30f;
        f->bounds_max[k] = -1e30f;
    }
    for (size_t i = 0; i < (size_t)3 * n; i++) {
        for (int k = 0; k < 3; k++) {
            f->bounds_min[k] = fminf(f->bounds_min[k], v[i][k]);
            f->bounds_max[k] = fmaxf(f->bounds_max[k], v[i][k]);
        }
    }
    /* Default view: 3.5 radii away, slightly above, 45 degree vertical FOV. */
    pf_camera *c = &f->camera;
    float pos[3] = {0.0f, 1.0f, 3.5f}, fwd[3], up0[3] = {0.0f, 1.0f, 0.0f};
    memcpy(c->position, pos, sizeof pos);
    fwd[0] = -pos[0];
    fwd[1] = -pos[1];
    fwd[2] = -pos[2];
    v_normalize(fwd);
    memcpy(c->forward, fwd, sizeof fwd);
    v_cross(fwd, up0, c->right);
    v_normalize(c->right);
    v_cross(c->right, fwd, c->up);
    c->yfov = 0.785398f;
    m->light[0] = 1.5f;
    m->light[1] = 3.0f;
    m->light[2] = 1.0f;
    return 1;
}

/*
 * Shadow-ray target: the scene's first punctual light; else just in front of
 * the first emissive triangle (the scenes light their rooms that way); else a
 * point high inside the scene box.
 */
static void pick_light(bench_mesh *m)
{
    const pf_scene_frame *f = &m->frame;
    float diag = scene_diagonal(f);
    if (f->light_count > 0) {
        const pf_light *l = &f->lights[0];
        /* A directional light: a point two diagonals up its beam from the centre. */
        for (int k = 0; k < 3; k++) {
            float centre = 0.5f * (f->bounds_min[k] + f->bounds_max[k]);
            m->light[k] = l->kind == PF_LIGHT_DIRECTIONAL ? centre - 2.0f * diag * l->direction[k]
                                                          : l->position[k];
        }
        return;
    }
    for (uint32_t t = 0; t < f->triangle_count; t++) {
        const pf_material *mat = &f->materials[f->triangle_material[t]];
        if (mat->emission[0] + mat->emission[1] + mat->emission[2] <= 0.0f)
            continue;
        float e1[3], e2[3], n[3];
        v_sub(f->vertices[3 * t + 1], f->vertices[3 * t], e1);
        v_sub(f->vertices[3 * t + 2], f->vertices[3 * t], e2);
        v_cross(e1, e2, n);
        v_normalize(n);
        for (int k = 0; k < 3; k++)
            m->light[k] = (f->vertices[3 * t][k] + f->vertices[3 * t + 1][k] +
                           f->vertices[3 * t + 2][k]) / 3.0f + 1e-3f * diag * n[k];
        return;
    }
    for (int k = 0; k < 3; k++)
        m->light[k] = 0.5f * (f->bounds_min[k] + f->bounds_max[k]);
    m->light[1] = f->bounds_min[1] + 0.9f * (f->bounds_max[1] - f->bounds_min[1]);
}

static void mesh_free(bench_mesh *m)
{
    if (m->owns_vertices)
        free(m->frame.vertices);
    else
        pf_scene_frame_free(&m->frame);
}

/* ---------- rays ---------- */

/*
 * Where pixel (x, y)'s primary ray goes in the ray array: 4×4 pixel tiles,
 * the tiles in rows, as a tile renderer and Embree's packet tutorials order
 * them, so consecutive rays (a CPU packet of PF_BIH_PACKET_RAYS = 16, an
 * 8-lane group on lavapipe) are a pixel neighbourhood, and the shadow and
 * diffuse rays made from the hits keep that order. Every traversal, Embree's
 * included, gets the same array. $PF_BENCH_ROW_ORDER=1: rows of pixels, the
 * order of the figures in bench/RESULTS.md before 2026-11-27's sixth stop.
 */
#define PRIMARY_TILE 4u
_Static_assert(BENCH_WIDTH % PRIMARY_TILE == 0 && BENCH_HEIGHT % PRIMARY_TILE == 0,
               "whole tiles");
static uint32_t primary_index(uint32_t x, uint32_t y, int row_order)
{
    if (row_order)
        return y * BENCH_WIDTH + x;
    uint32_t tile = (y / PRIMARY_TILE) * (BENCH_WIDTH / PRIMARY_TILE) + x / PRIMARY_TILE;
    return tile * PRIMARY_TILE * PRIMARY_TILE + (y % PRIMARY_TILE) * PRIMARY_TILE +
           x % PRIMARY_TILE;
}

static void make_primary(const pf_scene_frame *f, pf_ray *rays)
{
    const char *rows = getenv("PF_BENCH_ROW_ORDER");
    int row_order = rows && strcmp(rows, "1") == 0;
    float tx, ty;
    pf_camera_image_plane(&f->camera, BENCH_WIDTH, BENCH_HEIGHT, &tx, &ty);
    const pf_camera *c = &f->camera;
    for (uint32_t y = 0; y < BENCH_HEIGHT; y++) {
        for (uint32_t x = 0; x < BENCH_WIDTH; x++) {
            float sx = (2.0f * ((float)x + 0.5f) / (float)BENCH_WIDTH - 1.0f) * tx;
            float sy = (1.0f - 2.0f * ((float)y + 0.5f) / (float)BENCH_HEIGHT) * ty;
            pf_ray *r = &rays[primary_index(x, y, row_order)];
            for (int k = 0; k < 3; k++) {
                r->origin[k] = c->position[k];
                r->direction[k] = c->forward[k] + sx * c->right[k] + sy * c->up[k];
            }
            v_normalize(r->direction);
            r->tmin = 0.0f;
            r->tmax = RAY_FAR;
        }
    }
}

/* Geometric normal of triangle t, turned to face against the incoming direction. */
static void facing_normal(const pf_scene_frame *f, uint32_t t, const float *dir, float *n)
{
    float e1[3], e2[3];
    v_sub(f->vertices[3 * t + 1], f->vertices[3 * t], e1);
    v_sub(f->vertices[3 * t + 2], f->vertices[3 * t], e2);
    v_cross(e1, e2, n);
    v_normalize(n);
    if (v_dot(n, dir) > 0.0f) {
        n[0] = -n[0];
        n[1] = -n[1];
        n[2] = -n[2];
    }
}

/*
 * Secondary rays from the primary hits: shadow rays towards light (tmax stops
 * just short of it) and cosine-distributed bounce rays about the facing normal.
 * Returns the number of rays (= primary hits); both arrays get that many.
 */
static uint32_t make_secondary(const bench_mesh *m, const pf_ray *primary, const pf_hit *hits,
                               uint32_t count, pf_ray *shadow, pf_ray *diffuse)
{
    const pf_scene_frame *f = &m->frame;
    float eps = SURFACE_EPS_REL * scene_diagonal(f);
    uint64_t rng = 0x853c49e6748fea9bull;
    uint32_t out = 0;
    for (uint32_t i = 0; i < count; i++) {
        if (hits[i].triangle == PF_NO_HIT)
            continue;
        float p[3], n[3];
        for (int k = 0; k < 3; k++)
            p[k] = primary[i].origin[k] + hits[i].t * primary[i].direction[k];
        facing_normal(f, hits[i].triangle, primary[i].direction, n);
        for (int k = 0; k < 3; k++)
            p[k] += eps * n[k];

        pf_ray *s = &shadow[out];
        memcpy(s->origin, p, sizeof p);
        v_sub(m->light, p, s->direction);
        float dist = v_normalize(s->direction);
        s->tmin = 0.0f;
        s->tmax = dist > 2.0f * eps ? dist - eps : eps;

        /* Cosine-weighted hemisphere (Malley's method) in a frame around n. */
        float u1 = rand01(&rng), u2 = rand01(&rng);
        float rad = sqrtf(u1), phi = 6.2831853f * u2;
        float lx = rad * cosf(phi), ly = rad * sinf(phi), lz = sqrtf(fmaxf(0.0f, 1.0f - u1));
        float a[3] = {1.0f, 0.0f, 0.0f}, b1[3], b2[3];
        if (fabsf(n[0]) > 0.9f) {
            a[0] = 0.0f;
            a[1] = 1.0f;
        }
        v_cross(n, a, b1);
        v_normalize(b1);
        v_cross(n, b1, b2);
        pf_ray *d = &diffuse[out];
        memcpy(d->origin, p, sizeof p);
        for (int k = 0; k < 3; k++)
            d->direction[k] = lx * b1[k] + ly * b2[k] + lz * n[k];
        v_normalize(d->direction);
        d->tmin = 0.0f;
        d->tmax = RAY_FAR;
        out++;
    }
    return out;
}

/* ---------- Embree ---------- */

static RTCScene embree_scene(RTCDevice dev, const pf_scene_frame *f, enum RTCBuildQuality q,
                             uint32_t *indices, double *build_ms)
{
    RTCScene scene = rtcNewScene(dev);
    rtcSetSceneBuildQuality(scene, q);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(g, q);
    /* Our vertices are float4 (w padding): Embree reads float3 at stride 16. */
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, f->vertices, 0,
                               4 * sizeof(float), (size_t)3 * f->triangle_count);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, indices, 0,
                               3 * sizeof(uint32_t), f->triangle_count);
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    double t0 = pf_time_ms();
    rtcCommitScene(scene);
    *build_ms = pf_time_ms() - t0;
    return scene;
}

typedef struct embree_job {
    RTCScene scene;
    const pf_ray *rays;
    uint32_t first, count;
    int occluded;
    pf_hit *hits;
} embree_job;

static void *embree_trace(void *arg)
{
    embree_job *j = arg;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (uint32_t i = j->first; i < j->first + j->count; i++) {
        const pf_ray *r = &j->rays[i];
        pf_hit *h = &j->hits[i];
        if (j->occluded) {
            struct RTCRay ray = {r->origin[0], r->origin[1], r->origin[2], r->tmin,
                                 r->direction[0], r->direction[1], r->direction[2], 0.0f,
                                 r->tmax, 0xFFFFFFFFu, 0, 0};
            rtcOccluded1(j->scene, &ctx, &ray);
            /* Embree marks an occluded ray by tfar = -inf. */
            h->t = ray.tfar < 0.0f ? 1.0f : -1.0f;
            h->triangle = ray.tfar < 0.0f ? 0u : PF_NO_HIT;
        } else {
            struct RTCRayHit rh;
            memset(&rh, 0, sizeof rh);
            rh.ray.org_x = r->origin[0];
            rh.ray.org_y = r->origin[1];
            rh.ray.org_z = r->origin[2];
            rh.ray.tnear = r->tmin;
            rh.ray.dir_x = r->direction[0];
            rh.ray.dir_y = r->direction[1];
            rh.ray.dir_z = r->direction[2];
            rh.ray.tfar = r->tmax;
            rh.ray.mask = 0xFFFFFFFFu;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(j->scene, &ctx, &rh);
            h->t = rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? -1.0f : rh.ray.tfar;
            h->triangle = rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? PF_NO_HIT : rh.hit.primID;
        }
    }
    return NULL;
}

/* Traces rays with BENCH_THREADS pthreads; returns the wall time in ms. */
static double embree_cast(RTCScene scene, const pf_ray *rays, uint32_t count, int occluded,
                          pf_hit *hits)
{
    pthread_t th[BENCH_THREADS];
    embree_job jobs[BENCH_THREADS];
    double t0 = pf_time_ms();
    uint32_t per = (count + BENCH_THREADS - 1) / BENCH_THREADS;
    for (int i = 0; i < BENCH_THREADS; i++) {
        uint32_t first = (uint32_t)i * per;
        jobs[i] = (embree_job){scene, rays, first,
                               first >= count ? 0 : (count - first < per ? count - first : per),
                               occluded, hits};
        pthread_create(&th[i], NULL, embree_trace, &jobs[i]);
    }
    for (int i = 0; i < BENCH_THREADS; i++)
        pthread_join(th[i], NULL);
    return pf_time_ms() - t0;
}

/* Embree's builder over our triangles, with a binary tree of our own nodes. */
typedef struct ebvh_node {
    int leaf;
    uint32_t count;                  /* leaf: primitive references */
    float lo[3], hi[3];              /* leaf: box of its (possibly clipped) references */
    struct ebvh_node *child[2];
    float clo[2][3], chi[2][3];      /* inner: child boxes */
} ebvh_node;

static void *ebvh_create_node(RTCThreadLocalAllocator alloc, unsigned int child_count, void *user)
{
    (void)child_count;
    (void)user;
    ebvh_node *n = rtcThreadLocalAlloc(alloc, sizeof(ebvh_node), 16);
    memset(n, 0, sizeof *n);
    return n;
}

static void ebvh_set_children(void *node, void **children, unsigned int child_count, void *user)
{
    (void)user;
    ebvh_node *n = node;
    for (unsigned int i = 0; i < child_count && i < 2; i++)
        n->child[i] = children[i];
}

static void ebvh_set_bounds(void *node, const struct RTCBounds **bounds, unsigned int child_count,
                            void *user)
{
    (void)user;
    ebvh_node *n = node;
    for (unsigned int i = 0; i < child_count && i < 2; i++) {
        n->clo[i][0] = bounds[i]->lower_x;
        n->clo[i][1] = bounds[i]->lower_y;
        n->clo[i][2] = bounds[i]->lower_z;
        n->chi[i][0] = bounds[i]->upper_x;
        n->chi[i][1] = bounds[i]->upper_y;
        n->chi[i][2] = bounds[i]->upper_z;
    }
}

static void *ebvh_create_leaf(RTCThreadLocalAllocator alloc, const struct RTCBuildPrimitive *prims,
                              size_t count, void *user)
{
    (void)user;
    ebvh_node *n = rtcThreadLocalAlloc(alloc, sizeof(ebvh_node), 16);
    memset(n, 0, sizeof *n);
    n->leaf = 1;
    n->count = (uint32_t)count;
    for (int k = 0; k < 3; k++) {
        n->lo[k] = 1e30f;
        n->hi[k] = -1e30f;
    }
    for (size_t i = 0; i < count; i++) {
        const float lo[3] = {prims[i].lower_x, prims[i].lower_y, prims[i].lower_z};
        const float hi[3] = {prims[i].upper_x, prims[i].upper_y, prims[i].upper_z};
        for (int k = 0; k < 3; k++) {
            n->lo[k] = fminf(n->lo[k], lo[k]);
            n->hi[k] = fmaxf(n->hi[k], hi[k]);
        }
    }
    return n;
}

/*
 * Spatial split of a reference: clips its box at the plane (conservative, as
 * Embree's own bvh_builder tutorial does; exact triangle clipping would only
 * lower Embree's SAH further).
 */
static void ebvh_split(const struct RTCBuildPrimitive *p, unsigned int dim, float pos,
                       struct RTCBounds *l, struct RTCBounds *r, void *user)
{
    (void)user;
    struct RTCBounds b = {p->lower_x, p->lower_y, p->lower_z, 0.0f,
                          p->upper_x, p->upper_y, p->upper_z, 0.0f};
    *l = b;
    *r = b;
    float *lu = dim == 0 ? &l->upper_x : dim == 1 ? &l->upper_y : &l->upper_z;
    float *rl = dim == 0 ? &r->lower_x : dim == 1 ? &r->lower_y : &r->lower_z;
    *lu = pos;
    *rl = pos;
}

static double box_area(const float *lo, const float *hi)
{
    double d[3];
    for (int k = 0; k < 3; k++)
        d[k] = hi[k] > lo[k] ? (double)hi[k] - lo[k] : 0.0;
    return 2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0]);
}

/* Same cost model as pf_bih_quality_measure: C_trav = C_isect = 1, over A(root). */
static double ebvh_sah(const ebvh_node *n, double area, double root_area, uint32_t *nodes)
{
    (*nodes)++;
    if (n->leaf)
        return (double)n->count * area / root_area;
    double cost = area / root_area;
    for (int i = 0; i < 2; i++)
        if (n->child[i])
            cost += ebvh_sah(n->child[i], box_area(n->clo[i], n->chi[i]), root_area, nodes);
    return cost;
}

/* Returns the SAH of Embree's binary BVH (quality q), or -1 when the build fails. */
static double embree_builder_sah(RTCDevice dev, const pf_scene_frame *f, enum RTCBuildQuality q,
                                 uint32_t *node_count, double *build_ms)
{
    size_t n = f->triangle_count;
    /* Spatial splits add references: Embree uses the spare capacity for them. */
    size_t capacity = q == RTC_BUILD_QUALITY_HIGH ? 2 * n : n;
    struct RTCBuildPrimitive *prims = malloc(capacity * sizeof *prims);
    if (!prims)
        return -1.0;
    for (size_t t = 0; t < n; t++) {
        float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < 3; k++) {
                lo[k] = fminf(lo[k], f->vertices[3 * t + c][k]);
                hi[k] = fmaxf(hi[k], f->vertices[3 * t + c][k]);
            }
        prims[t] = (struct RTCBuildPrimitive){lo[0], lo[1], lo[2], 0, hi[0], hi[1], hi[2],
                                              (unsigned int)t};
    }
    RTCBVH bvh = rtcNewBVH(dev);
    struct RTCBuildArguments a = rtcDefaultBuildArguments();
    a.byteSize = sizeof a;
    a.buildQuality = q;
    a.maxBranchingFactor = 2;
    a.maxDepth = PF_BIH_STACK_SIZE;
    a.minLeafSize = 1;
    a.maxLeafSize = PF_BIH_DEFAULT_LEAF_SIZE;
    a.traversalCost = 1.0f;
    a.intersectionCost = 1.0f;
    a.bvh = bvh;
    a.primitives = prims;
    a.primitiveCount = n;
    a.primitiveArrayCapacity = capacity;
    a.createNode = ebvh_create_node;
    a.setNodeChildren = ebvh_set_children;
    a.setNodeBounds = ebvh_set_bounds;
    a.createLeaf = ebvh_create_leaf;
    a.splitPrimitive = ebvh_split;
    double t0 = pf_time_ms();
    ebvh_node *root = rtcBuildBVH(&a);
    *build_ms = pf_time_ms() - t0;
    double sah = -1.0;
    *node_count = 0;
    if (root) {
        double ra = box_area(f->bounds_min, f->bounds_max);
        sah = ebvh_sah(root, ra, ra > 0.0 ? ra : 1.0, node_count);
    }
    rtcReleaseBVH(bvh);
    free(prims);
    return sah;
}

/* ---------- our CPU traversal (the GPU include's reference), same 2 threads ---------- */

typedef struct cpu_job {
    const pf_bih *bih;
    const pf_bih_wide *wide; /* NULL: packets */
    const pf_ray *rays;
    uint32_t first, count;
    int any_hit;
    pf_hit *hits;
    int failed;
} cpu_job;

/* Consecutive rays (neighbouring pixels, or their bounces) go in packets. */
static void *cpu_trace(void *arg)
{
    cpu_job *j = arg;
    pf_error err = {0};
    pf_status status =
        j->wide ? pf_bih_wide_trace_rays(j->bih, j->wide, &j->rays[j->first], j->count,
                                         j->any_hit, &j->hits[j->first], &err)
                : pf_bih_trace_cpu_rays(j->bih, &j->rays[j->first], j->count, j->any_hit,
                                        &j->hits[j->first], &err);
    if (status != PF_OK)
        j->failed = 1;
    return NULL;
}

/*
 * Separates the algorithm from the driver: the same traversal on the CPU with
 * BENCH_THREADS pthreads. Returns ms, or -1 when a ray overflowed the stack.
 */
static double cpu_cast_view(const pf_bih *bih, const pf_bih_wide *wide, const pf_ray *rays,
                            uint32_t count, int any_hit, pf_hit *hits)
{
    pthread_t th[BENCH_THREADS];
    cpu_job jobs[BENCH_THREADS];
    double t0 = pf_time_ms();
    uint32_t per = (count + BENCH_THREADS - 1) / BENCH_THREADS;
    for (int i = 0; i < BENCH_THREADS; i++) {
        uint32_t first = (uint32_t)i * per;
        jobs[i] = (cpu_job){bih, wide, rays, first,
                            first >= count ? 0 : (count - first < per ? count - first : per),
                            any_hit, hits, 0};
        pthread_create(&th[i], NULL, cpu_trace, &jobs[i]);
    }
    int failed = 0;
    for (int i = 0; i < BENCH_THREADS; i++) {
        pthread_join(th[i], NULL);
        failed |= jobs[i].failed;
    }
    double ms = pf_time_ms() - t0;
    return failed ? -1.0 : ms;
}

/* The packets (pf_bih_trace_cpu_rays). */
static double cpu_cast(const pf_bih *bih, const pf_ray *rays, uint32_t count, int any_hit,
                       pf_hit *hits)
{
    return cpu_cast_view(bih, NULL, rays, count, any_hit, hits);
}

/* ---------- comparison ---------- */

static double agreement(const pf_hit *a, const pf_hit *b, uint32_t count, int occluded)
{
    if (count == 0)
        return 1.0;
    uint32_t same = 0;
    for (uint32_t i = 0; i < count; i++) {
        int ha = a[i].triangle != PF_NO_HIT, hb = b[i].triangle != PF_NO_HIT;
        if (ha != hb)
            continue;
        if (!ha || occluded) {
            same++;
            continue;
        }
        double scale = fmax(fabs((double)a[i].t), fabs((double)b[i].t));
        if (fabs((double)a[i].t - (double)b[i].t) <= T_REL_TOLERANCE * scale)
            same++;
    }
    return (double)same / count;
}

/* One GPU cast: ms, or -1 on failure (message printed). */
static double gpu_cast(pf_bih_gpu *gpu, const pf_ray *rays, uint32_t count, int any_hit,
                       pf_hit *hits)
{
    pf_error err = {0};
    double t0 = pf_time_ms();
    if (pf_bih_raycast(gpu, rays, count, any_hit, hits, &err) != PF_OK) {
        fprintf(stderr, "bih_bench: pf_bih_raycast: %s\n", err.message);
        return -1.0;
    }
    return pf_time_ms() - t0;
}

/* Best-of-TIMING_REPEATS GPU cast; returns ms or -1 on failure (message printed). */
static double ours_cast(pf_bih_gpu *gpu, const pf_ray *rays, uint32_t count, int any_hit,
                        pf_hit *hits)
{
    double best = -1.0;
    for (int rep = 0; rep < TIMING_REPEATS; rep++) {
        double ms = gpu_cast(gpu, rays, count, any_hit, hits);
        if (ms < 0.0)
            return -1.0;
        if (best < 0.0 || ms < best)
            best = ms;
    }
    return best;
}

static double best_embree_cast(RTCScene scene, const pf_ray *rays, uint32_t count, int occluded,
                               pf_hit *hits)
{
    double best = -1.0;
    for (int rep = 0; rep < TIMING_REPEATS; rep++) {
        double ms = embree_cast(scene, rays, count, occluded, hits);
        if (best < 0.0 || ms < best)
            best = ms;
    }
    return best;
}

static double mrays(uint32_t count, double ms)
{
    return ms > 0.0 ? (double)count / (ms * 1e3) : 0.0;
}

/* Best-of-TIMING_REPEATS CPU cast (the packets, or the wide view if given); -1 on failure. */
static double best_cpu_cast(const pf_bih *bih, const pf_bih_wide *wide, const pf_ray *rays,
                            uint32_t count, int any_hit, pf_hit *hits)
{
    double best = -1.0;
    for (int rep = 0; rep < TIMING_REPEATS; rep++) {
        double ms = cpu_cast_view(bih, wide, rays, count, any_hit, hits);
        if (ms < 0.0)
            return -1.0;
        if (best < 0.0 || ms < best)
            best = ms;
    }
    return best;
}

/*
 * One ray type: GPU (pf_bih_raycast), our CPU traversals (the packets, and
 * the wide view one ray at a time) and Embree, with the agreement of the GPU
 * hits and of the wide view's against Embree's. Leaves the GPU hits in ours.
 */
static void report_rays(const char *kind, const char *tree, pf_bih_gpu *gpu, const pf_bih *bih,
                        const pf_bih_wide *wide, RTCScene hq, const pf_ray *rays, uint32_t count,
                        int any_hit, pf_hit *ours, pf_hit *theirs)
{
    double c_ms = best_cpu_cast(bih, NULL, rays, count, any_hit, theirs);
    double w_ms = best_cpu_cast(bih, wide, rays, count, any_hit, ours);
    double e_ms = best_embree_cast(hq, rays, count, any_hit, theirs);
    double wide_agree = agreement(ours, theirs, count, any_hit);
    double o_ms = ours_cast(gpu, rays, count, any_hit, ours);
    double agree = agreement(ours, theirs, count, any_hit);
    printf("rays    %-8s %-6s %7u rays: ours GPU %7.3f Mrays/s | ours CPU %7.3f | wide %7.3f | "
           "Embree %7.3f | GPU/Embree %.3fx | CPU/Embree %.3fx | wide/Embree %.3fx | agree %.4f "
           "(wide %.4f)\n",
           kind, tree, count, mrays(count, o_ms), mrays(count, c_ms), mrays(count, w_ms),
           mrays(count, e_ms), o_ms > 0 ? e_ms / o_ms : 0.0, c_ms > 0 ? e_ms / c_ms : 0.0,
           w_ms > 0 ? e_ms / w_ms : 0.0, agree, wide_agree);
}

/* Lanes llvmpipe runs a compute shader on at 256 bits: 8 consecutive invocations move together. */
#define SIMD_LANES 8u

/*
 * The work each ray costs in the traversal (pf_bih_trace_cpu_counted takes
 * the GLSL's steps): loop iterations (nodes entered), ray-triangle tests,
 * stack pops and the deepest stack; and how much of it a SIMD device wastes.
 * Consecutive rays share an 8-lane vector on lavapipe and the vector loops
 * until its slowest lane is done, so a group costs 8 × its largest count:
 * efficiency = sum of counts / (8 × sum of group maxima), 1 when all lanes
 * finish together.
 */
static void profile_rays(const char *kind, const pf_bih *bih, const pf_ray *rays, uint32_t count,
                         int any_hit)
{
    double steps = 0, tests = 0, pops = 0, stack = 0, step_max_sum = 0, test_max_sum = 0;
    uint32_t deepest = 0, group_steps = 0, group_tests = 0;
    for (uint32_t i = 0; i < count; i++) {
        pf_hit hit;
        pf_bih_trace_counts c;
        pf_error err = {0};
        if (pf_bih_trace_cpu_counted(bih, &rays[i], any_hit, &hit, &c, &err) != PF_OK)
            continue;
        uint32_t ray_steps = c.inner_nodes + c.leaves;
        steps += ray_steps;
        tests += c.triangle_tests;
        pops += c.pops;
        stack += c.max_stack;
        deepest = c.max_stack > deepest ? c.max_stack : deepest;
        group_steps = ray_steps > group_steps ? ray_steps : group_steps;
        group_tests = c.triangle_tests > group_tests ? c.triangle_tests : group_tests;
        if (i % SIMD_LANES == SIMD_LANES - 1 || i + 1 == count) {
            step_max_sum += (double)SIMD_LANES * group_steps;
            test_max_sum += (double)SIMD_LANES * group_tests;
            group_steps = group_tests = 0;
        }
    }
    double n = count ? (double)count : 1.0;
    printf("profile %-8s SAH    per ray: %6.1f nodes entered, %6.1f triangle tests, %5.1f pops, "
           "stack %4.1f (max %u) | %u-lane efficiency: nodes %.2f, tests %.2f\n",
           kind, steps / n, tests / n, pops / n, stack / n, deepest, SIMD_LANES,
           step_max_sum > 0 ? steps / step_max_sum : 1.0,
           test_max_sum > 0 ? tests / test_max_sum : 1.0);
}

static const char *build_path_name(pf_bih_build_path path)
{
    return path == PF_BIH_BUILT_ON_GPU         ? "on GPU"
           : path == PF_BIH_BUILT_SMALL_ON_CPU ? "small: CPU"
                                               : "too deep: CPU fallback";
}

/*
 * Best-of-TIMING_REPEATS CPU build with the given heuristic and threads; the
 * last tree goes to keep (or is freed when keep is NULL). -1 on failure.
 */
static double cpu_build_ms(const pf_scene_frame *f, uint32_t heuristic, uint32_t threads,
                           pf_bih *keep)
{
    pf_bih_build_options options = {0};
    options.heuristic = heuristic;
    options.thread_count = threads;
    /* $PF_BENCH_LEAF_SIZE: trees with other leaf sizes (0 or unset: the default, what the
     * renderer builds), to see what a device's traversal prefers. */
    const char *leaf_size = getenv("PF_BENCH_LEAF_SIZE");
    options.max_leaf_size = leaf_size ? (uint32_t)atoi(leaf_size) : 0;
    double best = -1.0;
    for (int rep = 0; rep < TIMING_REPEATS; rep++) {
        pf_bih b = {0};
        pf_error err = {0};
        double t0 = pf_time_ms();
        if (pf_bih_build_cpu(f, &options, &b, &err) != PF_OK) {
            fprintf(stderr, "bih_bench: pf_bih_build_cpu: %s\n", err.message);
            return -1.0;
        }
        double ms = pf_time_ms() - t0;
        if (best < 0.0 || ms < best)
            best = ms;
        if (keep && rep == TIMING_REPEATS - 1)
            *keep = b;
        else
            pf_bih_free(&b);
    }
    return best;
}

static int bench_mesh_run(const bench_mesh *m, pf_vk_context *ctx, RTCDevice dev,
                          pf_bih_gpu_builder *builder)
{
    const pf_scene_frame *f = &m->frame;
    uint32_t n = f->triangle_count;
    printf("\n=== %s: %u triangles ===\n", m->name, n);

    /* Our CPU builds, best of TIMING_REPEATS each: the global heuristic on 1 and
     * BENCH_THREADS threads, binned SAH + empty-space cuts on BENCH_THREADS. */
    pf_bih bih = {0}, sah_bih = {0};
    double build_1t_ms = cpu_build_ms(f, PF_BIH_HEURISTIC_GLOBAL, 1, NULL);
    double build_ms = cpu_build_ms(f, PF_BIH_HEURISTIC_GLOBAL, BENCH_THREADS, &bih);
    double sah_build_ms = cpu_build_ms(f, PF_BIH_HEURISTIC_SAH, BENCH_THREADS, &sah_bih);
    if (build_1t_ms < 0.0 || build_ms < 0.0 || sah_build_ms < 0.0) {
        pf_bih_free(&bih);
        pf_bih_free(&sah_bih);
        return 0;
    }
    pf_bih_quality q, sq;
    pf_bih_quality_measure(&bih, &q);
    pf_bih_quality_measure(&sah_bih, &sq);
    pf_error check_err = {0};
    if (pf_bih_check(&sah_bih, f, &check_err) != PF_OK)
        printf("check   SAH tree FAILS pf_bih_check: %s\n", check_err.message);

    /* The GPU build (Morton/LBVH-style), best of TIMING_REPEATS, upload and download included. */
    double gpu_build_ms = -1.0;
    pf_bih_quality gq = {0};
    pf_bih_gpu_build_report report = {0};
    for (int rep = 0; rep < TIMING_REPEATS; rep++) {
        pf_bih b = {0};
        pf_error err = {0};
        double t0 = pf_time_ms();
        if (pf_bih_build_gpu(builder, f, NULL, &b, &report, &err) != PF_OK) {
            fprintf(stderr, "bih_bench: %s: pf_bih_build_gpu: %s\n", m->name, err.message);
            gpu_build_ms = -1.0;
            break;
        }
        double ms = pf_time_ms() - t0;
        if (gpu_build_ms < 0.0 || ms < gpu_build_ms)
            gpu_build_ms = ms;
        if (rep == 0) {
            pf_bih_quality_measure(&b, &gq);
        }
        pf_bih_free(&b);
    }

    /* Embree builds. */
    uint32_t *indices = malloc((size_t)3 * n * sizeof *indices);
    if (!indices) {
        pf_bih_free(&bih);
        return 0;
    }
    for (uint32_t i = 0; i < 3 * n; i++)
        indices[i] = i;
    double low_ms = -1.0, high_ms = -1.0, ms;
    RTCScene hq = NULL;
    for (int rep = 0; rep < TIMING_REPEATS; rep++) {
        RTCScene s = embree_scene(dev, f, RTC_BUILD_QUALITY_LOW, indices, &ms);
        rtcReleaseScene(s);
        if (low_ms < 0.0 || ms < low_ms)
            low_ms = ms;
        s = embree_scene(dev, f, RTC_BUILD_QUALITY_HIGH, indices, &ms);
        if (high_ms < 0.0 || ms < high_ms)
            high_ms = ms;
        if (hq)
            rtcReleaseScene(hq);
        hq = s;
    }
    uint32_t e_nodes_hq = 0, e_nodes_med = 0;
    double e_hq_build_ms, e_med_build_ms;
    double e_sah_hq =
        embree_builder_sah(dev, f, RTC_BUILD_QUALITY_HIGH, &e_nodes_hq, &e_hq_build_ms);
    double e_sah_med =
        embree_builder_sah(dev, f, RTC_BUILD_QUALITY_MEDIUM, &e_nodes_med, &e_med_build_ms);

    printf("build   ours CPU global 1 thread  %9.2f ms  %7.2f Mtri/s   ours/Embree LOW %.2fx\n",
           build_1t_ms, mrays(n, build_1t_ms), build_1t_ms / low_ms);
    printf("build   ours CPU global %d threads %9.2f ms  %7.2f Mtri/s   ours/Embree LOW %.2fx\n",
           BENCH_THREADS, build_ms, mrays(n, build_ms), build_ms / low_ms);
    printf("build   ours CPU SAH %d threads    %9.2f ms  %7.2f Mtri/s   ours/Embree LOW %.2fx, "
           "/HIGH %.2fx\n",
           BENCH_THREADS, sah_build_ms, mrays(n, sah_build_ms), sah_build_ms / low_ms,
           sah_build_ms / high_ms);
    if (gpu_build_ms >= 0.0)
        printf("build   ours (GPU: %s) %9.2f ms  %7.2f Mtri/s   GPU/Embree LOW %.2fx\n",
               build_path_name(report.path), gpu_build_ms, mrays(n, gpu_build_ms),
               gpu_build_ms / low_ms);
    printf("build   Embree LOW (Morton)   %9.2f ms  %7.2f Mtri/s\n", low_ms, mrays(n, low_ms));
    printf("build   Embree HIGH (SBVH)    %9.2f ms  %7.2f Mtri/s\n", high_ms, mrays(n, high_ms));
    const pf_bih_quality *trees[2] = {&q, &sq};
    const pf_bih *bihs[2] = {&bih, &sah_bih};
    const char *tree_names[2] = {"global", "SAH"};
    for (int t = 0; t < 2; t++)
        printf("tree    ours %-6s: %u nodes (%u inner, %u leaves with triangles), %u B/node = "
               "%.2f MiB, depth %u, mean leaf %.2f\n",
               tree_names[t], bihs[t]->node_count, trees[t]->inner_count, trees[t]->leaf_count,
               trees[t]->bytes_per_node,
               (double)bihs[t]->node_count * trees[t]->bytes_per_node / 1048576.0,
               trees[t]->depth, trees[t]->mean_leaf_size);
    printf("SAH     ours global %.3f (clip planes only: %.3f) | ours SAH %.3f (clip only: %.3f) | "
           "ours GPU tree %.3f (clip only: %.3f, %u nodes)\n",
           q.sah_cost, q.clip_sah_cost, sq.sah_cost, sq.clip_sah_cost, gq.sah_cost,
           gq.clip_sah_cost, gq.inner_count + gq.leaf_count);
    printf("SAH     Embree rtcBuildBVH binary leaf<=%u: HIGH %.3f (%u nodes, %.1f ms), MEDIUM %.3f "
           "(%u nodes) | /Embree HIGH: global %.2fx (clip %.2fx), SAH %.2fx (clip %.2fx)\n",
           PF_BIH_DEFAULT_LEAF_SIZE, e_sah_hq, e_nodes_hq, e_hq_build_ms, e_sah_med, e_nodes_med,
           q.sah_cost / e_sah_hq, q.clip_sah_cost / e_sah_hq, sq.sah_cost / e_sah_hq,
           sq.clip_sah_cost / e_sah_hq);

    /* GPU copies of both trees. */
    pf_bih_gpu *gpus[2] = {NULL, NULL};
    pf_bih_wide wides[2] = {{0}, {0}};
    pf_error err = {0};
    int ok = 1;
    for (int t = 0; t < 2 && ok; t++)
        ok = pf_bih_gpu_create(ctx, &gpus[t], &err) == PF_OK &&
             pf_bih_gpu_upload(gpus[t], bihs[t], &err) == PF_OK &&
             pf_bih_wide_build(bihs[t], &wides[t], &err) == PF_OK;
    if (!ok)
        fprintf(stderr, "bih_bench: %s: GPU upload or wide view: %s\n", m->name, err.message);

    uint32_t np = BENCH_WIDTH * BENCH_HEIGHT;
    pf_ray *primary = malloc(np * sizeof *primary);
    pf_ray *shadow = malloc(np * sizeof *shadow);
    pf_ray *diffuse = malloc(np * sizeof *diffuse);
    pf_hit *ours = malloc(np * sizeof *ours);
    pf_hit *theirs = malloc(np * sizeof *theirs);
    if (ok && primary && shadow && diffuse && ours && theirs) {
        make_primary(f, primary);
        for (int t = 1; t >= 0; t--)
            report_rays("primary", tree_names[t], gpus[t], bihs[t], &wides[t], hq, primary, np, 0,
                        ours, theirs);
        uint32_t ns = make_secondary(m, primary, ours, np, shadow, diffuse);
        profile_rays("primary", &sah_bih, primary, np, 0);
        profile_rays("shadow", &sah_bih, shadow, ns, 1);
        profile_rays("diffuse", &sah_bih, diffuse, ns, 0);
        for (int t = 0; t < 2; t++)
            report_rays("shadow", tree_names[t], gpus[t], bihs[t], &wides[t], hq, shadow, ns, 1,
                        ours, theirs);
        for (int t = 0; t < 2; t++)
            report_rays("diffuse", tree_names[t], gpus[t], bihs[t], &wides[t], hq, diffuse, ns, 0,
                        ours, theirs);
    }
    free(primary);
    free(shadow);
    free(diffuse);
    free(ours);
    free(theirs);
    pf_bih_gpu_destroy(gpus[0]);
    pf_bih_gpu_destroy(gpus[1]);
    pf_bih_wide_free(&wides[0]);
    pf_bih_wide_free(&wides[1]);
    rtcReleaseScene(hq);
    free(indices);
    pf_bih_free(&bih);
    pf_bih_free(&sah_bih);
    fflush(stdout);
    return ok;
}

static int load_scene(const char *dir, const char *name, bench_mesh *m)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s/%s.gltf", dir, name, name);
    pf_scene *scene = NULL;
    pf_error err = {0};
    memset(m, 0, sizeof *m);
    if (pf_scene_load(path, &scene, &err) != PF_OK) {
        fprintf(stderr, "bih_bench: %s\n", err.message);
        return 0;
    }
    pf_status s = pf_scene_eval(scene, 0.0, &m->frame, &err);
    pf_scene_destroy(scene);
    if (s != PF_OK) {
        fprintf(stderr, "bih_bench: %s\n", err.message);
        return 0;
    }
    snprintf(m->name, sizeof m->name, "%s", name);
    pick_light(m);
    return 1;
}

static int name_cmp(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

static int compare_ms(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* "sphere-build": the builds alone, interleaved rounds, best and median. */
static int build_rounds(const bench_mesh *m, RTCDevice dev, pf_vk_context *ctx,
                        pf_bih_gpu_builder *builder)
{
    const pf_scene_frame *f = &m->frame;
    uint32_t n = f->triangle_count;
    unsigned *indices = malloc(3 * (size_t)n * sizeof *indices);
    if (!indices)
        return 0;
    for (uint32_t i = 0; i < 3 * n; i++)
        indices[i] = i;
    static const char *const names[4] = {"ours CPU global", "ours CPU SAH", "Embree LOW",
                                         "ours GPU"};
    double ms[4][BUILD_ROUNDS];
    pf_vk_traffic gpu_traffic = {0};
    int ok = 1;
    for (int round = 0; round < BUILD_ROUNDS && ok; round++) {
        for (uint32_t h = 0; h < 2 && ok; h++) {
            /* cpu_build_ms takes the best of TIMING_REPEATS; one build per round here. */
            pf_bih_build_options options = {0};
            options.heuristic = h ? PF_BIH_HEURISTIC_SAH : PF_BIH_HEURISTIC_GLOBAL;
            options.thread_count = BENCH_THREADS;
            pf_bih b = {0};
            pf_error err = {0};
            double t0 = pf_time_ms();
            ok = pf_bih_build_cpu(f, &options, &b, &err) == PF_OK;
            ms[h][round] = pf_time_ms() - t0;
            if (!ok)
                fprintf(stderr, "bih_bench: pf_bih_build_cpu: %s\n", err.message);
            pf_bih_free(&b);
        }
        if (ok)
            rtcReleaseScene(embree_scene(dev, f, RTC_BUILD_QUALITY_LOW, indices, &ms[2][round]));
        if (ok) { /* the device build, wall time: on lavapipe an upper bound on its overhead */
            pf_bih b = {0};
            pf_error err = {0};
            pf_vk_traffic before = pf_vk_traffic_of(ctx);
            double t0 = pf_time_ms();
            ok = pf_bih_build_gpu(builder, f, NULL, &b, NULL, &err) == PF_OK;
            ms[3][round] = pf_time_ms() - t0;
            gpu_traffic = pf_vk_traffic_since(ctx, before);
            if (!ok)
                fprintf(stderr, "bih_bench: pf_bih_build_gpu: %s\n", err.message);
            pf_bih_free(&b);
        }
    }
    free(indices);
    if (!ok)
        return 0;
    printf("\n=== %s: %u triangles, %d build rounds, %u threads ===\n", m->name, n,
           BUILD_ROUNDS, BENCH_THREADS);
    double best[4];
    for (int i = 0; i < 4; i++) {
        qsort(ms[i], BUILD_ROUNDS, sizeof ms[i][0], compare_ms);
        best[i] = ms[i][0];
        printf("build   %-16s best %8.2f ms  median %8.2f ms\n", names[i], ms[i][0],
               ms[i][BUILD_ROUNDS / 2]);
    }
    printf("build   ours global / Embree LOW: best %.2fx, median %.2fx\n", best[0] / best[2],
           ms[0][BUILD_ROUNDS / 2] / ms[2][BUILD_ROUNDS / 2]);
    printf("build   ours GPU / ours CPU SAH: best %.2fx, median %.2fx; a GPU build: %llu "
           "submission(s), %llu wait(s), %llu bytes read back\n",
           best[3] / best[1], ms[3][BUILD_ROUNDS / 2] / ms[1][BUILD_ROUNDS / 2],
           (unsigned long long)gpu_traffic.submits, (unsigned long long)gpu_traffic.host_waits,
           (unsigned long long)gpu_traffic.readback_bytes);
    return 1;
}

/*
 * "cpu" / "gpu": our CPU traversal (ctx NULL) or the device's (pf_bih_raycast)
 * of the SAH tree against Embree HIGH, interleaved rounds.
 */
static int traversal_rounds(const bench_mesh *m, RTCDevice dev, pf_vk_context *ctx)
{
    const pf_scene_frame *f = &m->frame;
    uint32_t n = f->triangle_count, np = BENCH_WIDTH * BENCH_HEIGHT;
    pf_bih sah = {0};
    unsigned *indices = malloc(3 * (size_t)n * sizeof *indices);
    pf_ray *rays[3] = {malloc(np * sizeof(pf_ray)), malloc(np * sizeof(pf_ray)),
                       malloc(np * sizeof(pf_ray))};
    pf_hit *hits = malloc(np * sizeof *hits);
    int ok = indices && rays[0] && rays[1] && rays[2] && hits &&
             cpu_build_ms(f, PF_BIH_HEURISTIC_SAH, BENCH_THREADS, &sah) >= 0.0;
    RTCScene hq = NULL;
    uint32_t counts[3] = {np, 0, 0};
    if (ok) {
        for (uint32_t i = 0; i < 3 * n; i++)
            indices[i] = i;
        double ms;
        hq = embree_scene(dev, f, RTC_BUILD_QUALITY_HIGH, indices, &ms);
        make_primary(f, rays[0]);
        ok = cpu_cast(&sah, rays[0], np, 0, hits) >= 0.0;
        counts[1] = counts[2] = make_secondary(m, rays[0], hits, np, rays[1], rays[2]);
    }
    pf_bih_gpu *gpu = NULL;
    if (ok && ctx) {
        pf_error err = {0};
        ok = pf_bih_gpu_create(ctx, &gpu, &err) == PF_OK &&
             pf_bih_gpu_upload(gpu, &sah, &err) == PF_OK;
        if (!ok)
            fprintf(stderr, "bih_bench: %s\n", err.message);
        /* Both pipelines (closest and any hit) compiled before the rounds. */
        ok = ok && gpu_cast(gpu, rays[0], np, 0, hits) >= 0.0 &&
             gpu_cast(gpu, rays[1], counts[1], 1, hits) >= 0.0;
    }
    /* In "cpu" mode also the wide view, one ray at a time (pf_bih_wide). */
    pf_bih_wide wide = {0};
    double wide_build_ms = -1.0;
    if (ok && !ctx) {
        pf_error err = {0};
        double t0 = pf_time_ms();
        ok = pf_bih_wide_build(&sah, &wide, &err) == PF_OK;
        wide_build_ms = pf_time_ms() - t0;
        if (!ok)
            fprintf(stderr, "bih_bench: %s\n", err.message);
    }
    const char *what = ctx ? "gpu" : "cpu";
    static const char *const kinds[3] = {"primary", "shadow", "diffuse"};
    double ours[3][CPU_ROUNDS], theirs[3][CPU_ROUNDS], wide_ms[3][CPU_ROUNDS];
    for (int round = 0; round < CPU_ROUNDS && ok; round++)
        for (int k = 0; k < 3 && ok; k++) {
            ours[k][round] = ctx ? gpu_cast(gpu, rays[k], counts[k], k == 1, hits)
                                 : cpu_cast(&sah, rays[k], counts[k], k == 1, hits);
            theirs[k][round] = embree_cast(hq, rays[k], counts[k], k == 1, hits);
            wide_ms[k][round] =
                ctx ? 0.0 : cpu_cast_view(&sah, &wide, rays[k], counts[k], k == 1, hits);
            ok = ours[k][round] >= 0.0 && wide_ms[k][round] >= 0.0;
        }
    if (ok) {
        printf("\n=== %s: %u triangles, SAH tree, %d rounds, %d threads each ===\n", m->name, n,
               CPU_ROUNDS, BENCH_THREADS);
        for (int k = 0; k < 3; k++) {
            qsort(ours[k], CPU_ROUNDS, sizeof ours[k][0], compare_ms);
            qsort(theirs[k], CPU_ROUNDS, sizeof theirs[k][0], compare_ms);
            double our_median = ours[k][CPU_ROUNDS / 2], their_median = theirs[k][CPU_ROUNDS / 2];
            printf("%s     %-8s ours best %7.3f median %7.3f Mrays/s | Embree best %7.3f median "
                   "%7.3f | %s/Embree median %.3fx\n",
                   what, kinds[k], mrays(counts[k], ours[k][0]), mrays(counts[k], our_median),
                   mrays(counts[k], theirs[k][0]), mrays(counts[k], their_median),
                   ctx ? "GPU" : "CPU", their_median / our_median);
        }
        for (int k = 0; k < 3 && !ctx; k++) {
            qsort(wide_ms[k], CPU_ROUNDS, sizeof wide_ms[k][0], compare_ms);
            double median = wide_ms[k][CPU_ROUNDS / 2];
            printf("cpu-wide %-8s ours best %7.3f median %7.3f Mrays/s | wide/Embree median "
                   "%.3fx%s\n",
                   kinds[k], mrays(counts[k], wide_ms[k][0]), mrays(counts[k], median),
                   theirs[k][CPU_ROUNDS / 2] / median,
                   pf_bih_wide_available() ? "" : " (no AVX2: the packets)");
        }
        if (!ctx)
            printf("cpu-wide view: %u nodes from %u, %u blocks of 4 triangles, built in %.2f ms\n",
                   wide.node_count, sah.node_count, wide.block_count, wide_build_ms);
    }
    pf_bih_wide_free(&wide);
    if (hq)
        rtcReleaseScene(hq);
    pf_bih_gpu_destroy(gpu);
    pf_bih_free(&sah);
    free(indices);
    free(rays[0]);
    free(rays[1]);
    free(rays[2]);
    free(hits);
    return ok;
}

int main(int argc, char **argv)
{
    const char *dir = argc > 1 ? argv[1] : getenv("PF_SHARED_SCENES");
    const char *only = argc > 2 ? argv[2] : NULL;
    int cpu_only = argc > 3 && strcmp(argv[3], "cpu") == 0;
    int gpu_only = argc > 3 && strcmp(argv[3], "gpu") == 0;
    int rounds_only = cpu_only || gpu_only;
    if (!dir) {
        fprintf(stderr, "usage: bih_bench [scenes_dir [only]] (or set PF_SHARED_SCENES)\n");
        return 2;
    }
    pf_vk_context *ctx = NULL;
    pf_error err = {0};
    pf_vk_options vo = {NULL, 0};
    if (pf_vk_create(&vo, &ctx, &err) != PF_OK) {
        fprintf(stderr, "bih_bench: %s\n", err.message);
        return 1;
    }
    pf_vk_context *rounds_ctx = gpu_only ? ctx : NULL; /* traversal_rounds': the device's */
    RTCDevice dev = rtcNewDevice("threads=2");
    if (!dev) {
        fprintf(stderr, "bih_bench: rtcNewDevice failed (error %d)\n",
                (int)rtcGetDeviceError(NULL));
        pf_vk_destroy(ctx);
        return 1;
    }
    printf("bih_bench: device %s, Embree %s, %u threads each, primary %ux%u, timings best of %d\n",
           pf_vk_info(ctx)->name, RTC_VERSION_STRING, BENCH_THREADS, BENCH_WIDTH, BENCH_HEIGHT,
           TIMING_REPEATS);

    /* Scene directories in name order, so runs print in the same order. */
    char *names[256];
    int count = 0;
    DIR *d = opendir(dir);
    if (!d) {
        fprintf(stderr, "bih_bench: cannot open %s\n", dir);
    } else {
        struct dirent *e;
        while ((e = readdir(d)) && count < 256) {
            if (e->d_name[0] == '.' || (only && strcmp(only, e->d_name) != 0))
                continue;
            char path[1024];
            snprintf(path, sizeof path, "%s/%s/%s.gltf", dir, e->d_name, e->d_name);
            FILE *probe = fopen(path, "rb");
            if (!probe)
                continue;
            fclose(probe);
            names[count++] = strdup(e->d_name);
        }
        closedir(d);
    }
    qsort(names, (size_t)count, sizeof names[0], name_cmp);

    pf_bih_gpu_builder *builder = NULL;
    if (pf_bih_gpu_builder_create(ctx, &builder, &err) != PF_OK) {
        fprintf(stderr, "bih_bench: %s\n", err.message);
        rtcReleaseDevice(dev);
        pf_vk_destroy(ctx);
        return 1;
    }
    int failures = 0;
    for (int i = 0; i < count; i++) {
        bench_mesh m;
        if (load_scene(dir, names[i], &m)) {
            failures += rounds_only ? !traversal_rounds(&m, dev, rounds_ctx)
                                    : !bench_mesh_run(&m, ctx, dev, builder);
            mesh_free(&m);
        } else {
            failures++;
        }
        free(names[i]);
    }
    bench_mesh sphere;
    if (only && !strcmp(only, "sphere-build")) {
        if (make_sphere(&sphere)) {
            failures += !build_rounds(&sphere, dev, ctx, builder);
            mesh_free(&sphere);
        } else {
            failures++;
        }
    } else if (only && strcmp(only, "sphere") != 0) {
        /* one shared scene asked for: no generated mesh */
    } else if (make_sphere(&sphere)) {
        failures += rounds_only ? !traversal_rounds(&sphere, dev, rounds_ctx)
                                : !bench_mesh_run(&sphere, ctx, dev, builder);
        mesh_free(&sphere);
    } else {
        failures++;
    }
    pf_bih_gpu_builder_destroy(builder);
    rtcReleaseDevice(dev);
    pf_vk_destroy(ctx);
    return failures ? 1 : 0;
}
