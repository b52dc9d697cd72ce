/*
 * glTF materials -> pf_material: the parameters of the metallic-roughness
 * BSDF (pf_scene.h; evaluated by shaders/common/materials.glsl):
 *   baseColorFactor.rgb, metallicFactor, roughnessFactor (both default 1);
 *   KHR_materials_transmission.transmissionFactor (0), KHR_materials_ior.ior
 *   (1.5), KHR_materials_specular.specularFactor (1) and
 *   .specularColorFactor (1, 1, 1), scaled by specularTexture's A and specularColorTexture's
 *   RGB (sRGB; Blender writes one where its specular tint or specular is textured);
 *   KHR_materials_volume's attenuationColor
 *   (1, 1, 1) and attenuationDistance (infinite) as the Beer-Lambert
 *   coefficient -ln(colour)/distance, where thicknessFactor (0) says the mesh
 *   is a volume (> 0; the thickness itself is for rasterisers: a ray tracer
 *   measures the distance travelled inside).
 * KHR_materials_clearcoat: clearcoatFactor (0) and clearcoatRoughnessFactor (0), scaled by
 * clearcoatTexture's R and clearcoatRoughnessTexture's G; clearcoatNormalTexture (with its
 * scale) tilts the coat's normal, which is otherwise the mesh's even under a base normal map.
 * KHR_materials_sheen: sheenColorFactor (0, 0, 0: no sheen) and sheenRoughnessFactor (0),
 * scaled by sheenColorTexture's RGB (sRGB) and sheenRoughnessTexture's A.
 * KHR_materials_unlit: the base colour as the camera sees it, nothing else (make_unlit).
 * Emission = emissiveFactor x KHR_materials_emissive_strength.emissiveStrength,
 * from both faces when the material is doubleSided.
 * Textures (gltf_textures.c): baseColor and emissive (sRGB) and
 * metallicRoughness multiply their factors; normalTexture (with its scale)
 * tilts the shading normal in tangent space; alphaMode MASK (alphaCutoff, 0.5)
 * and BLEND read baseColor's alpha. occlusionTexture is not read: a global
 * illumination renderer computes the occlusion it approximates.
 * Factors outside the spec's ranges are format errors naming the field.
 */
#include "gltf_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* KHR_materials_ior default. */
#define GLTF_DEFAULT_IOR 1.5
/* The least attenuation colour taken: exp(-ln(1e-6)) keeps the coefficient finite. */
#define VOLUME_COLOUR_MIN 1e-6

static const char *const known_material_extensions[] = {
    "KHR_materials_emissive_strength", "KHR_materials_transmission", "KHR_materials_ior",
    "KHR_materials_specular", "KHR_materials_volume", "KHR_materials_clearcoat",
    "KHR_materials_unlit", "KHR_materials_sheen"};

static void warn_unhandled(gltf_context *ctx, const cJSON *material, const cJSON *pbr,
                           const char *element)
{
    (void)pbr;
    const cJSON *extensions = cJSON_GetObjectItemCaseSensitive(material, "extensions");
    const cJSON *extension;
    cJSON_ArrayForEach(extension, extensions)
    {
        int known = 0;
        for (size_t k = 0; k < sizeof known_material_extensions / sizeof *known_material_extensions;
             k++)
            known |= strcmp(extension->string, known_material_extensions[k]) == 0;
        if (!known) {
            char key[256];
            /* Same key as the extensionsUsed warning: one warning per extension. */
            snprintf(key, sizeof key, "extension %s", extension->string);
            scene_warn_once(ctx->scene, key, "%s: %s: material extension %s is not supported: "
                            "ignored", ctx->path, element, extension->string);
        }
    }
}

/* alphaMode and alphaCutoff; the alpha itself is baseColorFactor's (and its texture's). */
static pf_status load_alpha(gltf_context *ctx, const cJSON *material, const char *element,
                            pf_material *out, pf_error *err)
{
    const cJSON *mode = cJSON_GetObjectItemCaseSensitive(material, "alphaMode");
    out->alpha_mode = PF_ALPHA_OPAQUE;
    if (mode && !cJSON_IsString(mode))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "alphaMode must be a string");
    if (mode && strcmp(mode->valuestring, "MASK") == 0)
        out->alpha_mode = PF_ALPHA_MASK;
    else if (mode && strcmp(mode->valuestring, "BLEND") == 0)
        out->alpha_mode = PF_ALPHA_BLEND;
    else if (mode && strcmp(mode->valuestring, "OPAQUE") != 0)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "alphaMode \"%s\" is not OPAQUE, MASK or BLEND", mode->valuestring);
    double cutoff;
    pf_status status = gltf_number(ctx, material, "alphaCutoff", 0.5, &cutoff, element, err);
    if (status)
        return status;
    if (!(cutoff >= 0))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "alphaCutoff %g must be >= 0",
                         cutoff);
    out->alpha_cutoff = (float)cutoff;
    if (out->alpha_mode != PF_ALPHA_OPAQUE)
        ctx->scene->info.has_alpha = 1;
    return PF_OK;
}

/* One texture slot, the textureInfo at parent's key (absent: none), named in errors as
 * parent_element.key. */
static pf_status material_slot(gltf_context *ctx, const cJSON *parent, const char *parent_element,
                               const char *key, int srgb, uint32_t *slot, float *scale,
                               pf_error *err)
{
    char element[256];
    snprintf(element, sizeof element, "%s.%s", parent_element, key);
    return gltf_texture_slot(ctx, cJSON_GetObjectItemCaseSensitive(parent, key), srgb, element,
                             slot, scale, err);
}

/* The textured slots: baseColor, emissive and specularColor in sRGB, metallicRoughness, normal
 * and specular linear. */
static pf_status load_texture_slots(gltf_context *ctx, const cJSON *material, const cJSON *pbr,
                                    const char *element, pf_material *out, pf_error *err)
{
    char pbr_element[160], specular_element[192];
    snprintf(pbr_element, sizeof pbr_element, "%s.pbrMetallicRoughness", element);
    snprintf(specular_element, sizeof specular_element, "%s.extensions.KHR_materials_specular",
             element);
    const cJSON *specular = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(material, "extensions"), "KHR_materials_specular");
    pf_status status = material_slot(ctx, pbr, pbr_element, "baseColorTexture", 1,
                                     &out->base_color_texture, NULL, err);
    if (!status)
        status = material_slot(ctx, pbr, pbr_element, "metallicRoughnessTexture", 0,
                               &out->metallic_roughness_texture, NULL, err);
    if (!status)
        status = material_slot(ctx, material, element, "normalTexture", 0, &out->normal_texture,
                               &out->normal_scale, err);
    if (!status)
        status = material_slot(ctx, material, element, "emissiveTexture", 1,
                               &out->emissive_texture, NULL, err);
    if (!status)
        status = material_slot(ctx, specular, specular_element, "specularTexture", 0,
                               &out->specular_texture, NULL, err);
    if (!status)
        status = material_slot(ctx, specular, specular_element, "specularColorTexture", 1,
                               &out->specular_color_texture, NULL, err);
    return status;
}

/* KHR_materials_clearcoat (NULL: none): the coat's factors and their textures. */
static pf_status load_clearcoat(gltf_context *ctx, const cJSON *coat, const char *element,
                                pf_material *out, pf_error *err)
{
    if (!coat)
        return PF_OK;
    char coat_element[192];
    snprintf(coat_element, sizeof coat_element, "%s.extensions.KHR_materials_clearcoat",
             element);
    double factor = 0, roughness = 0;
    pf_status status = gltf_number(ctx, coat, "clearcoatFactor", 0, &factor, coat_element, err);
    if (!status)
        status = gltf_number(ctx, coat, "clearcoatRoughnessFactor", 0, &roughness,
                             coat_element, err);
    if (!status && !(factor >= 0 && factor <= 1 && roughness >= 0 && roughness <= 1))
        status = gltf_fail(ctx, err, PF_ERR_FORMAT, coat_element,
                           "clearcoatFactor %g and clearcoatRoughnessFactor %g must be in [0, 1]",
                           factor, roughness);
    if (!status)
        status = material_slot(ctx, coat, coat_element, "clearcoatTexture", 0,
                               &out->clearcoat_texture, NULL, err);
    if (!status)
        status = material_slot(ctx, coat, coat_element, "clearcoatRoughnessTexture", 0,
                               &out->clearcoat_roughness_texture, NULL, err);
    if (!status)
        status = material_slot(ctx, coat, coat_element, "clearcoatNormalTexture", 0,
                               &out->clearcoat_normal_texture, &out->clearcoat_normal_scale,
                               err);
    if (status)
        return status;
    if (out->clearcoat_normal_texture == PF_NO_TEXTURE)
        out->clearcoat_normal_scale = 1.0f;
    out->clearcoat = (float)factor;
    out->clearcoat_roughness = (float)roughness;
    return PF_OK;
}

/*
 * KHR_materials_unlit: the base colour (its factor, texture, COLOR_0 and alpha mode) is all
 * that counts; the spec has the rest ignored (and forbids a sheen beside it), so the lobes
 * the kernels would sample are zeroed (an unlit surface reflects nothing) and its emission
 * is left to the camera hit (pf_scene.h PF_MATERIAL_UNLIT).
 */
static void make_unlit(pf_material *m)
{
    m->flags |= PF_MATERIAL_UNLIT;
    m->metallic = 0.0f;
    m->roughness = 1.0f;
    m->transmission = 0.0f;
    m->specular = 0.0f;
    m->clearcoat = 0.0f;
    memset(m->emission, 0, sizeof m->emission);
    memset(m->absorption, 0, sizeof m->absorption);
    m->metallic_roughness_texture = m->normal_texture = m->emissive_texture = PF_NO_TEXTURE;
    m->specular_texture = m->specular_color_texture = PF_NO_TEXTURE;
    m->clearcoat_texture = m->clearcoat_roughness_texture = PF_NO_TEXTURE;
    m->clearcoat_normal_texture = PF_NO_TEXTURE;
    memset(m->sheen_color, 0, sizeof m->sheen_color);
    m->sheen_roughness = 0.0f;
    m->sheen_color_texture = m->sheen_roughness_texture = PF_NO_TEXTURE;
}

/* KHR_materials_sheen (NULL: none): the fibres' colour and roughness, and their textures. */
static pf_status load_sheen(gltf_context *ctx, const cJSON *sheen, const char *element,
                            pf_material *out, pf_error *err)
{
    if (!sheen)
        return PF_OK;
    char sheen_element[192];
    snprintf(sheen_element, sizeof sheen_element, "%s.extensions.KHR_materials_sheen", element);
    float colour[3] = {0, 0, 0};
    double roughness = 0;
    pf_status status = gltf_floats(ctx, sheen, "sheenColorFactor", 3, colour, sheen_element, err);
    if (!status)
        status = gltf_number(ctx, sheen, "sheenRoughnessFactor", 0, &roughness, sheen_element,
                             err);
    for (int c = 0; !status && c < 3; c++)
        if (!(colour[c] >= 0 && colour[c] <= 1))
            status = gltf_fail(ctx, err, PF_ERR_FORMAT, sheen_element,
                               "sheenColorFactor %g is outside [0, 1]", colour[c]);
    if (!status && !(roughness >= 0 && roughness <= 1))
        status = gltf_fail(ctx, err, PF_ERR_FORMAT, sheen_element,
                           "sheenRoughnessFactor %g is outside [0, 1]", roughness);
    if (!status)
        status = material_slot(ctx, sheen, sheen_element, "sheenColorTexture", 1,
                               &out->sheen_color_texture, NULL, err);
    if (!status)
        status = material_slot(ctx, sheen, sheen_element, "sheenRoughnessTexture", 0,
                               &out->sheen_roughness_texture, NULL, err);
    if (status)
        return status;
    memcpy(out->sheen_color, colour, sizeof out->sheen_color);
    out->sheen_roughness = (float)roughness;
    return PF_OK;
}

static pf_status load_material(gltf_context *ctx, const cJSON *material, const char *element,
                               pf_material *out, pf_error *err)
{
    const cJSON *pbr = cJSON_GetObjectItemCaseSensitive(material, "pbrMetallicRoughness");
    const cJSON *extensions = cJSON_GetObjectItemCaseSensitive(material, "extensions");
    const cJSON *strength_ext =
        cJSON_GetObjectItemCaseSensitive(extensions, "KHR_materials_emissive_strength");
    const cJSON *transmission_ext =
        cJSON_GetObjectItemCaseSensitive(extensions, "KHR_materials_transmission");
    const cJSON *ior_ext = cJSON_GetObjectItemCaseSensitive(extensions, "KHR_materials_ior");
    const cJSON *specular_ext =
        cJSON_GetObjectItemCaseSensitive(extensions, "KHR_materials_specular");
    const cJSON *volume_ext = cJSON_GetObjectItemCaseSensitive(extensions, "KHR_materials_volume");
    char pbr_element[128], ext_element[192];
    snprintf(pbr_element, sizeof pbr_element, "%s.pbrMetallicRoughness", element);

    float base_color[4] = {1, 1, 1, 1};
    float emissive[3] = {0, 0, 0};
    float specular_color[3] = {1, 1, 1};
    double metallic = 1, roughness = 1, strength = 1, transmission = 0, ior = GLTF_DEFAULT_IOR;
    double specular = 1;
    float attenuation_color[3] = {1, 1, 1};
    double thickness = 0, attenuation_distance = 0; /* 0: absent, i.e. infinite */
    pf_status status = gltf_floats(ctx, pbr, "baseColorFactor", 4, base_color, pbr_element, err);
    if (!status)
        status = gltf_number(ctx, pbr, "metallicFactor", 1, &metallic, pbr_element, err);
    if (!status)
        status = gltf_number(ctx, pbr, "roughnessFactor", 1, &roughness, pbr_element, err);
    if (!status)
        status = gltf_floats(ctx, material, "emissiveFactor", 3, emissive, element, err);
    if (!status) {
        snprintf(ext_element, sizeof ext_element, "%s.extensions.KHR_materials_emissive_strength",
                 element);
        status = gltf_number(ctx, strength_ext, "emissiveStrength", 1, &strength, ext_element,
                             err);
    }
    if (!status) {
        snprintf(ext_element, sizeof ext_element, "%s.extensions.KHR_materials_transmission",
                 element);
        status = gltf_number(ctx, transmission_ext, "transmissionFactor", 0, &transmission,
                             ext_element, err);
    }
    if (!status) {
        snprintf(ext_element, sizeof ext_element, "%s.extensions.KHR_materials_ior", element);
        status = gltf_number(ctx, ior_ext, "ior", GLTF_DEFAULT_IOR, &ior, ext_element, err);
        /* KHR_materials_ior: ior 0 is the legacy "infinite" value; anything else must be >= 1. */
        if (!status && ior != 0 && ior < 1)
            status = gltf_fail(ctx, err, PF_ERR_FORMAT, ext_element, "ior %g must be >= 1", ior);
    }
    if (!status) {
        snprintf(ext_element, sizeof ext_element, "%s.extensions.KHR_materials_specular",
                 element);
        status = gltf_number(ctx, specular_ext, "specularFactor", 1, &specular, ext_element,
                             err);
        if (!status)
            status = gltf_floats(ctx, specular_ext, "specularColorFactor", 3, specular_color,
                                 ext_element, err);
    }
    if (!status) {
        snprintf(ext_element, sizeof ext_element, "%s.extensions.KHR_materials_volume", element);
        status = gltf_number(ctx, volume_ext, "thicknessFactor", 0, &thickness, ext_element, err);
        if (!status)
            status = gltf_number(ctx, volume_ext, "attenuationDistance", 0,
                                 &attenuation_distance, ext_element, err);
        if (!status)
            status = gltf_floats(ctx, volume_ext, "attenuationColor", 3, attenuation_color,
                                 ext_element, err);
        if (!status && (thickness < 0 || attenuation_distance < 0 ||
                        (cJSON_GetObjectItemCaseSensitive(volume_ext, "attenuationDistance") &&
                         attenuation_distance == 0)))
            status = gltf_fail(ctx, err, PF_ERR_FORMAT, ext_element,
                               "thicknessFactor must be >= 0 and attenuationDistance > 0");
        for (int c = 0; !status && c < 3; c++)
            if (!(attenuation_color[c] >= 0 && attenuation_color[c] <= 1))
                status = gltf_fail(ctx, err, PF_ERR_FORMAT, ext_element,
                                   "attenuationColor %g is outside [0, 1]", attenuation_color[c]);
    }
    if (status)
        return status;
    if (strength < 0 || emissive[0] < 0 || emissive[1] < 0 || emissive[2] < 0)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "emissiveFactor and emissiveStrength must be non-negative");
    const struct {
        const char *name;
        double value;
    } unit_factors[] = {{"pbrMetallicRoughness.metallicFactor", metallic},
                        {"pbrMetallicRoughness.roughnessFactor", roughness},
                        {"pbrMetallicRoughness.baseColorFactor", base_color[0]},
                        {"pbrMetallicRoughness.baseColorFactor", base_color[1]},
                        {"pbrMetallicRoughness.baseColorFactor", base_color[2]},
                        {"extensions.KHR_materials_transmission.transmissionFactor",
                         transmission},
                        {"extensions.KHR_materials_specular.specularFactor", specular}};
    for (size_t k = 0; k < sizeof unit_factors / sizeof *unit_factors; k++)
        if (!(unit_factors[k].value >= 0 && unit_factors[k].value <= 1))
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "%s %g is outside [0, 1]",
                             unit_factors[k].name, unit_factors[k].value);
    if (specular_color[0] < 0 || specular_color[1] < 0 || specular_color[2] < 0)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "extensions.KHR_materials_specular.specularColorFactor must be "
                         "non-negative");
    if (!(base_color[3] >= 0 && base_color[3] <= 1))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "pbrMetallicRoughness.baseColorFactor alpha %g is outside [0, 1]",
                         base_color[3]);
    warn_unhandled(ctx, material, pbr, element);

    memset(out, 0, sizeof *out);
    status = load_alpha(ctx, material, element, out, err);
    if (!status)
        status = load_texture_slots(ctx, material, pbr, element, out, err);
    if (!status)
        status = load_clearcoat(
            ctx, cJSON_GetObjectItemCaseSensitive(extensions, "KHR_materials_clearcoat"), element,
            out, err);
    if (!status)
        status = load_sheen(ctx, cJSON_GetObjectItemCaseSensitive(extensions,
                                                                  "KHR_materials_sheen"),
                            element, out, err);
    if (status)
        return status;
    memcpy(out->albedo, base_color, sizeof out->albedo);
    out->alpha = base_color[3];
    if (out->normal_texture == PF_NO_TEXTURE)
        out->normal_scale = 1.0f;
    for (int c = 0; c < 3; c++)
        out->emission[c] = emissive[c] * (float)strength;
    /* KHR_materials_ior: 0 is the legacy "unknown" value: the default. */
    out->ior = ior == 0 ? (float)GLTF_DEFAULT_IOR : (float)ior;
    out->metallic = (float)metallic;
    out->roughness = (float)roughness;
    out->transmission = (float)transmission;
    out->specular = (float)specular;
    memcpy(out->specular_color, specular_color, sizeof out->specular_color);
    /* Beer-Lambert: a colour c left after distance d is a coefficient -ln(c)/d; a black
     * attenuation colour absorbs everything (a large finite coefficient, no infinity). */
    for (int c = 0; thickness > 0 && attenuation_distance > 0 && c < 3; c++)
        out->absorption[c] = (float)(-log(fmax(attenuation_color[c], VOLUME_COLOUR_MIN)) /
                                     attenuation_distance);
    const cJSON *double_sided = cJSON_GetObjectItemCaseSensitive(material, "doubleSided");
    if (double_sided && !cJSON_IsBool(double_sided))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "doubleSided must be true or false");
    if (cJSON_IsTrue(double_sided))
        out->flags |= PF_MATERIAL_DOUBLE_SIDED;
    const cJSON *unlit = cJSON_GetObjectItemCaseSensitive(extensions, "KHR_materials_unlit");
    if (unlit && !cJSON_IsObject(unlit))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "extensions.KHR_materials_unlit must be an object");
    if (unlit)
        make_unlit(out);
    pf_material_classify(out);
    return PF_OK;
}

pf_status gltf_load_materials(gltf_context *ctx, pf_error *err)
{
    pf_scene *scene = ctx->scene;
    const cJSON *materials;
    uint32_t count;
    pf_status status = gltf_array(ctx, ctx->root, "materials", &materials, &count, "", err);
    if (status || count == 0)
        return status;
    scene->materials = calloc(count, sizeof *scene->materials);
    if (!scene->materials)
        return gltf_fail(ctx, err, PF_ERR_NOMEM, "materials", "out of memory");
    scene->material_count = count;
    ctx->file_material_count = count;
    for (uint32_t k = 0; k < count; k++) {
        char element[64];
        snprintf(element, sizeof element, "materials[%u]", k);
        const cJSON *material = cJSON_GetArrayItem(materials, (int)k);
        if (!cJSON_IsObject(material))
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "expected an object");
        status = load_material(ctx, material, element, &scene->materials[k], err);
        if (status)
            return status;
    }
    return PF_OK;
}
