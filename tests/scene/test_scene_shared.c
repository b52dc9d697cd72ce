/* The shared scenes ($PF_SHARED_SCENES) load with the values their files state,
 * every frame of the animated ones evaluates to finite data, and one scene can
 * be evaluated from two threads at once. */
#include "pf_scene.h"
#include "pf_test.h"

#include <math.h>
#include <pthread.h>
#include <string.h>

static pf_scene *load_shared(const char *name)
{
    char path[1024];
    pf_scene *scene = NULL;
    pf_error err = {0};
    pf_status status = pf_scene_load(pf_test_shared_scene(name, path, sizeof path), &scene, &err);
    PF_CHECK_MSG(status == PF_OK, "%s: %s", name, err.message);
    return status == PF_OK ? scene : NULL;
}

static int frame_is_finite(const pf_scene_frame *frame)
{
    for (size_t k = 0; k < 3 * (size_t)frame->triangle_count; k++)
        for (int c = 0; c < 4; c++)
            if (!isfinite(frame->vertices[k][c]) || !isfinite(frame->normals[k][c]))
                return 0;
    for (uint32_t k = 0; k < frame->light_count; k++)
        for (int c = 0; c < 3; c++)
            if (!isfinite(frame->lights[k].position[c]) || !isfinite(frame->lights[k].direction[c]))
                return 0;
    const pf_camera *camera = &frame->camera;
    for (int c = 0; c < 3; c++)
        if (!isfinite(camera->position[c]) || !isfinite(camera->forward[c]) ||
            !isfinite(camera->up[c]) || !isfinite(camera->right[c]))
            return 0;
    return isfinite(frame->bounds_min[0]) && isfinite(frame->bounds_max[2]);
}

/* Every frame 1..frame_count evaluates, finite, with the constant triangle count. */
static void check_all_frames(const pf_scene *scene)
{
    const pf_scene_info *info = pf_scene_get_info(scene);
    for (int64_t f = 1; f <= info->frame_count; f++) {
        pf_scene_frame frame;
        pf_error err;
        PF_CHECK_OK(pf_scene_eval(scene, pf_scene_frame_time(scene, f), &frame, &err), &err);
        PF_CHECK_MSG(frame_is_finite(&frame), "%s frame %lld not finite", info->path,
                     (long long)f);
        PF_CHECK(frame.triangle_count == info->triangle_count);
        pf_scene_frame_free(&frame);
    }
}

/* Index of the first material with nonzero emission, or -1. */
static int emissive_material(const pf_scene_frame *frame)
{
    for (uint32_t k = 0; k < frame->material_count; k++)
        if (frame->materials[k].emission[0] > 0)
            return (int)k;
    return -1;
}

PF_TEST(cornell_box)
{
    pf_scene *scene = load_shared("cornell-box");
    PF_REQUIRE(scene);
    const pf_scene_info *info = pf_scene_get_info(scene);
    PF_CHECK(info->triangle_count > 0 && info->has_camera && info->has_emissive);
    PF_CHECK(info->emissive_triangle_count == 2);
    PF_CHECK(info->frame_count == 1 && !info->geometry_animated);
    pf_scene_frame frame;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0, &frame, &err), &err);
    int light = emissive_material(&frame);
    PF_REQUIRE(light >= 0);
    /* emissiveFactor (1, 0.70588, 0.23529) × emissiveStrength 17 */
    PF_CHECK_NEAR(frame.materials[light].emission[0], 17, 1e-3);
    PF_CHECK_NEAR(frame.materials[light].emission[1], 12, 1e-3);
    PF_CHECK_NEAR(frame.materials[light].emission[2], 4, 1e-3);
    PF_CHECK_NEAR(frame.camera.yfov, 0.34033920413889424, 1e-6);
    PF_CHECK_NEAR(frame.camera.position[2], 6.8, 1e-6);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

PF_TEST(cornell_anim)
{
    pf_scene *scene = load_shared("cornell-anim");
    PF_REQUIRE(scene);
    const pf_scene_info *info = pf_scene_get_info(scene);
    PF_CHECK(info->frame_count == 48);
    PF_CHECK_NEAR(info->fps, 24, 0);
    PF_CHECK(info->geometry_animated == 1);
    PF_CHECK(info->camera_animated == 1);
    PF_CHECK(info->lights_animated == 0);
    PF_CHECK(info->has_specular == 1); /* glass sphere */
    PF_CHECK(info->animation_count == 1);
    pf_scene_frame first, last;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_eval(scene, pf_scene_frame_time(scene, 1), &first, &err), &err);
    PF_REQUIRE_OK(pf_scene_eval(scene, pf_scene_frame_time(scene, 48), &last, &err), &err);
    int light = emissive_material(&first);
    PF_REQUIRE(light >= 0);
    PF_CHECK_NEAR(first.materials[light].emission[0], 17, 1e-3);
    PF_CHECK_NEAR(first.materials[light].emission[1], 12, 1e-3);
    PF_CHECK_NEAR(first.materials[light].emission[2], 4, 1e-3);
    /* The tall box (node 6) turns: its vertices move; the floor (node 0) does not. */
    int tall_box_moved = 0, floor_moved = 0;
    for (uint32_t t = 0; t < first.triangle_count; t++)
        for (int c = 0; c < 3; c++) {
            float dx = first.vertices[3 * t + c][0] - last.vertices[3 * t + c][0];
            float dz = first.vertices[3 * t + c][2] - last.vertices[3 * t + c][2];
            int moved = fabsf(dx) > 1e-3f || fabsf(dz) > 1e-3f;
            if (first.triangle_node[t] == 6)
                tall_box_moved |= moved;
            if (first.triangle_node[t] == 0)
                floor_moved |= moved;
        }
    PF_CHECK(tall_box_moved);
    PF_CHECK(!floor_moved);
    /* The camera dollies 0.4 m. */
    float dolly = 0;
    for (int c = 0; c < 3; c++)
        dolly += powf(first.camera.position[c] - last.camera.position[c], 2);
    PF_CHECK_NEAR(sqrtf(dolly), 0.4, 0.01);
    pf_scene_frame_free(&first);
    pf_scene_frame_free(&last);
    check_all_frames(scene);
    pf_scene_destroy(scene);
}

PF_TEST(caustic_anim)
{
    pf_scene *scene = load_shared("caustic-anim");
    PF_REQUIRE(scene);
    const pf_scene_info *info = pf_scene_get_info(scene);
    PF_CHECK(info->light_count == 1);
    PF_CHECK(info->lights_animated == 1);
    PF_CHECK(info->geometry_animated == 0);
    PF_CHECK(info->has_specular == 1);
    PF_CHECK(info->frame_count == 48);
    pf_scene_frame frame;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0, &frame, &err), &err);
    PF_REQUIRE(frame.light_count == 1);
    PF_CHECK(frame.lights[0].kind == PF_LIGHT_POINT);
    for (int c = 0; c < 3; c++)
        PF_CHECK_NEAR(frame.lights[0].intensity[c], 8, 1e-5);
    PF_CHECK_NEAR(frame.camera.aspect, 1.7778, 1e-4);
    PF_CHECK_NEAR(frame.camera.yfov, 0.6109, 1e-4);
    int glass = 0, mirror = 0;
    for (uint32_t k = 0; k < frame.material_count; k++) {
        glass |= frame.materials[k].kind == PF_MATERIAL_GLASS;
        mirror |= frame.materials[k].kind == PF_MATERIAL_MIRROR;
    }
    PF_CHECK(glass && mirror);
    pf_scene_frame_free(&frame);
    check_all_frames(scene);
    pf_scene_destroy(scene);
}

PF_TEST(staircase2)
{
    pf_scene *scene = load_shared("staircase2");
    PF_REQUIRE(scene);
    const pf_scene_info *info = pf_scene_get_info(scene);
    PF_CHECK(info->triangle_count > 1000);
    PF_CHECK(info->has_emissive && info->has_specular && info->has_camera);
    check_all_frames(scene);
    pf_scene_destroy(scene);
}

typedef struct eval_job {
    const pf_scene *scene;
    double time;
    int repeats;
    pf_scene_frame frame;
    int ok;
} eval_job;

static void *eval_thread(void *argument)
{
    eval_job *job = argument;
    job->ok = 1;
    for (int k = 0; k < job->repeats; k++) {
        pf_error err;
        pf_scene_frame_free(&job->frame);
        job->ok &= pf_scene_eval(job->scene, job->time, &job->frame, &err) == PF_OK;
    }
    return NULL;
}

PF_TEST(two_threads_evaluate_concurrently)
{
    pf_scene *scene = load_shared("cornell-anim");
    PF_REQUIRE(scene);
    eval_job jobs[2] = {{.scene = scene, .time = 0.3, .repeats = 20},
                        {.scene = scene, .time = 1.7, .repeats = 20}};
    pthread_t threads[2];
    for (int k = 0; k < 2; k++)
        PF_CHECK(pthread_create(&threads[k], NULL, eval_thread, &jobs[k]) == 0);
    for (int k = 0; k < 2; k++)
        pthread_join(threads[k], NULL);
    for (int k = 0; k < 2; k++) {
        PF_CHECK(jobs[k].ok);
        pf_scene_frame alone;
        pf_error err;
        PF_REQUIRE_OK(pf_scene_eval(scene, jobs[k].time, &alone, &err), &err);
        PF_CHECK(alone.triangle_count == jobs[k].frame.triangle_count);
        PF_CHECK(memcmp(alone.vertices, jobs[k].frame.vertices,
                        3 * (size_t)alone.triangle_count * sizeof *alone.vertices) == 0);
        PF_CHECK(memcmp(&alone.camera, &jobs[k].frame.camera, sizeof alone.camera) == 0);
        pf_scene_frame_free(&alone);
        pf_scene_frame_free(&jobs[k].frame);
    }
    pf_scene_destroy(scene);
}

int main(void)
{
    pf_log_set_level(PF_LOG_ERROR);
    PF_RUN(cornell_box);
    PF_RUN(cornell_anim);
    PF_RUN(caustic_anim);
    PF_RUN(staircase2);
    PF_RUN(two_threads_evaluate_concurrently);
    return pf_test_finish();
}
