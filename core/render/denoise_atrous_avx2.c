/*
 * The host's variance estimate and à-trous pass 8 pixels a vector (denoise_atrous_body.h), built with -mavx2 but
 * no -mfma (the same IEEE operations as the 4-wide build, so the same image). Only called
 * where the CPU reports AVX2 (denoise_atrous.c).
 */
#define ATROUS_WIDTH 8
#define ATROUS_NAME pf_denoise_atrous_rows_8
#define VARIANCE_NAME pf_denoise_variance_rows_8
#include "denoise_atrous_body.h"
