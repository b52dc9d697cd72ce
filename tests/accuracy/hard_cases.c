/* The hard cases of accuracy (hard_cases.h). */
#include "hard_cases.h"

#include <math.h>

static const char *const names[HARD_CASE_COUNT] = {
    "water", "lamp-wall", "lamps-glass", "small-light", "indirect-only", "grazing", "thin-wall"};

const char *hard_case_name(hard_case which)
{
    return (unsigned)which < HARD_CASE_COUNT ? names[which] : "unknown";
}

static uint32_t lambert(ref_scene *scene, float r, float g, float b)
{
    return ref_scene_add_material(scene, ref_material(PF_MATERIAL_LAMBERT, r, g, b));
}

void hard_case_build_water(ref_scene *scene, float min_y, float max_y)
{
    const double pi = acos(-1.0);
    const float half = 2.0f; /* 2 m wide against 7 cm deep */
    ref_scene_init(scene);
    uint32_t floor_material =
        lambert(scene, HARD_WATER_ALBEDO, HARD_WATER_ALBEDO, HARD_WATER_ALBEDO);
    pf_material glass = ref_material(PF_MATERIAL_GLASS, 1, 1, 1);
    glass.ior = (float)HARD_WATER_ETA;
    uint32_t water = ref_scene_add_material(scene, glass);
    const float centre[3] = {0, 0, 0}, u[3] = {0, 0, half}, v[3] = {half, 0, 0};
    ref_scene_add_quad(scene, centre, u, v, floor_material); /* u × v = +y */
    const float lo[3] = {-half, min_y, -half}, hi[3] = {half, max_y, half};
    ref_scene_add_box(scene, lo, hi, 0, water);
    double theta = HARD_WATER_THETA_DEG * pi / 180.0;
    const float e = (float)HARD_WATER_IRRADIANCE;
    pf_light sun = {{0, 0, 0}, PF_LIGHT_DIRECTIONAL, {(float)sin(theta), (float)-cos(theta), 0},
                    0, {e, e, e}, 1, 1};
    ref_scene_add_light(scene, sun);
    const float eye[3] = {0, 1, 0}, target[3] = {0, 0, 0}, up[3] = {0, 0, -1};
    ref_scene_look_at(scene, eye, target, up, 0.35f);
}

static void build_lamp_wall(ref_scene *scene)
{
    ref_scene_init(scene);
    uint32_t white = lambert(scene, 0.7f, 0.7f, 0.7f);
    uint32_t lamp = ref_scene_add_material(scene, ref_material_emitter(20.0f, 20.0f, 20.0f));
    const float lo[3] = {-1, 0, -1}, hi[3] = {1, 2, 1};
    ref_scene_add_box(scene, lo, hi, 1, white);
    /* A panel facing down, its edge against the wall x = -1. */
    const float c[3] = {-0.8f, 1.5f, 0}, u[3] = {0, 0, 0.2f}, v[3] = {0.2f, 0, 0};
    ref_scene_add_quad(scene, c, v, u, lamp);
    const float eye[3] = {0.5f, 1.0f, 0.9f}, target[3] = {0.3f, 0, 0}, up[3] = {0, 1, 0};
    ref_scene_look_at(scene, eye, target, up, 0.6f);
}

static void build_lamps_glass(ref_scene *scene)
{
    ref_scene_init(scene);
    uint32_t white = lambert(scene, 0.7f, 0.7f, 0.7f);
    uint32_t wood = lambert(scene, 0.6f, 0.4f, 0.25f);
    uint32_t glass = ref_scene_add_material(scene, ref_material(PF_MATERIAL_GLASS, 1, 1, 1));
    uint32_t lamp = ref_scene_add_material(scene, ref_material_emitter(40.0f, 36.0f, 30.0f));
    const float room_lo[3] = {-2, 0, -2}, room_hi[3] = {2, 2.5f, 2};
    ref_scene_add_box(scene, room_lo, room_hi, 1, white);
    const float table_lo[3] = {-1, 0, -0.6f}, table_hi[3] = {1, 0.7f, 0.6f};
    ref_scene_add_box(scene, table_lo, table_hi, 0, wood);
    /* Emitters off the glass spheres' centres: the glass bends their light into caustics. */
    const float glass_centre[2][3] = {{-0.5f, 1.0f, 0.0f}, {0.5f, 1.0f, 0.0f}};
    const float lamp_centre[2][3] = {{-0.47f, 1.05f, 0.0f}, {0.53f, 1.05f, 0.02f}};
    for (int i = 0; i < 2; i++) {
        ref_scene_add_sphere(scene, glass_centre[i], 0.15f, 24, 12, 0, glass);
        ref_scene_add_sphere(scene, lamp_centre[i], 0.05f, 12, 6, 0, lamp);
    }
    const float eye[3] = {0, 1.3f, 1.9f}, target[3] = {0, 0.8f, 0}, up[3] = {0, 1, 0};
    ref_scene_look_at(scene, eye, target, up, 1.0f);
}

static void build_small_light(ref_scene *scene)
{
    ref_scene_init(scene);
    uint32_t white = lambert(scene, 0.7f, 0.7f, 0.7f);
    uint32_t blue = lambert(scene, 0.2f, 0.3f, 0.6f);
    /* 2 cm × 2 cm of radiance 5000: 6.3 W, as bright per area as a bare bulb. */
    uint32_t lamp = ref_scene_add_material(scene, ref_material_emitter(5000, 5000, 5000));
    const float lo[3] = {-1, 0, -1}, hi[3] = {1, 2, 1};
    ref_scene_add_box(scene, lo, hi, 1, white);
    const float block_lo[3] = {-0.3f, 0, -0.3f}, block_hi[3] = {0.2f, 0.5f, 0.2f};
    ref_scene_add_box(scene, block_lo, block_hi, 0, blue);
    const float c[3] = {0.1f, 1.5f, 0.1f}, u[3] = {0, 0, 0.01f}, v[3] = {0.01f, 0, 0};
    ref_scene_add_quad(scene, c, v, u, lamp); /* v × u = -y: facing down */
    const float eye[3] = {0.2f, 1.2f, 0.95f}, target[3] = {0, 0.3f, 0}, up[3] = {0, 1, 0};
    ref_scene_look_at(scene, eye, target, up, 1.2f);
}

static void build_indirect_only(ref_scene *scene)
{
    ref_scene_init(scene);
    uint32_t white = lambert(scene, 0.75f, 0.75f, 0.75f);
    uint32_t red = lambert(scene, 0.7f, 0.15f, 0.1f);
    uint32_t lamp = ref_scene_add_material(scene, ref_material_emitter(30, 30, 30));
    const float lo[3] = {-2, 0, -1}, hi[3] = {2, 2, 1};
    ref_scene_add_box(scene, lo, hi, 1, white);
    /* A partition 1.6 m high at x = 0; the lamp left of it faces the ceiling. */
    const float wall_lo[3] = {-0.05f, 0, -1}, wall_hi[3] = {0.05f, 1.6f, 1};
    ref_scene_add_box(scene, wall_lo, wall_hi, 0, red);
    const float c[3] = {-1.0f, 1.0f, 0}, u[3] = {0.15f, 0, 0}, v[3] = {0, 0, 0.15f};
    ref_scene_add_quad(scene, c, v, u, lamp); /* v × u = +y: facing up */
    /* The camera sees the floor and lower walls right of the partition: no direct light. */
    const float eye[3] = {1.9f, 1.0f, 0.9f}, target[3] = {0.6f, 0.2f, -0.3f}, up[3] = {0, 1, 0};
    ref_scene_look_at(scene, eye, target, up, 0.9f);
}

static void build_grazing(ref_scene *scene)
{
    ref_scene_init(scene);
    uint32_t white = lambert(scene, 0.8f, 0.8f, 0.8f);
    uint32_t lamp = ref_scene_add_material(scene, ref_material_emitter(50, 50, 50));
    const float centre[3] = {0.5f, 0, 0}, u[3] = {0, 0, 1.0f}, v[3] = {3.0f, 0, 0};
    ref_scene_add_quad(scene, centre, u, v, white); /* u × v = +y */
    /* A strip 1 m wide, 2–6 cm above the floor, facing +x along it. */
    const float c[3] = {-2.4f, 0.04f, 0}, lu[3] = {0, 0.02f, 0}, lv[3] = {0, 0, 0.5f};
    ref_scene_add_quad(scene, c, lu, lv, lamp); /* lu × lv = +x */
    const float eye[3] = {0.5f, 2.0f, 0.01f}, target[3] = {0.5f, 0, 0}, up[3] = {0, 0, -1};
    ref_scene_look_at(scene, eye, target, up, 0.9f);
}

static void build_thin_wall(ref_scene *scene)
{
    ref_scene_init(scene);
    uint32_t white = lambert(scene, 0.7f, 0.7f, 0.7f);
    uint32_t lamp = ref_scene_add_material(scene, ref_material_emitter(20, 20, 20));
    const float centre[3] = {0, 0, 0}, u[3] = {0, 0, 1.0f}, v[3] = {2.0f, 0, 0};
    ref_scene_add_quad(scene, centre, u, v, white);
    const float wall_lo[3] = {HARD_THIN_WALL_X - 0.002f, 0, -1},
                wall_hi[3] = {HARD_THIN_WALL_X, 1.0f, 1};
    ref_scene_add_box(scene, wall_lo, wall_hi, 0, white);
    const float c[3] = {0.6f, 0.6f, 0}, lu[3] = {0.15f, 0, 0}, lv[3] = {0, 0, 0.15f};
    ref_scene_add_quad(scene, c, lu, lv, lamp); /* lu × lv = -y: facing down */
    const float eye[3] = {0, 3.0f, 0.01f}, target[3] = {0, 0, 0}, up[3] = {0, 0, -1};
    ref_scene_look_at(scene, eye, target, up, 0.9f);
}

void hard_case_build(hard_case which, ref_scene *scene)
{
    switch (which) {
    case HARD_WATER:
        hard_case_build_water(scene, HARD_WATER_MIN_Y, HARD_WATER_MAX_Y);
        break;
    case HARD_LAMP_WALL:
        build_lamp_wall(scene);
        break;
    case HARD_LAMPS_GLASS:
        build_lamps_glass(scene);
        break;
    case HARD_SMALL_LIGHT:
        build_small_light(scene);
        break;
    case HARD_INDIRECT_ONLY:
        build_indirect_only(scene);
        break;
    case HARD_GRAZING:
        build_grazing(scene);
        break;
    default:
        build_thin_wall(scene);
        break;
    }
}
