/*
 * core/bih internals shared by its .c files: the leaf fields' bit casts and
 * the node word decoding (GLSL mirror in shaders/common/bih_traverse.glsl).
 */
#ifndef PF_BIH_INTERNAL_H
#define PF_BIH_INTERNAL_H

#include "pf_bih.h"

#include <string.h>

/* A leaf keeps uint32 bits in its float fields (see the node format in pf_bih.h). */
static inline float pf_bih_bits_to_float(uint32_t bits)
{
    float value;
    memcpy(&value, &bits, sizeof value);
    return value;
}

static inline uint32_t pf_bih_float_to_bits(float value)
{
    uint32_t bits;
    memcpy(&bits, &value, sizeof bits);
    return bits;
}

static inline int pf_bih_is_leaf(const pf_bih_node *node)
{
    return (node->word & 3u) == PF_BIH_LEAF;
}

static inline uint32_t pf_bih_leaf_first(const pf_bih_node *node)
{
    return pf_bih_float_to_bits(node->clip[0]);
}

static inline uint32_t pf_bih_leaf_count(const pf_bih_node *node)
{
    return pf_bih_float_to_bits(node->clip[1]);
}

static inline uint32_t pf_bih_axis(const pf_bih_node *node)
{
    return node->word & 3u;
}

static inline uint32_t pf_bih_first_child(const pf_bih_node *node)
{
    return node->word >> 2;
}

#endif
