/*
 * The monitor's bound on requests per second (issue 41): each client address has a token
 * bucket of `burst` requests, refilled at `per_second`; a request finding it empty is
 * answered 429 with Retry-After. Addresses live in a fixed open-addressing table, so
 * neither many clients nor a flood of addresses grows the server's memory.
 */
#include "rate_limit.h"

#include <math.h>
#include <netinet/in.h>
#include <stdlib.h>
#include <string.h>

/* Slots looked at from an address's hash before the least recently seen one is reused. */
#define PROBES 16

int pf_rate_limiter_init(pf_rate_limiter *limiter, double per_second, double burst)
{
    memset(limiter, 0, sizeof *limiter);
    limiter->per_second = per_second;
    limiter->burst = burst < 1.0 ? 1.0 : burst;
    if (per_second <= 0)
        return 0;
    limiter->buckets = calloc(PF_RATE_ADDRESSES, sizeof *limiter->buckets);
    if (!limiter->buckets)
        return -1;
    pthread_mutex_init(&limiter->lock, NULL);
    return 0;
}

void pf_rate_limiter_free(pf_rate_limiter *limiter)
{
    if (limiter->buckets)
        pthread_mutex_destroy(&limiter->lock);
    free(limiter->buckets);
    limiter->buckets = NULL;
}

/* The address's bytes (4 or 16); 0 for another family. */
static size_t address_key(const struct sockaddr *address, unsigned char key[16])
{
    if (address && address->sa_family == AF_INET) {
        memcpy(key, &((const struct sockaddr_in *)address)->sin_addr, 4);
        return 4;
    }
    if (address && address->sa_family == AF_INET6) {
        memcpy(key, &((const struct sockaddr_in6 *)address)->sin6_addr, 16);
        return 16;
    }
    return 0;
}

static uint32_t hash_key(const unsigned char *key, size_t length)
{
    uint32_t h = 2166136261u; /* FNV-1a */
    for (size_t i = 0; i < length; i++)
        h = (h ^ key[i]) * 16777619u;
    return h;
}

/* The address's bucket: found, or a free slot, or the least recently seen one among the
 * probed ones, reset full. */
static pf_rate_bucket *bucket_of(pf_rate_limiter *limiter, const unsigned char *key,
                                 size_t length, double now_s)
{
    uint32_t start = hash_key(key, length);
    pf_rate_bucket *oldest = NULL;
    for (uint32_t i = 0; i < PROBES; i++) {
        pf_rate_bucket *bucket = &limiter->buckets[(start + i) % PF_RATE_ADDRESSES];
        if (bucket->key_length == length && !memcmp(bucket->key, key, length))
            return bucket;
        if (bucket->key_length == 0 || !oldest || bucket->last_s < oldest->last_s)
            oldest = bucket;
        if (bucket->key_length == 0)
            break;
    }
    memcpy(oldest->key, key, length);
    oldest->key_length = (unsigned char)length;
    oldest->tokens = limiter->burst;
    oldest->last_s = now_s;
    return oldest;
}

int pf_rate_limit_take(pf_rate_limiter *limiter, const struct sockaddr *address, double now_s,
                       int *retry_after_s)
{
    unsigned char key[16];
    size_t length = address_key(address, key);
    if (limiter->per_second <= 0 || length == 0)
        return 1;
    pthread_mutex_lock(&limiter->lock);
    pf_rate_bucket *bucket = bucket_of(limiter, key, length, now_s);
    double elapsed = now_s - bucket->last_s;
    if (elapsed > 0)
        bucket->tokens = fmin(limiter->burst, bucket->tokens + elapsed * limiter->per_second);
    bucket->last_s = now_s;
    int allowed = bucket->tokens >= 1.0;
    if (allowed)
        bucket->tokens -= 1.0;
    else
        *retry_after_s = (int)ceil((1.0 - bucket->tokens) / limiter->per_second);
    pthread_mutex_unlock(&limiter->lock);
    return allowed;
}
