/*
 * The packet traversal 8 lanes a vector (bih_cpu_packet_body.h), built with
 * -mavx2 (but no -mfma: the same IEEE operations as the 4-wide build, so the
 * same answers). Only called where the CPU reports AVX2 (bih_cpu_packet.c).
 */
#define PACKET_WIDTH 8
#define PACKET_TRACE pf_bih_trace_packet_8
#include "bih_cpu_packet_body.h"
