/*
 * KHR_materials_variants: a file's named sets of materials (a product's colourways, which
 * Blender exports from its glTF Variants panel). The root lists the variants by name; a
 * primitive maps some of them to materials of its own. The scene is loaded wearing one
 * variant (pf_scene_load_options.material_variant), or each primitive's own material when
 * none is chosen, as the spec's default.
 */
#include "gltf_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define VARIANTS_EXTENSION "KHR_materials_variants"

/* object.extensions.KHR_materials_variants, NULL when absent. */
static const cJSON *variants_extension(const cJSON *object)
{
    return cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(object, "extensions"), VARIANTS_EXTENSION);
}

pf_status gltf_load_material_variants(gltf_context *ctx, pf_error *err)
{
    pf_scene *scene = ctx->scene;
    const cJSON *extension = variants_extension(ctx->root);
    const cJSON *variants = NULL;
    uint32_t count = 0;
    if (extension) {
        if (!cJSON_IsObject(extension))
            return gltf_fail(ctx, err, PF_ERR_FORMAT, "extensions." VARIANTS_EXTENSION,
                             "expected an object");
        pf_status status = gltf_array(ctx, extension, "variants", &variants, &count,
                                      "extensions." VARIANTS_EXTENSION, err);
        if (status)
            return status;
    }
    for (uint32_t v = 0; v < count; v++) {
        if (!cJSON_IsString(cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(variants, (int)v),
                                                             "name"))) {
            char element[96];
            snprintf(element, sizeof element, "extensions." VARIANTS_EXTENSION ".variants[%u]",
                     v);
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "name: expected a string");
        }
    }
    char names[512];
    const char *choice = scene->variant_choice;
    scene->variant_count = count;
    scene->variant = gltf_named_entry(variants, count, choice, names, sizeof names);
    if (!choice && count > 0)
        pf_log(PF_LOG_INFO,
               "%s: %u material variants (%s): each primitive wears its own material; "
               "--variant picks one",
               ctx->path, count, names);
    if (!choice || scene->variant != SCENE_NONE)
        return PF_OK;
    return pf_error_set(err, PF_ERR_INVALID,
                        "%s: --variant '%s': no material variant of that name or index (the "
                        "file's: %s)",
                        ctx->path, choice, names);
}

pf_status gltf_primitive_variant(gltf_context *ctx, const cJSON *primitive, const char *element,
                                 int32_t *material, pf_error *err)
{
    const cJSON *extension = variants_extension(primitive);
    if (!extension)
        return PF_OK;
    char where[192];
    snprintf(where, sizeof where, "%s.extensions." VARIANTS_EXTENSION, element);
    const cJSON *mappings;
    uint32_t mapping_count;
    pf_status status = cJSON_IsObject(extension)
                           ? gltf_array(ctx, extension, "mappings", &mappings, &mapping_count,
                                        where, err)
                           : gltf_fail(ctx, err, PF_ERR_FORMAT, where, "expected an object");
    /* Every mapping is checked, worn or not: a file that names a material or a variant it
     * lacks is broken for whoever picks another variant too. */
    int32_t chosen = SCENE_NONE;
    for (uint32_t m = 0; !status && m < mapping_count; m++) {
        char mapping_element[224];
        snprintf(mapping_element, sizeof mapping_element, "%s.mappings[%u]", where, m);
        const cJSON *mapping = cJSON_GetArrayItem(mappings, (int)m);
        if (!cJSON_IsObject(mapping)) {
            status = gltf_fail(ctx, err, PF_ERR_FORMAT, mapping_element, "expected an object");
            break;
        }
        int32_t mapped;
        const cJSON *variants;
        uint32_t variant_count;
        status = gltf_index(ctx, mapping, "material", ctx->file_material_count, &mapped,
                            mapping_element, err);
        if (!status && mapped == SCENE_NONE)
            status = gltf_fail(ctx, err, PF_ERR_FORMAT, mapping_element, "material: missing");
        if (!status)
            status = gltf_array(ctx, mapping, "variants", &variants, &variant_count,
                                mapping_element, err);
        for (uint32_t v = 0; !status && v < variant_count; v++) {
            const cJSON *variant = cJSON_GetArrayItem(variants, (int)v);
            double index = cJSON_IsNumber(variant) ? variant->valuedouble : -1.0;
            if (index < 0 || index >= ctx->scene->variant_count || index != (double)(int)index)
                status = gltf_fail(ctx, err, PF_ERR_FORMAT, mapping_element,
                                   "variants[%u]: not one of the file's %u variants", v,
                                   ctx->scene->variant_count);
            else if ((int32_t)index == ctx->scene->variant)
                chosen = mapped;
        }
    }
    if (!status && chosen != SCENE_NONE)
        *material = chosen;
    return status;
}
