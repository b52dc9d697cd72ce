/* Quality preset names (DESIGN.md §4). */
#include "pf_render.h"

#include <string.h>

static const char *const quality_names[] = {
    [PF_QUALITY_PREVIEW] = "preview",
    [PF_QUALITY_FAST] = "fast",
    [PF_QUALITY_FINAL] = "final",
    [PF_QUALITY_REFERENCE] = "reference",
    [PF_QUALITY_AUTO] = "auto",
};

/* The index of name in a table of count names; -1 if absent. */
static int name_index(const char *const *table, int count, const char *name)
{
    for (int k = 0; name && k < count; k++)
        if (table[k] && !strcmp(name, table[k]))
            return k;
    return -1;
}

#define TABLE_SIZE(table) ((int)(sizeof table / sizeof table[0]))

int pf_quality_parse(const char *name)
{
    return name_index(quality_names, TABLE_SIZE(quality_names), name);
}

const char *pf_quality_name(pf_quality quality)
{
    return (int)quality >= 0 && (int)quality < TABLE_SIZE(quality_names) ? quality_names[quality]
                                                                        : "unknown";
}

static const char *const filter_names[] = {"gaussian", "box", "blackman-harris"};

int pf_pixel_filter_parse(const char *name)
{
    return name_index(filter_names, TABLE_SIZE(filter_names), name);
}

const char *pf_pixel_filter_name(pf_pixel_filter filter)
{
    return (int)filter >= 0 && (int)filter < TABLE_SIZE(filter_names) ? filter_names[filter]
                                                                     : "unknown";
}

static const char *const denoise_names[] = {"auto", "on", "off", "spatial"};

int pf_denoise_parse(const char *name)
{
    return name_index(denoise_names, TABLE_SIZE(denoise_names), name);
}

const char *pf_denoise_name(pf_denoise_mode mode)
{
    return (int)mode >= 0 && (int)mode < TABLE_SIZE(denoise_names) ? denoise_names[mode]
                                                                  : "unknown";
}

int pf_denoise_applies(pf_denoise_mode mode, pf_quality preset)
{
    if (mode == PF_DENOISE_OFF || preset == PF_QUALITY_PREVIEW)
        return 0;
    return mode == PF_DENOISE_ON || mode == PF_DENOISE_SPATIAL || preset == PF_QUALITY_FINAL ||
           preset == PF_QUALITY_REFERENCE;
}

int pf_denoise_temporal(pf_denoise_mode mode, pf_quality preset)
{
    return mode != PF_DENOISE_SPATIAL && pf_denoise_applies(mode, preset);
}
