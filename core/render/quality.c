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

int pf_quality_parse(const char *name)
{
    for (int quality = 0; name && quality < (int)(sizeof quality_names / sizeof quality_names[0]);
         quality++) {
        if (!strcmp(name, quality_names[quality]))
            return quality;
    }
    return -1;
}

const char *pf_quality_name(pf_quality quality)
{
    if ((unsigned)quality < sizeof quality_names / sizeof quality_names[0])
        return quality_names[quality];
    return "unknown";
}

static const char *const filter_names[] = {"gaussian", "box", "blackman-harris"};

int pf_pixel_filter_parse(const char *name)
{
    for (int filter = 0; name && filter < (int)(sizeof filter_names / sizeof filter_names[0]);
         filter++) {
        if (!strcmp(name, filter_names[filter]))
            return filter;
    }
    return -1;
}

const char *pf_pixel_filter_name(pf_pixel_filter filter)
{
    if ((unsigned)filter < sizeof filter_names / sizeof filter_names[0])
        return filter_names[filter];
    return "unknown";
}


