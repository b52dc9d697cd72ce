/* The monitor's shared, polled view of the queue (snapshot.h). */
#include "snapshot.h"

#include "json_views.h"
#include "pf_queue.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* Reads jobs and workers into JSON texts (malloc'ed) with one connection. */
static pf_status read_queue(pf_queue *queue, char **jobs_text, char **workers_text,
                            pf_error *err)
{
    pf_queue_job *jobs = NULL;
    size_t job_count = 0;
    pf_queue_worker_info *workers = NULL;
    size_t worker_count = 0;
    pf_status status = pf_queue_job_list(queue, &jobs, &job_count, err);
    if (status == PF_OK)
        status = pf_queue_worker_list(queue, &workers, &worker_count, err);
    cJSON *job_array = cJSON_CreateArray(), *worker_array = cJSON_CreateArray();
    for (size_t i = 0; status == PF_OK && i < job_count; i++)
        cJSON_AddItemToArray(job_array, pf_monitor_job_json(&jobs[i]));
    for (size_t i = 0; status == PF_OK && i < worker_count; i++)
        cJSON_AddItemToArray(worker_array, pf_monitor_worker_json(&workers[i]));
    pf_queue_job_list_free(jobs, job_count);
    free(workers);
    *jobs_text = status == PF_OK ? cJSON_PrintUnformatted(job_array) : NULL;
    *workers_text = status == PF_OK ? cJSON_PrintUnformatted(worker_array) : NULL;
    cJSON_Delete(job_array);
    cJSON_Delete(worker_array);
    if (status == PF_OK && (!*jobs_text || !*workers_text)) {
        free(*jobs_text);
        free(*workers_text);
        status = pf_error_set(err, PF_ERR_NOMEM, "out of memory building the monitor's view");
    }
    return status;
}

/* Stores a read: a new generation when either text changed. */
static void store(pf_snapshot *snapshot, char *jobs_text, char *workers_text)
{
    pthread_mutex_lock(&snapshot->lock);
    int changed = !snapshot->jobs_json || strcmp(snapshot->jobs_json, jobs_text) != 0 ||
                  strcmp(snapshot->workers_json, workers_text) != 0;
    if (changed) {
        free(snapshot->jobs_json);
        free(snapshot->workers_json);
        snapshot->jobs_json = jobs_text;
        snapshot->workers_json = workers_text;
        snapshot->generation++;
        pthread_cond_broadcast(&snapshot->changed);
    } else {
        free(jobs_text);
        free(workers_text);
    }
    snapshot->reads++;
    snapshot->error[0] = '\0';
    pthread_mutex_unlock(&snapshot->lock);
}

static struct timespec deadline_after(int ms)
{
    struct timespec when;
    clock_gettime(CLOCK_REALTIME, &when);
    when.tv_sec += ms / 1000;
    when.tv_nsec += (long)(ms % 1000) * 1000000L;
    if (when.tv_nsec >= 1000000000L) {
        when.tv_sec++;
        when.tv_nsec -= 1000000000L;
    }
    return when;
}

static void *poll_loop(void *user)
{
    pf_snapshot *snapshot = user;
    pf_queue *queue = NULL;
    for (;;) {
        pthread_mutex_lock(&snapshot->lock);
        struct timespec until = deadline_after(snapshot->poll_ms);
        while (!snapshot->stopping && !snapshot->poked &&
               pthread_cond_timedwait(&snapshot->changed, &snapshot->lock, &until) != ETIMEDOUT)
            continue;
        int stopping = snapshot->stopping, poked = snapshot->poked;
        snapshot->poked = 0;
        pthread_mutex_unlock(&snapshot->lock);
        if (stopping)
            break;
        /* Opened at the first poll that can (the queue re-establishes a lost PostgreSQL
         * connection itself, at the next read). */
        pf_error err = {0};
        char *jobs_text = NULL, *workers_text = NULL;
        pf_status status = queue ? PF_OK : pf_queue_open(snapshot->db_path, NULL, &queue, &err);
        /* Nothing committed since the last read, which is recent: it still holds. The
         * mark is taken before the read, so a commit during the read shows next time. */
        char mark[PF_QUEUE_MARK_MAX] = "";
        double now_ms = pf_time_ms();
        if (status == PF_OK && pf_queue_change_mark(queue, mark, sizeof mark, &err) == PF_OK &&
            !poked && snapshot->mark[0] && !strcmp(mark, snapshot->mark) &&
            now_ms - snapshot->read_at_ms < PF_SNAPSHOT_REFRESH_MS) {
            pthread_mutex_lock(&snapshot->lock);
            snapshot->checks++;
            pthread_mutex_unlock(&snapshot->lock);
            continue;
        }
        if (status == PF_OK)
            status = read_queue(queue, &jobs_text, &workers_text, &err);
        if (status == PF_OK) {
            memcpy(snapshot->mark, mark, sizeof mark); /* the poller's own (not under lock) */
            snapshot->read_at_ms = now_ms;
            store(snapshot, jobs_text, workers_text);
            continue;
        }
        snapshot->mark[0] = '\0';
        pthread_mutex_lock(&snapshot->lock);
        snprintf(snapshot->error, sizeof snapshot->error, "%s", err.message);
        pthread_mutex_unlock(&snapshot->lock);
    }
    pf_queue_close(queue);
    return NULL;
}

pf_status pf_snapshot_start(pf_snapshot *snapshot, const char *db_path, int poll_ms,
                            pf_error *err)
{
    memset(snapshot, 0, sizeof *snapshot);
    pthread_mutex_init(&snapshot->lock, NULL);
    pthread_cond_init(&snapshot->changed, NULL);
    snapshot->poll_ms = poll_ms;
    snapshot->db_path = strdup(db_path);
    pf_queue *queue = NULL;
    char *jobs_text = NULL, *workers_text = NULL;
    pf_status status = snapshot->db_path ? pf_queue_open(db_path, NULL, &queue, err)
                                         : pf_error_set(err, PF_ERR_NOMEM, "out of memory");
    if (status == PF_OK)
        status = read_queue(queue, &jobs_text, &workers_text, err);
    pf_queue_close(queue);
    if (status == PF_OK) {
        store(snapshot, jobs_text, workers_text);
        if (pthread_create(&snapshot->thread, NULL, poll_loop, snapshot) != 0)
            status = pf_error_set(err, PF_ERR_NOMEM, "cannot start the monitor's poller");
    }
    if (status != PF_OK)
        pf_snapshot_free(snapshot);
    return status;
}

void pf_snapshot_stop(pf_snapshot *snapshot)
{
    pthread_mutex_lock(&snapshot->lock);
    snapshot->stopping = 1;
    pthread_cond_broadcast(&snapshot->changed);
    pthread_mutex_unlock(&snapshot->lock);
    pthread_join(snapshot->thread, NULL);
}

void pf_snapshot_free(pf_snapshot *snapshot)
{
    free(snapshot->db_path);
    free(snapshot->jobs_json);
    free(snapshot->workers_json);
    pthread_mutex_destroy(&snapshot->lock);
    pthread_cond_destroy(&snapshot->changed);
}

char *pf_snapshot_copy(pf_snapshot *snapshot, int jobs, uint64_t *generation)
{
    pthread_mutex_lock(&snapshot->lock);
    char *copy = strdup(jobs ? snapshot->jobs_json : snapshot->workers_json);
    if (generation)
        *generation = snapshot->generation;
    pthread_mutex_unlock(&snapshot->lock);
    return copy;
}

uint64_t pf_snapshot_wait(pf_snapshot *snapshot, uint64_t seen, int timeout_ms)
{
    pthread_mutex_lock(&snapshot->lock);
    struct timespec until = deadline_after(timeout_ms);
    while (!snapshot->stopping && snapshot->generation == seen &&
           pthread_cond_timedwait(&snapshot->changed, &snapshot->lock, &until) != ETIMEDOUT)
        continue;
    uint64_t generation = snapshot->stopping ? 0 : snapshot->generation;
    pthread_mutex_unlock(&snapshot->lock);
    return generation;
}

void pf_snapshot_poke(pf_snapshot *snapshot)
{
    pthread_mutex_lock(&snapshot->lock);
    snapshot->poked = 1;
    pthread_cond_broadcast(&snapshot->changed);
    pthread_mutex_unlock(&snapshot->lock);
}

uint64_t pf_snapshot_generation(pf_snapshot *snapshot)
{
    pthread_mutex_lock(&snapshot->lock);
    uint64_t generation = snapshot->generation;
    pthread_mutex_unlock(&snapshot->lock);
    return generation;
}
