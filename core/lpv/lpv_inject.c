/*
 * VPL injection into every cascade (pf_lpv.h): (Φ/π) × the clamped-cosine
 * lobe of the VPL's normal, into the cell of its position moved
 * offset_cells along the normal.
 */
#include "pf_lpv.h"

#include <math.h>
#include <string.h>

#define INV_PI 0.31830988618379067f

static int vpl_usable(const pf_lpv_vpl *vpl, float normal[3])
{
    float length2 = 0.0f;
    for (int i = 0; i < 3; i++) {
        if (!isfinite(vpl->position[i]) || !isfinite(vpl->normal[i]) || !isfinite(vpl->flux[i]))
            return 0;
        length2 += vpl->normal[i] * vpl->normal[i];
    }
    if (!(length2 > 0.0f))
        return 0;
    float inv = 1.0f / sqrtf(length2);
    for (int i = 0; i < 3; i++)
        normal[i] = vpl->normal[i] * inv;
    return 1;
}

void pf_lpv_inject(const pf_lpv_layout *layout, const pf_lpv_vpl *vpls, uint32_t count,
                   float *grid, pf_lpv_inject_stats *stats)
{
    pf_lpv_inject_stats local;
    if (!stats)
        stats = &local;
    memset(stats, 0, sizeof *stats);
    uint64_t cells = (uint64_t)layout->size * layout->size * layout->size;
    int32_t size = (int32_t)layout->size;
    for (uint32_t v = 0; v < count; v++) {
        const pf_lpv_vpl *vpl = &vpls[v];
        float normal[3];
        if (!vpl_usable(vpl, normal)) {
            stats->rejected++;
            continue;
        }
        float lobe[4];
        pf_sh_cosine_lobe(normal, lobe);
        int landed = 0;
        for (uint32_t k = 0; k < layout->count; k++) {
            const pf_lpv_cascade *cascade = &layout->cascades[k];
            int32_t cell[3];
            int inside = 1;
            for (int i = 0; i < 3; i++) {
                float p = vpl->position[i] + normal[i] * layout->offset_cells * cascade->cell_size;
                double c = floor(((double)p - cascade->origin[i]) / cascade->cell_size);
                if (!(c >= 0.0 && c < size))
                    inside = 0;
                cell[i] = inside ? (int32_t)c : 0;
            }
            if (!inside)
                continue;
            landed = 1;
            stats->injected[k]++;
            uint64_t index = k * cells + ((uint64_t)cell[2] * size + cell[1]) * size + cell[0];
            float *out = grid + index * PF_LPV_FLOATS_PER_CELL;
            for (int channel = 0; channel < 3; channel++) {
                float scale = vpl->flux[channel] * INV_PI;
                for (int c = 0; c < 4; c++)
                    out[4 * channel + c] += scale * lobe[c];
            }
        }
        if (!landed)
            stats->outside++;
    }
}
