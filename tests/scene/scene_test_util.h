/*
 * Helpers for the scene tests: each test writes the small glTF/OBJ files it
 * needs into $PF_TEST_TMP. The standard glTF buffer holds one unit quad in the
 * z = 0 plane (facing +Z) followed by a test's own floats:
 *   accessors[0] POSITION  (0,0,0) (1,0,0) (1,1,0) (0,1,0)
 *   accessors[1] NORMAL    (0,0,1) × 4
 *   accessors[2] indices   u16 0 1 2  0 2 3
 *   bufferViews[3]         the extra floats (accessors[3...] come from the test)
 */
#ifndef SCENE_TEST_UTIL_H
#define SCENE_TEST_UTIL_H

#include "pf_scene.h"

#include <stddef.h>
#include <stdint.h>

#define ST_QUAD_BYTES 108u /* positions 48 + normals 48 + indices 12 */

typedef struct st_gltf {
    const char *name;        /* file stem: writes <name>.gltf and <name>.bin */
    const float *extra;      /* floats appended after the quad (bufferViews[3]) */
    uint32_t extra_floats;
    const char *nodes;       /* JSON array text */
    const char *scenes;      /* default [{"nodes":[0]}] */
    const char *meshes;      /* default one quad mesh with material 0 if materials given */
    const char *materials;   /* JSON array text or NULL */
    const char *cameras;
    const char *animations;
    const char *skins;       /* JSON array text or NULL */
    const char *extensions;       /* root "extensions" object text */
    const char *extensions_used;  /* array text */
    const char *extensions_required; /* array text */
    const char *extra_accessors;  /* ", {...}, {...}" appended after accessors[2] */
    const char *asset_extras;     /* object text */
    const char *generator;        /* asset.generator, or NULL */
    int data_uri;            /* embed the buffer as a base64 data: URI */
    int glb;                 /* write <name>.glb with a BIN chunk instead */
} st_gltf;

/* $PF_TEST_TMP/name into buffer. */
const char *st_path(char *buffer, size_t size, const char *name);
/* Writes bytes to path; returns 0 on success. */
int st_write(const char *path, const void *data, size_t size);
int st_write_text(const char *path, const char *text);
/* The standard quad buffer plus extra floats; caller frees. */
unsigned char *st_quad_buffer(const float *extra, uint32_t extra_floats, size_t *size);
/* Writes the glTF described by spec; returns the path of the .gltf/.glb. */
const char *st_write_gltf(const st_gltf *spec, char *path, size_t size);

/* Loads path expecting success (a failed check naming the error otherwise); NULL on failure. */
pf_scene *st_load_ok(const char *path);
/* Checks actual[0..2] against (x, y, z) within tolerance. */
void st_check_vec3(const float *actual, double x, double y, double z, double tolerance);

/* Loads path expecting failure with status; checks the message names all needles. */
void st_expect_error(const char *path, pf_status status, const char *needle1,
                     const char *needle2);

#endif
