/*
 * spirv_denormals.c: every embedded shader, given DenormPreserve for 32-bit
 * floats, is still a valid Vulkan 1.2 module (spirv-val, as the build checks
 * the originals), declares the mode once per entry point with its capability,
 * and is left as it is by a second pass. The device path itself runs only
 * where shaderDenormPreserveFloat32 exists (not lavapipe 22.x); there
 * test_bih_gpu_build's clustered rays, whose edge products are subnormal,
 * are what it fixes.
 */
#include "pf_test.h"
#include "pf_vk_internal.h"

#include "pf_shaders.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

#define OP_EXTENSION 10u
#define OP_ENTRY_POINT 15u
#define OP_EXECUTION_MODE 16u
#define OP_CAPABILITY 17u
#define CAPABILITY_DENORM_PRESERVE 4464u
#define MODE_DENORM_PRESERVE 4459u

typedef struct module_counts {
    uint32_t entry_points;
    uint32_t capabilities; /* OpCapability DenormPreserve */
    uint32_t modes;        /* OpExecutionMode <entry> DenormPreserve 32 */
    uint32_t extensions;   /* OpExtension "SPV_KHR_float_controls" */
} module_counts;

/* Walks every instruction: a malformed result fails the word-count check. */
static module_counts count_module(const uint32_t *words, size_t count)
{
    module_counts counts = {0};
    size_t at = 5;
    while (at < count) {
        uint32_t op = words[at] & 0xffffu, n = words[at] >> 16;
        if (n == 0 || at + n > count) {
            PF_CHECK_MSG(0, "instruction at word %zu (op %u, %u words) runs past %zu", at, op,
                         n, count);
            break;
        }
        counts.entry_points += op == OP_ENTRY_POINT;
        counts.capabilities += op == OP_CAPABILITY && words[at + 1] == CAPABILITY_DENORM_PRESERVE;
        counts.modes += op == OP_EXECUTION_MODE && n == 4 &&
                        words[at + 2] == MODE_DENORM_PRESERVE && words[at + 3] == 32;
        counts.extensions += op == OP_EXTENSION &&
                             !strcmp((const char *)&words[at + 1], "SPV_KHR_float_controls");
        at += n;
    }
    return counts;
}

static int spirv_val_accepts(const char *name, const uint32_t *words, size_t count)
{
    char dir[1024], path[1200], command[2600];
    pf_test_tmpdir(dir, sizeof dir);
    snprintf(path, sizeof path, "%s/%s.spv", dir, name);
    FILE *file = fopen(path, "wb");
    PF_CHECK_MSG(file != NULL, "cannot write %s", path);
    if (!file)
        return 0;
    PF_CHECK(fwrite(words, 4, count, file) == count);
    PF_CHECK(fclose(file) == 0);
    snprintf(command, sizeof command, "'%s' --target-env vulkan1.2 '%s'", PF_SPIRV_VAL, path);
    int status = system(command);
    return status != -1 && WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

PF_TEST(every_shader_stays_valid_with_denorm_preserve)
{
    size_t shaders = 0;
    for (const pf_shader_blob *blob; (blob = pf_shader_at(shaders)) != NULL; shaders++) {
        pf_error err = {0};
        uint32_t *patched = NULL, *again = NULL;
        size_t patched_count = 0, again_count = 0;
        size_t count = blob->bytes / 4;
        PF_CHECK_OK(pf_vk_spirv_preserve_denormals(blob->words, count, &patched, &patched_count,
                                                   &err),
                    &err);
        if (!patched)
            continue;
        module_counts before = count_module(blob->words, count);
        module_counts after = count_module(patched, patched_count);
        PF_CHECK_MSG(before.modes == 0 && before.capabilities == 0, "%s", blob->name);
        PF_CHECK_MSG(after.entry_points == 1 && after.modes == 1 && after.capabilities == 1,
                     "%s: %u entry points, %u modes, %u capabilities", blob->name,
                     after.entry_points, after.modes, after.capabilities);
        /* glslang targets SPIR-V 1.5 for Vulkan 1.2: float controls are core there. */
        PF_CHECK_MSG(after.extensions == 0 && patched_count == count + 6,
                     "%s: %zu words from %zu", blob->name, patched_count, count);
        PF_CHECK_MSG(spirv_val_accepts(blob->name, patched, patched_count),
                     "spirv-val rejects %s with DenormPreserve", blob->name);
        /* A module that declares the mode already keeps its words. */
        PF_CHECK_OK(pf_vk_spirv_preserve_denormals(patched, patched_count, &again, &again_count,
                                                   &err),
                    &err);
        PF_CHECK(again && again_count == patched_count &&
                 !memcmp(again, patched, patched_count * 4));
        free(again);
        free(patched);
    }
    PF_CHECK_MSG(shaders >= 20, "only %zu embedded shaders", shaders);
}

/* A malloc'd copy of an embedded shader's words, to alter; NULL (and a failure) if none. */
static uint32_t *shader_copy(const char *name, size_t *count)
{
    const pf_shader_blob *blob = pf_shader_find(name);
    uint32_t *copy = blob ? malloc(blob->bytes) : NULL;
    PF_CHECK_MSG(copy != NULL, "no copy of embedded shader '%s'", name);
    if (copy)
        memcpy(copy, blob->words, blob->bytes);
    *count = blob ? blob->bytes / 4 : 0;
    return copy;
}

PF_TEST(spirv_before_1_4_also_gets_the_extension)
{
    size_t count = 0;
    uint32_t *older = shader_copy("vk_selftest", &count);
    PF_REQUIRE(older != NULL);
    older[1] = 0x00010300u; /* SPIR-V 1.3: SPV_KHR_float_controls is an extension there */
    pf_error err = {0};
    uint32_t *patched = NULL;
    size_t patched_count = 0;
    PF_CHECK_OK(pf_vk_spirv_preserve_denormals(older, count, &patched, &patched_count, &err),
                &err);
    if (patched) {
        module_counts after = count_module(patched, patched_count);
        PF_CHECK(after.extensions == 1 && after.modes == 1 && after.capabilities == 1);
        PF_CHECK(patched_count == count + 6 + 7); /* "SPV_KHR_float_controls\0" is 6 words */
    }
    free(patched);
    free(older);
}

PF_TEST(malformed_modules_are_refused)
{
    const pf_shader_blob *blob = pf_shader_find("vk_selftest");
    size_t count = 0;
    uint32_t *copy = shader_copy("vk_selftest", &count);
    PF_REQUIRE(blob != NULL && copy != NULL);
    pf_error err = {0};
    uint32_t *patched = NULL;
    size_t patched_count = 0;

    memcpy(copy, blob->words, blob->bytes);
    copy[5] = 0xffffu << 16 | (copy[5] & 0xffffu); /* the first instruction runs past the end */
    PF_CHECK(pf_vk_spirv_preserve_denormals(copy, count, &patched, &patched_count, &err) ==
             PF_ERR_FORMAT);
    PF_CHECK(patched == NULL && strstr(err.message, "runs past the end") != NULL);

    memcpy(copy, blob->words, blob->bytes);
    copy[0] = 0;
    PF_CHECK(pf_vk_spirv_preserve_denormals(copy, count, &patched, &patched_count, &err) ==
             PF_ERR_FORMAT);
    PF_CHECK(pf_vk_spirv_preserve_denormals(blob->words, 5, &patched, &patched_count, &err) ==
             PF_ERR_FORMAT);
    PF_CHECK(patched == NULL);
    free(copy);
}

int main(void)
{
    PF_RUN(every_shader_stays_valid_with_denorm_preserve);
    PF_RUN(spirv_before_1_4_also_gets_the_extension);
    PF_RUN(malformed_modules_are_refused);
    return pf_test_finish();
}
