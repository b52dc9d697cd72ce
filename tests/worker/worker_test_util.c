/* Helpers for the worker tests (see worker_test_util.h). */
#include "worker_test_util.h"

#include "pf_image.h"
#include "pf_test.h"

#include <dirent.h>
#include <stdarg.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

/* One triangle (-1,-1,0) (1,-1,0) (0,1,0) as float32 positions + uint16 indices 0,1,2 + 2 bytes of padding. */
#define TINY_BUFFER_BASE64 "AACAvwAAgL8AAAAAAACAPwAAgL8AAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA="
/* The tiny triangle's buffer, views and accessors (0 positions, 1 indices), the glTF's end. */
#define TINY_TRIANGLE_DATA                                                                   \
    " \"buffers\":[{\"byteLength\":44,\"uri\":\"data:application/octet-stream;base64,"         \
    TINY_BUFFER_BASE64 "\"}],\n"                                                              \
    " \"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36},\n"                  \
    "  {\"buffer\":0,\"byteOffset\":36,\"byteLength\":6}],\n"                                  \
    " \"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\","    \
    "\"min\":[-1,-1,0],\"max\":[1,1,0]},\n"                                                   \
    "  {\"bufferView\":1,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]}\n"

void wt_format(char *out, size_t size, const char *format, ...)
{
    va_list args;
    va_start(args, format);
    int written = vsnprintf(out, size, format, args);
    va_end(args);
    PF_CHECK_MSG(written >= 0 && (size_t)written < size, "path or command too long: %s", out);
}

void wt_sleep_ms(int ms)
{
    struct timespec delay = {ms / 1000, (long)(ms % 1000) * 1000000L};
    while (nanosleep(&delay, &delay) != 0 && errno == EINTR) {
    }
}

int wt_run(const char *arguments, const char *output_path)
{
    const char *binary = getenv("PHOTONFARM");
    char default_log[WT_PATH_MAX + 32], command[3 * WT_PATH_MAX];
    if (!output_path) {
        char tmp[WT_PATH_MAX];
        snprintf(default_log, sizeof default_log, "%s/last-run.log", pf_test_tmpdir(tmp, sizeof tmp));
        output_path = default_log;
    }
    snprintf(command, sizeof command, "'%s' %s >'%s' 2>&1", binary ? binary : "photonfarm",
             arguments, output_path);
    int status = system(command);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

char *wt_read_file(const char *path, size_t *size)
{
    FILE *file = fopen(path, "rb");
    if (!file)
        return NULL;
    fseek(file, 0, SEEK_END);
    long length = ftell(file);
    fseek(file, 0, SEEK_SET);
    char *buffer = malloc((size_t)length + 1);
    size_t got = fread(buffer, 1, (size_t)length, file);
    fclose(file);
    buffer[got] = '\0';
    if (size)
        *size = got;
    return buffer;
}

int wt_file_contains(const char *path, const char *text)
{
    char *content = wt_read_file(path, NULL);
    int found = content && strstr(content, text) != NULL;
    if (!found)
        fprintf(stderr, "expected '%s' in %s:\n%s\n", text, path, content ? content : "(missing)");
    free(content);
    return found;
}

int wt_exr_frame(const char *path)
{
    pf_image image = {0};
    pf_image_attribute *attributes = NULL;
    uint32_t count = 0;
    pf_error err = {0};
    int frame = -1;
    if (pf_exr_read(path, &image, &attributes, &count, &err) == PF_OK) {
        const char *value = pf_image_attribute_value(attributes, count, "photonfarm/frame");
        if (value)
            frame = atoi(value);
    }
    free(attributes);
    pf_image_free(&image);
    return frame;
}

int wt_count_in_file(const char *path, const char *text)
{
    char *content = wt_read_file(path, NULL);
    int count = 0;
    for (const char *at = content; at && (at = strstr(at, text)) != NULL; at += strlen(text))
        count++;
    free(content);
    return count;
}

int64_t wt_enqueue(const char *arguments, const char *log_path)
{
    char command[16 * WT_PATH_MAX];
    wt_format(command, sizeof command, "enqueue %s", arguments);
    int code = wt_run(command, log_path);
    PF_CHECK_MSG(code == 0, "enqueue exited %d", code);
    /* The id is stdout's one line; stderr (warnings, the summary) shares the log. */
    char *printed = code == 0 ? wt_read_file(log_path, NULL) : NULL;
    int64_t job_id = 0;
    for (char *line = printed; line && *line && !job_id; line = strchr(line, '\n')) {
        line += *line == '\n';
        size_t digits = strspn(line, "0123456789");
        if (digits > 0 && (line[digits] == '\n' || line[digits] == '\0'))
            job_id = atoll(line);
    }
    free(printed);
    return job_id;
}

pid_t wt_spawn(const char *const *arguments, const char *log_path, const char *environment)
{
    const char *binary = getenv("PHOTONFARM");
    pid_t pid = fork();
    if (pid == 0) {
        int fd = open(log_path, O_WRONLY | O_CREAT | O_APPEND, 0644);
        if (fd >= 0) {
            dup2(fd, 1);
            dup2(fd, 2);
            close(fd);
        }
        /* One "KEY=VALUE" per line; putenv keeps the strings (this process execs). */
        for (char *rest = environment ? strdup(environment) : NULL, *line;
             rest && (line = strsep(&rest, "\n")) != NULL;)
            if (*line)
                putenv(line);
        char *argv[32];
        int count = 0;
        argv[count++] = (char *)(binary ? binary : "photonfarm");
        for (int i = 0; arguments[i] && count < 31; i++)
            argv[count++] = (char *)arguments[i];
        argv[count] = NULL;
        execv(argv[0], argv);
        _exit(127);
    }
    return pid;
}

void wt_fault_environment(char *out, size_t size, const char *dir, const char *flip,
                          const char *kind, int hold_ms)
{
    const char *preloaded = getenv("LD_PRELOAD"), *library = getenv("PF_FAULT_INJECT_LIB");
    PF_CHECK_MSG(library != NULL, "PF_FAULT_INJECT_LIB is not set");
    wt_format(out, size,
              "LD_PRELOAD=%s%s%s\nPF_FAULT_DIR=%s\nPF_FAULT_SWITCH=%s\nPF_FAULT_KIND=%s\n"
              "PF_FAULT_HOLD_MS=%d\nASAN_OPTIONS=verify_asan_link_order=0",
              preloaded ? preloaded : "", preloaded ? " " : "", library ? library : "", dir,
              flip ? flip : "", kind ? kind : "read-only", hold_ms);
}

int wt_wait(pid_t pid, int timeout_ms)
{
    for (int waited = 0;; waited += 20) {
        int status = 0;
        pid_t done = waitpid(pid, &status, WNOHANG);
        if (done == pid) {
            if (WIFEXITED(status))
                return WEXITSTATUS(status);
            return WIFSIGNALED(status) ? 128 + WTERMSIG(status) : -1;
        }
        if (waited >= timeout_ms) {
            kill(pid, SIGKILL);
            waitpid(pid, &status, 0);
            fprintf(stderr, "process %ld did not exit within %d ms (killed)\n", (long)pid,
                    timeout_ms);
            return -1;
        }
        wt_sleep_ms(20);
    }
}

void wt_write_tiny_scene(const char *path, int frame_count)
{
    FILE *file = fopen(path, "wb");
    if (!file)
        return;
    fprintf(file,
            "{\"asset\":{\"version\":\"2.0\",\"extras\":{\"frames\":%d,\"fps\":24}},\n"
            " \"extensionsUsed\":[\"KHR_lights_punctual\"],\n"
            " \"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"point\","
            "\"intensity\":6830}]}},\n"
            " \"scene\":0,\"scenes\":[{\"nodes\":[0,1,2]}],\n"
            " \"nodes\":[{\"mesh\":0},{\"camera\":0,\"translation\":[0,0,3]},\n"
            "  {\"translation\":[0,0,2],\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}],\n"
            " \"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.8,\"znear\":0.1}}],\n"
            " \"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}],\n"
            TINY_TRIANGLE_DATA,
            frame_count);
    fclose(file);
}

void wt_write_variant_scene(const char *path)
{
    FILE *file = fopen(path, "wb");
    if (!file)
        return;
    fputs("{\"asset\":{\"version\":\"2.0\"},\n"
          " \"extensionsUsed\":[\"KHR_materials_unlit\",\"KHR_materials_variants\"],\n"
          " \"extensions\":{\"KHR_materials_variants\":{\"variants\":[{\"name\":\"red\"},"
          "{\"name\":\"blue\"}]}},\n"
          " \"scene\":0,\"scenes\":[{\"nodes\":[0,1]}],\n"
          " \"nodes\":[{\"mesh\":0},{\"camera\":0,\"translation\":[0,0,3]}],\n"
          " \"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.8,\"znear\":0.1}}],\n"
          " \"materials\":[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.8,0.05,0.05,1]},"
          "\"extensions\":{\"KHR_materials_unlit\":{}}},\n"
          "  {\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.05,0.05,0.8,1]},"
          "\"extensions\":{\"KHR_materials_unlit\":{}}}],\n"
          " \"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,"
          "\"material\":0,\"extensions\":{\"KHR_materials_variants\":{\"mappings\":["
          "{\"material\":1,\"variants\":[1]}]}}}]}],\n"
          TINY_TRIANGLE_DATA,
          file);
    fclose(file);
}

const char *wt_fresh_dir(const char *name, char *out, size_t size)
{
    char tmp[WT_PATH_MAX];
    pf_test_tmpdir(tmp, sizeof tmp);
    if (snprintf(out, size, "%s/%s", tmp, name) >= (int)size)
        return out;
    mkdir(out, 0755);
    DIR *dir = opendir(out);
    if (dir) {
        struct dirent *entry;
        char path[2 * WT_PATH_MAX + 2];
        while ((entry = readdir(dir)) != NULL) {
            if (entry->d_name[0] == '.' && (!entry->d_name[1] || !strcmp(entry->d_name, "..")))
                continue;
            snprintf(path, sizeof path, "%s/%s", out, entry->d_name);
            unlink(path);
        }
        closedir(dir);
    }
    return out;
}

int wt_count_files(const char *dir_path, const char *text)
{
    DIR *dir = opendir(dir_path);
    if (!dir)
        return -1;
    int count = 0;
    struct dirent *entry;
    while ((entry = readdir(dir)) != NULL) {
        if (!strcmp(entry->d_name, ".") || !strcmp(entry->d_name, ".."))
            continue;
        if (strstr(entry->d_name, text))
            count++;
    }
    closedir(dir);
    return count;
}

pf_queue *wt_open_queue(const char *path)
{
    pf_queue *queue = NULL;
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_open(path, NULL, &queue, &err), &err);
    return queue;
}

int wt_count_query(const char *db_path, const char *sql, int64_t id, const char *text)
{
    sqlite3 *db = NULL;
    if (sqlite3_open_v2(db_path, &db, SQLITE_OPEN_READONLY, NULL) != SQLITE_OK) {
        sqlite3_close(db);
        return -1;
    }
    sqlite3_stmt *statement = NULL;
    int count = -1;
    if (sqlite3_prepare_v2(db, sql, -1, &statement, NULL) == SQLITE_OK) {
        sqlite3_bind_int64(statement, 1, id);
        if (text)
            sqlite3_bind_text(statement, 2, text, -1, SQLITE_STATIC);
        if (sqlite3_step(statement) == SQLITE_ROW)
            count = sqlite3_column_int(statement, 0);
    }
    sqlite3_finalize(statement);
    sqlite3_close(db);
    return count;
}

int wt_stage_rows_for_task(const char *db_path, int64_t task_id, const char *stage)
{
    return wt_count_query(db_path,
                          "SELECT count(*) FROM stage_timings WHERE task_id = ?1 AND stage = ?2",
                          task_id, stage);
}
