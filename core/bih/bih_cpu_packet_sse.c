/* The packet traversal 4 lanes a vector: x86-64's SSE2 baseline, or any target (bih_cpu_packet_body.h). */
#define PACKET_WIDTH 4
#define PACKET_TRACE pf_bih_trace_packet_4
#include "bih_cpu_packet_body.h"
