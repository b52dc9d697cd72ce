/*
 * The CPU packet traversal's entry points (contracts in pf_bih.h): the vector
 * width picked at run time, and any number of rays cut into packets.
 */
#include "bih_internal.h"

pf_bih_packet_trace_fn pf_bih_packet_tracer(uint32_t width)
{
    if (width == 4)
        return pf_bih_trace_packet_4;
#if defined(PF_BIH_AVX2_PACKETS)
    /* The 8-wide build's code is AVX2 throughout: only where the CPU (and its OS) runs it. */
    if (width == 8 && __builtin_cpu_supports("avx2"))
        return pf_bih_trace_packet_8;
#endif
    return NULL;
}

pf_status pf_bih_trace_cpu_packet(const pf_bih *bih, const pf_ray *rays, uint32_t count,
                                  int any_hit, pf_hit *hits, pf_error *err)
{
    if (count > PF_BIH_PACKET_RAYS)
        return pf_error_set(err, PF_ERR_INVALID, "BIH packet: %u rays (at most %u)", count,
                            (unsigned)PF_BIH_PACKET_RAYS);
    pf_bih_packet_trace_fn trace = pf_bih_packet_tracer(8);
    if (!trace)
        trace = pf_bih_trace_packet_4;
    return trace(bih, rays, count, any_hit, hits, err);
}

pf_status pf_bih_trace_cpu_rays(const pf_bih *bih, const pf_ray *rays, uint32_t count,
                                int any_hit, pf_hit *hits, pf_error *err)
{
    /*
     * Packets of consecutive rays, in the caller's order. Binning bounce rays
     * by direction (octant and dominant axis, then origin) was tried: it
     * helped staircase2's bounces by ~10 % and cost the 1M sphere's a third,
     * whose binned packets gathered rays from far-apart origins; neighbouring
     * pixels' bounces start close together and part ways late enough. Sorting
     * by origin alone cost primary and shadow rays 15-20 % (bench/RESULTS.md).
     */
    pf_status status = PF_OK;
    for (uint32_t i = 0; i < count && status == PF_OK; i += PF_BIH_PACKET_RAYS) {
        uint32_t n = count - i < PF_BIH_PACKET_RAYS ? count - i : PF_BIH_PACKET_RAYS;
        status = pf_bih_trace_cpu_packet(bih, &rays[i], n, any_hit, &hits[i], err);
    }
    return status;
}
