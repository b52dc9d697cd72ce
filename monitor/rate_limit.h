/* Requests per second per client address (rate_limit.c): a token bucket per address. */
#ifndef PF_MONITOR_RATE_LIMIT_H
#define PF_MONITOR_RATE_LIMIT_H

#include <pthread.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/socket.h>

/* Addresses tracked at once; beyond them the least recently seen is forgotten (it starts
 * again with a full bucket: a flood from that many addresses is the connection limit's). */
#define PF_RATE_ADDRESSES 4096

typedef struct pf_rate_bucket {
    unsigned char key[16]; /* the IPv4 or IPv6 address */
    unsigned char key_length;
    double tokens, last_s;
} pf_rate_bucket;

typedef struct pf_rate_limiter {
    pthread_mutex_t lock;
    double per_second, burst; /* per_second 0: no limit */
    pf_rate_bucket *buckets;   /* PF_RATE_ADDRESSES, open addressing */
} pf_rate_limiter;

/* per_second 0: every request allowed. Returns 0, or -1 when out of memory. */
int pf_rate_limiter_init(pf_rate_limiter *limiter, double per_second, double burst);
void pf_rate_limiter_free(pf_rate_limiter *limiter);

/* Takes one request of address's bucket at now_s (a monotonic clock, seconds): 1 allowed;
 * 0 refused, with *retry_after_s the whole seconds until one would be. */
int pf_rate_limit_take(pf_rate_limiter *limiter, const struct sockaddr *address, double now_s,
                       int *retry_after_s);

#endif
