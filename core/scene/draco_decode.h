/*
 * KHR_draco_mesh_compression's decoder: a C interface over Draco's C++ library (Debian's
 * libdraco-dev has no C API), used by gltf_draco.c. Nothing here knows glTF.
 */
#ifndef PF_DRACO_DECODE_H
#define PF_DRACO_DECODE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* One attribute wanted from the mesh: its unique id in the Draco stream and how many
 * components the glTF accessor has; values gets point_count × components doubles, the
 * attribute's stored values (dequantized where Draco quantized them, otherwise raw: the
 * caller applies the accessor's normalization). */
typedef struct pf_draco_attribute {
    uint32_t unique_id;
    uint32_t components;
    double *values; /* malloc'ed by pf_draco_decode, freed by the caller */
} pf_draco_attribute;

typedef struct pf_draco_mesh {
    uint32_t point_count;
    uint32_t index_count; /* 3 per face */
    uint32_t *indices;    /* malloc'ed by pf_draco_decode, freed by the caller */
} pf_draco_mesh;

/* Decodes the Draco mesh in data[0, size) and the attributes asked for. Returns 0, or -1
 * with a message (the stream is not a Draco mesh, an attribute is missing or has fewer
 * components than asked, out of memory); on failure nothing is left allocated. */
int pf_draco_decode(const unsigned char *data, size_t size, pf_draco_attribute *attributes,
                    uint32_t attribute_count, pf_draco_mesh *mesh, char *message,
                    size_t message_size);

#ifdef __cplusplus
}
#endif

#endif
