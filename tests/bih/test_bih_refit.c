/*
 * pf_bih_refit on the CPU: a tree built (global or SAH heuristic) for one
 * frame, refit to a moved, rotated, deformed, scattered or collapsed copy,
 * passes pf_bih_check against the new frame and its CPU traversal matches CPU
 * brute force exactly (same triangle test on both sides); a translation keeps
 * the SAH cost, scattering the triangles ruins it (what makes frame_bih.c
 * rebuild); refused input leaves the tree untouched.
 */
#include "bih_refit_util.h"

#define REFIT_RAYS 1500u

/* Checks the refit tree against frame: invariants, and closest/any hits against brute force. */
static void check_refit_tree(const char *label, bih_expect expect, const pf_bih *bih,
                             const pf_scene_frame *frame, uint32_t seed)
{
    pf_error err = {0};
    PF_CHECK_OK(pf_bih_check(bih, frame, &err), &err);
    if (err.status != PF_OK)
        return;
    bih_ray_set set;
    PF_REQUIRE(bih_ray_set_alloc(&set, REFIT_RAYS));
    set.aimed = bih_case_rays(expect.inside, frame, bih, seed, set.rays, set.count);
    bih_oracle_cpu(frame, &set);
    bih_trace_cpu_both(label, bih, &set);
    bih_check_answers(label, frame, expect, &set, 1);
    bih_ray_set_free(&set);
}

static double sah_of(const pf_bih *bih)
{
    pf_bih_quality quality;
    pf_bih_quality_measure(bih, &quality);
    return quality.sah_cost;
}

/* Builds original's tree with heuristic, then refits copies of it to every motion. */
static void refit_every_motion(const char *name, int which, const pf_scene_frame *original,
                               uint32_t heuristic, uint32_t seed)
{
    pf_bih_build_options options = {0, 0, heuristic, 0};
    pf_bih built;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_bih_build_cpu(original, &options, &built, &err), &err);
    for (int how = 0; how < MOTION_COUNT; how++) {
        pf_scene_frame moved;
        PF_REQUIRE(moved_copy(original, (motion)how, &moved));
        pf_bih refit;
        PF_REQUIRE(copy_tree(&built, &refit));
        char label[96];
        snprintf(label, sizeof label, "%s, %s build, %s", name,
                 heuristic == PF_BIH_HEURISTIC_SAH ? "SAH" : "global", motion_names[how]);
        PF_CHECK_OK(pf_bih_refit(&refit, &moved, &err), &err);
        /* Topology and leaf assignment stay. */
        PF_CHECK(refit.node_count == built.node_count && refit.depth == built.depth);
        PF_CHECK(!memcmp(refit.triangle_index, built.triangle_index,
                         original->triangle_count * sizeof *built.triangle_index));
        /* Only a translated closed mesh is still closed around its box's middle; moved
         * degenerate triangles may round into real ones. */
        bih_expect expect = {0.0f, 0};
        if (how == MOTION_TRANSLATE)
            expect.inside = bih_case_expect(which).inside;
        check_refit_tree(label, expect, &refit, &moved, seed + (uint32_t)how);

        /* Refitting back gives exactly what refitting the build in place gives. */
        pf_bih direct;
        PF_REQUIRE(copy_tree(&built, &direct));
        PF_CHECK_OK(pf_bih_refit(&direct, original, &err), &err);
        PF_CHECK_OK(pf_bih_refit(&refit, original, &err), &err);
        PF_CHECK_MSG(same_tree(&refit, &direct), "%s: refit back differs", label);
        pf_bih_free(&direct);
        pf_bih_free(&refit);
        bih_frame_free(&moved);
    }
    pf_bih_free(&built);
}

PF_TEST(refit_trees_pass_the_invariants_and_match_brute_force)
{
    /* Cases a motion changes meaningfully, and the edge cases one and zero. */
    const int cases[] = {BIH_CASE_SOUP,      BIH_CASE_CUBE,     BIH_CASE_SOUP_OFFSET,
                         BIH_CASE_FLAT,      BIH_CASE_COPLANAR, BIH_CASE_DEGENERATE,
                         BIH_CASE_CLUSTERED, BIH_CASE_ONE,      BIH_CASE_ZERO};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        pf_scene_frame original;
        const char *name;
        PF_REQUIRE(bih_make_case(cases[i], &original, &name));
        /* The SAH build's empty-space cuts leave empty leaves: their -inf/+inf clips must survive. */
        refit_every_motion(name, cases[i], &original, PF_BIH_HEURISTIC_GLOBAL,
                           500 + 10 * (uint32_t)i);
        refit_every_motion(name, cases[i], &original, PF_BIH_HEURISTIC_SAH,
                           700 + 10 * (uint32_t)i);
        bih_frame_free(&original);
    }
}

/*
 * The figures frame_bih.c's reuse policy relies on: a rigid translation keeps
 * the (normalised) SAH exactly, scattering or collapsing triangles ruins it.
 * The other motions are printed for reference.
 */
PF_TEST(rigid_motion_keeps_the_sah_and_scattering_ruins_it)
{
    pf_scene_frame original;
    PF_REQUIRE(bih_make_soup(&original, 2000, 99));
    pf_bih built;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_bih_build_cpu(&original, NULL, &built, &err), &err);
    double built_sah = sah_of(&built);
    PF_REQUIRE(built_sah > 0.0);
    for (int how = 0; how < MOTION_COUNT; how++) {
        pf_scene_frame moved;
        PF_REQUIRE(moved_copy(&original, (motion)how, &moved));
        pf_bih refit, fresh;
        PF_REQUIRE(copy_tree(&built, &refit));
        PF_REQUIRE_OK(pf_bih_refit(&refit, &moved, &err), &err);
        PF_REQUIRE_OK(pf_bih_build_cpu(&moved, NULL, &fresh, &err), &err);
        double refit_sah = sah_of(&refit), fresh_sah = sah_of(&fresh);
        printf("  %-9s: built %.3f, refit %.3f, fresh build %.3f\n", motion_names[how], built_sah,
               refit_sah, fresh_sah);
        if (how == MOTION_TRANSLATE)
            PF_CHECK_NEAR(refit_sah, built_sah, 1e-3 * built_sah);
        /* Scattered or collapsed, leaves span far-apart triangles: worse than any 10%. */
        if (how == MOTION_SCATTER || how == MOTION_COLLAPSE)
            PF_CHECK_MSG(refit_sah > 1.10 * fresh_sah && refit_sah > 1.10 * built_sah,
                         "%s: refit SAH %.3f vs fresh %.3f, built %.3f", motion_names[how],
                         refit_sah, fresh_sah, built_sah);
        pf_bih_free(&refit);
        pf_bih_free(&fresh);
        bih_frame_free(&moved);
    }
    pf_bih_free(&built);
    bih_frame_free(&original);
}

PF_TEST(refused_input_leaves_the_tree_untouched)
{
    pf_scene_frame original;
    PF_REQUIRE(bih_make_soup(&original, 300, 5));
    pf_bih built, tree;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_bih_build_cpu(&original, NULL, &built, &err), &err);
    PF_REQUIRE(copy_tree(&built, &tree));

    /* One triangle fewer, one more: a refit keeps the triangles, so it is refused. */
    pf_scene_frame other;
    for (int delta = -1; delta <= 1; delta += 2) {
        PF_REQUIRE(bih_frame_alloc(&other, original.triangle_count + (uint32_t)delta));
        uint32_t common = delta < 0 ? other.triangle_count : original.triangle_count;
        memcpy(other.vertices, original.vertices, 3 * (size_t)common * sizeof *other.vertices);
        bih_frame_bounds(&other);
        PF_CHECK(pf_bih_refit(&tree, &other, &err) == PF_ERR_INVALID);
        PF_CHECK_MSG(strstr(err.message, "300") != NULL, "message: %s", err.message);
        bih_frame_free(&other);
    }
    /* A NaN vertex, last, so a refit that wrote as it checked would have changed the tree. */
    PF_REQUIRE(moved_copy(&original, MOTION_TRANSLATE, &other));
    other.vertices[3 * other.triangle_count - 1][1] = NAN;
    PF_CHECK(pf_bih_refit(&tree, &other, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "triangle 299") != NULL, "message: %s", err.message);
    PF_CHECK(same_tree(&tree, &built));
    PF_CHECK_OK(pf_bih_check(&tree, &original, &err), &err);
    bih_frame_free(&other);

    /* A malformed tree (a child index past the end) is refused, not followed. */
    uint32_t saved = tree.nodes[0].word;
    tree.nodes[0].word = (tree.node_count << 2) | (saved & 3u);
    PF_CHECK(pf_bih_refit(&tree, &original, &err) == PF_ERR_INVALID);
    tree.nodes[0].word = saved;
    PF_CHECK(same_tree(&tree, &built));
    PF_CHECK(pf_bih_refit(NULL, &original, &err) == PF_ERR_INVALID);
    pf_bih_free(&tree);
    pf_bih_free(&built);
    bih_frame_free(&original);
}

int main(void)
{
    PF_RUN(refit_trees_pass_the_invariants_and_match_brute_force);
    PF_RUN(rigid_motion_keeps_the_sah_and_scattering_ruins_it);
    PF_RUN(refused_input_leaves_the_tree_untouched);
    return pf_test_finish();
}
