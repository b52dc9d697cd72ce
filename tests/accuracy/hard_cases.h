/*
 * The hard cases of accuracy (issue 16), built by hand so that tests/accuracy
 * and bench/accuracy render exactly the same scenes:
 *
 *   water          a floor under a closed dielectric (η 1.8), a directional
 *                  light at 30°: closed form in test_water_slab.c
 *   lamp-wall      an emitting panel whose edge touches a wall (gather rays
 *                  meet the wall next to the emitter)
 *   lamps-glass    two small emitters inside glass spheres over a table
 *                  (after Veach's bidirectional test scene)
 *   small-light    a 2 cm emitter of high radiance in a closed room
 *   indirect-only  a room whose light shines behind a partition: all the
 *                  camera sees is lit by bounced light
 *   grazing        an area light 4 cm above a plane, 5 m away: light
 *                  arrives at 80–89° from the normal
 *   thin-wall      a 2 mm wall on an open floor between a lit half (a lamp
 *                  hangs over it) and a dark half; the camera above sees both
 *
 * Every case but water converges under the reference path tracer (its
 * lights are small but not tiny, never punctual behind glass), so the
 * reference at a high sample count is its converged answer.
 */
#ifndef HARD_CASES_H
#define HARD_CASES_H

#include "../render/reference_test_util.h"

typedef enum hard_case {
    HARD_WATER = 0,
    HARD_LAMP_WALL,
    HARD_LAMPS_GLASS,
    HARD_SMALL_LIGHT,
    HARD_INDIRECT_ONLY,
    HARD_GRAZING,
    HARD_THIN_WALL,
    HARD_CASE_COUNT
} hard_case;

const char *hard_case_name(hard_case which);
/* Builds the case into scene (ref_scene_init'ed here; ref_scene_free when done). */
void hard_case_build(hard_case which, ref_scene *scene);

/* The water case's material and light, for its closed form. */
#define HARD_WATER_ETA 1.8
#define HARD_WATER_ALBEDO 0.5
#define HARD_WATER_IRRADIANCE 3.0
#define HARD_WATER_THETA_DEG 30.0
/* The water case's dielectric box spans y in [HARD_WATER_MIN_Y, HARD_WATER_MAX_Y]; the floor is y = 0. */
#define HARD_WATER_MIN_Y (-0.05f)
#define HARD_WATER_MAX_Y 0.02f
/* A floating slab instead (test_water_slab.c's second case). */
void hard_case_build_water(ref_scene *scene, float min_y, float max_y);

/* thin-wall: the wall's plane; floor left of it (x < HARD_THIN_WALL_X) is the dark room. */
#define HARD_THIN_WALL_X (-0.4f)

#endif
