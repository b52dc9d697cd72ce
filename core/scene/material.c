/*
 * The material parameters' summary (pf_material_classify) and constructors
 * for the limits of the glTF BSDF (pf_scene.h).
 */
#include "pf_scene.h"

#include <string.h>

/* glTF's (and KHR_materials_ior's) default index of refraction. */
#define DEFAULT_IOR 1.5f

uint32_t pf_scene_frame_surface_features(const pf_scene_frame *frame)
{
    uint32_t features = frame->corners ? PF_SURFACE_CORNERS : 0u;
    uint32_t has = frame->light_count > 0 ? PF_SURFACE_NO_LIGHTS : 0u; /* bits it has not */
    if (frame->light_count > PF_DIRECT_LIGHTS_EVERY_MAX)
        has |= PF_SURFACE_NO_MANY_LIGHTS;
    for (uint32_t m = 0; m < frame->material_count; m++) {
        const pf_material *material = &frame->materials[m];
        /* An unlit surface is tested as alpha is: only camera rays see it. */
        if (material->alpha_mode != PF_ALPHA_OPAQUE || (material->flags & PF_MATERIAL_UNLIT))
            features |= PF_SURFACE_ALPHA;
        if (material->transmission > 0.0f)
            has |= PF_SURFACE_NO_TRANSMISSION;
        if (material->clearcoat > 0.0f)
            has |= PF_SURFACE_NO_CLEARCOAT;
        if (material->sheen_color[0] > 0.0f || material->sheen_color[1] > 0.0f ||
            material->sheen_color[2] > 0.0f)
            has |= PF_SURFACE_NO_SHEEN;
        for (int c = 0; c < 3; c++)
            if (material->emission[c] > 0.0f)
                has |= PF_SURFACE_NO_EMISSION;
        /* A texture scales roughness and metallic down: a texel may be a mirror. */
        if (material->kind != PF_MATERIAL_LAMBERT ||
            material->metallic_roughness_texture != PF_NO_TEXTURE)
            has |= PF_SURFACE_NO_SPECULAR;
    }
    const uint32_t absent = PF_SURFACE_NO_LIGHTS | PF_SURFACE_NO_TRANSMISSION |
                            PF_SURFACE_NO_EMISSION | PF_SURFACE_NO_SPECULAR |
                            PF_SURFACE_NO_MANY_LIGHTS | PF_SURFACE_NO_CLEARCOAT |
                            PF_SURFACE_NO_SHEEN;
    return features | (absent & ~has);
}

void pf_scene_spec_constants(uint32_t features, uint32_t ids[PF_SCENE_SPEC_CONSTANTS],
                             uint32_t values[PF_SCENE_SPEC_CONSTANTS])
{
    /* Each constant's bit, and whether the bit says the frame has it (1) or lacks it (0). */
    static const struct {
        uint32_t constant_id, bit, has;
    } map[PF_SCENE_SPEC_CONSTANTS] = {
        {PF_SPEC_SCENE_HAS_ALPHA, PF_SURFACE_ALPHA, 1},
        {PF_SPEC_SCENE_HAS_CORNERS, PF_SURFACE_CORNERS, 1},
        {PF_SPEC_SCENE_HAS_LIGHTS, PF_SURFACE_NO_LIGHTS, 0},
        {PF_SPEC_SCENE_HAS_TRANSMISSION, PF_SURFACE_NO_TRANSMISSION, 0},
        {PF_SPEC_SCENE_HAS_EMITTERS, PF_SURFACE_NO_EMISSION, 0},
        {PF_SPEC_SCENE_HAS_SPECULAR, PF_SURFACE_NO_SPECULAR, 0},
        {PF_SPEC_SCENE_HAS_MANY_LIGHTS, PF_SURFACE_NO_MANY_LIGHTS, 0},
        {PF_SPEC_SCENE_HAS_CLEARCOAT, PF_SURFACE_NO_CLEARCOAT, 0},
        {PF_SPEC_SCENE_HAS_SHEEN, PF_SURFACE_NO_SHEEN, 0}};
    for (uint32_t i = 0; i < PF_SCENE_SPEC_CONSTANTS; i++) {
        ids[i] = map[i].constant_id;
        uint32_t set = (features & map[i].bit) != 0;
        values[i] = set == map[i].has ? 1u : 0u;
    }
}

uint64_t pf_materials_buffer_bytes(uint32_t count)
{
    return sizeof pf_sheen_albedo + (uint64_t)count * sizeof(pf_material);
}

void pf_materials_buffer_write(const pf_material *materials, uint32_t count, void *out)
{
    memcpy(out, pf_sheen_albedo, sizeof pf_sheen_albedo);
    if (count > 0)
        memcpy((char *)out + sizeof pf_sheen_albedo, materials, count * sizeof(pf_material));
}

void pf_material_classify(pf_material *material)
{
    int rough = material->roughness >= PF_MATERIAL_GLOSSY_ROUGHNESS;
    /* The diffuse base has weight (1 - metallic)(1 - transmission). */
    int has_diffuse = material->metallic < 1.0f && material->transmission < 1.0f;
    /* A rough metal's glossy reflection is estimated like a diffuse base; a
     * sharper one, and a fully transmissive dielectric, rough or not, is
     * passed through. */
    if (has_diffuse || (rough && material->metallic > 0.0f))
        material->kind = PF_MATERIAL_LAMBERT;
    else if (material->metallic >= 1.0f)
        material->kind = PF_MATERIAL_MIRROR;
    else
        material->kind = PF_MATERIAL_GLASS;
}

static pf_material base_material(float r, float g, float b)
{
    pf_material material;
    memset(&material, 0, sizeof material);
    material.albedo[0] = r;
    material.albedo[1] = g;
    material.albedo[2] = b;
    material.ior = DEFAULT_IOR;
    material.specular = 1.0f;
    material.specular_color[0] = material.specular_color[1] = material.specular_color[2] = 1.0f;
    return material;
}

pf_material pf_material_lambert(float r, float g, float b)
{
    pf_material material = base_material(r, g, b);
    material.specular = 0.0f;
    material.roughness = 1.0f;
    pf_material_classify(&material);
    return material;
}

pf_material pf_material_mirror(float r, float g, float b)
{
    pf_material material = base_material(r, g, b);
    material.metallic = 1.0f;
    pf_material_classify(&material);
    return material;
}

pf_material pf_material_glass(float ior, float r, float g, float b)
{
    pf_material material = base_material(r, g, b);
    material.ior = ior;
    material.transmission = 1.0f;
    pf_material_classify(&material);
    return material;
}
