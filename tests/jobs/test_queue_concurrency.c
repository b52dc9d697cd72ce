/*
 * Atomic claims across processes: 4 forked workers on one database claim and
 * complete 200 one-frame tasks at once, 40 more of a job that requires a GPU
 * and a tag (issue 42), which only the two workers registered with both may
 * take, 20 of a job that waits for the first one (--after) and 40 of one whose
 * frame n waits for the demanding job's frame n (--after-frames). Every task
 * must be completed exactly once (each child logs what it completed), none
 * lost, every completion's stage rows present exactly once, no task of the
 * demanding job done by a worker that does not meet it, and no waiting frame
 * claimed before what it waits for was done.
 */
#include "queue_test_util.h"

#include "pf_test.h"

#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define WORKER_COUNT 4
#define FRAME_COUNT 200
/* The second job's frames: task ids FRAME_COUNT + 1 .. TASK_COUNT. */
#define GPU_FRAME_COUNT 40
/* The third (after the first) and fourth (frame by frame after the second). */
#define AFTER_FRAME_COUNT 20
#define AFTER_FRAMES_FRAME_COUNT GPU_FRAME_COUNT
#define TASK_COUNT (FRAME_COUNT + GPU_FRAME_COUNT + AFTER_FRAME_COUNT + AFTER_FRAMES_FRAME_COUNT)
/* A worker that finds nothing to claim while frames still wait polls again after this. */
#define WAIT_POLL_NS 2000000L
#define STAGES_PER_FRAME 2
/* Stand-in for rendering a tiny frame, outside any transaction as a real
 * worker's render is; without it one process can win every lock in a row
 * and the others never race. */
#define RENDER_PAUSE_NS 2000000L

enum child_exit { CHILD_OK = 0, CHILD_QUEUE_ERROR = 10, CHILD_REPEATED = 11, CHILD_LOG = 12 };

/* A worker process: claim, complete with two stage rows, log the task id.
 * It starts claiming when start_gate reaches end of file, so that all four
 * are connected and racing from the first claim. */
static int run_child(const char *db_path, const char *log_path, int index, int start_gate)
{
    pf_queue *queue = NULL;
    pf_error err = {0};
    FILE *log = fopen(log_path, "w");
    if (!log)
        return CHILD_LOG;
    if (pf_queue_open(db_path, NULL, &queue, &err) != PF_OK) {
        fprintf(stderr, "child %d: %s\n", index, err.message);
        return CHILD_QUEUE_ERROR;
    }
    char name[32];
    snprintf(name, sizeof name, "worker-%d", index);
    /* Workers 0 and 1 have a GPU and the tag the second job asks for; 2 and 3 do not. */
    pf_queue_worker_spec spec = {.name = name, .host = "test", .pid = getpid(),
                                 .device_type = index < 2 ? "gpu" : "cpu",
                                 .tags = index < 2 ? "farm-a" : ""};
    int64_t worker_id = 0;
    int result = CHILD_OK;
    if (pf_queue_worker_register(queue, &spec, &worker_id, &err) != PF_OK)
        result = CHILD_QUEUE_ERROR;
    char byte;
    while (read(start_gate, &byte, 1) > 0)
        continue;
    int64_t loaded_job = 0;
    int32_t last_frame = 0;
    while (result == CHILD_OK) {
        pf_queue_task task;
        bool claimed = false;
        if (pf_queue_claim(queue, worker_id, loaded_job, last_frame, &task, &claimed, &err)) {
            result = CHILD_QUEUE_ERROR;
            break;
        }
        if (!claimed && queue_test_query_int(db_path, "SELECT count(*) FROM tasks WHERE "
                                                      "status = 'queued'") == 0)
            break; /* every task is claimed: the others finish theirs */
        if (!claimed) { /* frames that wait for others' */
            nanosleep(&(struct timespec){0, WAIT_POLL_NS}, NULL);
            continue;
        }
        nanosleep(&(struct timespec){0, RENDER_PAUSE_NS}, NULL);
        pf_queue_stage_row rows[STAGES_PER_FRAME] = {
            {task.first_frame, "render", task.first_frame * 0.5, 1.0, NULL, false, NULL},
            {task.first_frame, "write", 0.25, PF_QUEUE_NO_GPU_MS, NULL, false, NULL},
        };
        bool repeated = false;
        if (pf_queue_complete(queue, task.lease_token, rows, STAGES_PER_FRAME, &repeated, &err)) {
            result = CHILD_QUEUE_ERROR;
            break;
        }
        if (repeated)
            result = CHILD_REPEATED;
        fprintf(log, "%lld\n", (long long)task.task_id);
        loaded_job = task.job_id;
        last_frame = task.last_frame;
    }
    if (result == CHILD_QUEUE_ERROR)
        fprintf(stderr, "child %d: %s\n", index, err.message);
    pf_queue_close(queue);
    return fclose(log) == 0 ? result : CHILD_LOG;
}

/* What the database says, read past the queue's API. */
static int64_t count(const char *db_path, const char *sql)
{
    return queue_test_query_int(db_path, sql);
}

PF_TEST(four_processes_complete_each_task_exactly_once)
{
    char db_path[1200], dir[1024];
    fresh_db_path("concurrent.db", db_path, sizeof db_path);
    pf_test_tmpdir(dir, sizeof dir);
    pf_queue *queue = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_queue_open(db_path, NULL, &queue, &err), &err);
    pf_queue_job_spec spec = {.scene_path = "tiny.gltf", .frame_range = "1-200",
                              .output_pattern = "tiny_####.exr"};
    int64_t job_id = 0;
    PF_REQUIRE_OK(pf_queue_enqueue(queue, &spec, &job_id, &err), &err);
    pf_queue_job_spec demanding = {.scene_path = "big.gltf", .frame_range = "1-40",
                                   .output_pattern = "big_####.exr", .requires_device = "gpu",
                                   .required_tags = "farm-a"};
    int64_t demanding_id = 0;
    PF_REQUIRE_OK(pf_queue_enqueue(queue, &demanding, &demanding_id, &err), &err);
    pf_queue_dependency after_first = {job_id, false}, after_frames = {demanding_id, true};
    pf_queue_job_spec waiting = {.scene_path = "comp.gltf", .frame_range = "1-20",
                                 .output_pattern = "comp_####.exr", .priority = 5,
                                 .after = &after_first, .after_count = 1};
    int64_t waiting_id = 0, frame_waiting_id = 0;
    PF_REQUIRE_OK(pf_queue_enqueue(queue, &waiting, &waiting_id, &err), &err);
    pf_queue_job_spec frame_waiting = {.scene_path = "grade.gltf", .frame_range = "1-40",
                                       .output_pattern = "grade_####.exr", .priority = 5,
                                       .after = &after_frames, .after_count = 1};
    PF_REQUIRE_OK(pf_queue_enqueue(queue, &frame_waiting, &frame_waiting_id, &err), &err);
    pf_queue_close(queue); /* a connection must not cross fork() */

    char log_paths[WORKER_COUNT][1200];
    pid_t children[WORKER_COUNT];
    int gate[2];
    PF_REQUIRE(pipe(gate) == 0);
    for (int i = 0; i < WORKER_COUNT; i++) {
        snprintf(log_paths[i], sizeof log_paths[i], "%s/completed-%d.txt", dir, i);
        fflush(NULL);
        children[i] = fork();
        PF_REQUIRE(children[i] >= 0);
        if (children[i] == 0) {
            close(gate[1]);
            _exit(run_child(db_path, log_paths[i], i, gate[0]));
        }
    }
    close(gate[0]);
    close(gate[1]); /* opens the gate */
    for (int i = 0; i < WORKER_COUNT; i++) {
        int wait_status = 0;
        PF_CHECK(waitpid(children[i], &wait_status, 0) == children[i]);
        PF_CHECK_MSG(WIFEXITED(wait_status) && WEXITSTATUS(wait_status) == CHILD_OK,
                     "child %d exited with status %d", i, wait_status);
    }

    /* Each task id appears in exactly one log, exactly once. */
    int completions[TASK_COUNT + 1] = {0};
    int per_child[WORKER_COUNT] = {0};
    for (int i = 0; i < WORKER_COUNT; i++) {
        FILE *log = fopen(log_paths[i], "r");
        PF_REQUIRE(log);
        long long task_id;
        while (fscanf(log, "%lld", &task_id) == 1) {
            PF_CHECK(task_id >= 1 && task_id <= TASK_COUNT);
            if (task_id >= 1 && task_id <= TASK_COUNT)
                completions[task_id]++;
            per_child[i]++;
        }
        fclose(log);
    }
    int once = 0;
    for (int task = 1; task <= TASK_COUNT; task++) {
        PF_CHECK_MSG(completions[task] == 1, "task %d completed %d times", task,
                     completions[task]);
        once += completions[task] == 1;
    }
    PF_CHECK(once == TASK_COUNT);
    /* The race really happened: more than one process completed frames. */
    int busy_children = 0;
    for (int i = 0; i < WORKER_COUNT; i++)
        busy_children += per_child[i] > 0;
    PF_CHECK_MSG(busy_children >= 2, "only %d worker process completed frames", busy_children);
    printf("completions per worker: %d %d %d %d\n", per_child[0], per_child[1], per_child[2],
           per_child[3]);

    PF_CHECK(count(db_path, "SELECT count(*) FROM tasks WHERE status = 'done'") == TASK_COUNT);
    PF_CHECK(count(db_path, "SELECT count(*) FROM tasks WHERE attempt != 1") == 0);
    PF_CHECK(count(db_path, "SELECT count(*) FROM task_failures") == 0);
    PF_CHECK(count(db_path, "SELECT count(*) FROM stage_timings") ==
             TASK_COUNT * STAGES_PER_FRAME);
    /* Exactly one row per (task, stage), and each on the task's own frame. */
    PF_CHECK(count(db_path, "SELECT count(*) FROM (SELECT task_id, stage FROM stage_timings "
                           "GROUP BY task_id, stage HAVING count(*) != 1) AS twice") == 0);
    PF_CHECK(count(db_path, "SELECT count(DISTINCT task_id) FROM stage_timings") == TASK_COUNT);
    PF_CHECK(count(db_path, "SELECT count(*) FROM stage_timings s JOIN tasks t ON t.id = "
                           "s.task_id WHERE s.frame != t.first_frame") == 0);
    PF_CHECK(count(db_path, "SELECT count(*) FROM jobs WHERE status = 'done'") == 4);
    /* Not one of the demanding job's frames went to a worker without a GPU and the tag. */
    char sql[256];
    snprintf(sql, sizeof sql,
             "SELECT count(*) FROM tasks t JOIN workers w ON w.id = t.worker_id WHERE "
             "t.job_id = %lld AND (w.device_type <> 'gpu' OR w.tags <> 'farm-a')",
             (long long)demanding_id);
    PF_CHECK(count(db_path, sql) == 0);
    snprintf(sql, sizeof sql,
             "SELECT count(*) FROM tasks WHERE job_id = %lld AND status = 'done'",
             (long long)demanding_id);
    PF_CHECK(count(db_path, sql) == GPU_FRAME_COUNT);
    /* No frame of the third job claimed before the first job's last frame was done, and
     * no frame n of the fourth before the second's frame n (times in ms: equal is after). */
    snprintf(sql, sizeof sql,
             "SELECT count(*) FROM tasks t WHERE t.job_id = %lld AND t.started_at < "
             "(SELECT max(p.finished_at) FROM tasks p WHERE p.job_id = %lld)",
             (long long)waiting_id, (long long)job_id);
    PF_CHECK(count(db_path, sql) == 0);
    snprintf(sql, sizeof sql,
             "SELECT count(*) FROM tasks t JOIN tasks p ON p.job_id = %lld AND "
             "p.first_frame = t.first_frame WHERE t.job_id = %lld AND "
             "t.started_at < p.finished_at",
             (long long)demanding_id, (long long)frame_waiting_id);
    PF_CHECK(count(db_path, sql) == 0);
    snprintf(sql, sizeof sql, "SELECT count(*) FROM tasks WHERE job_id IN (%lld, %lld) AND "
             "status = 'done'", (long long)waiting_id, (long long)frame_waiting_id);
    PF_CHECK(count(db_path, sql) == AFTER_FRAME_COUNT + AFTER_FRAMES_FRAME_COUNT);
}

int main(void)
{
    PF_RUN(four_processes_complete_each_task_exactly_once);
    return pf_test_finish();
}
