/* The table-driven option parser and help printer of every subcommand (cli_options.h). */
#include "cli_options.h"
#include "cli_queue.h"
#include "pf_cli.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Column where option descriptions start in --help. */
#define HELP_COLUMN 26
/* Lines of --help stay within this many columns where the texts allow. */
#define HELP_WIDTH 80

int pf_cli_store_flag(const char *command, const pf_cli_option *option, const char *value)
{
    (void)command;
    (void)value;
    *(int *)option->target = 1;
    return 0;
}

int pf_cli_store_text(const char *command, const pf_cli_option *option, const char *value)
{
    (void)command;
    *(const char **)option->target = value;
    return 0;
}

int pf_cli_store_int(const char *command, const pf_cli_option *option, const char *value)
{
    if (!pf_cli_parse_int(value, option->min, option->max, (int64_t *)option->target))
        return pf_cli_fail(command, 2, "%s '%s': expected an integer %lld..%lld", option->name,
                           value, (long long)option->min, (long long)option->max);
    return 0;
}

int pf_cli_store_choice(const char *command, const pf_cli_option *option, const char *value)
{
    size_t length = strlen(value);
    for (const char *word = option->choices; word && *word;) {
        size_t word_length = strcspn(word, "|");
        if (word_length == length && !strncmp(word, value, length)) {
            *(const char **)option->target = value;
            return 0;
        }
        word += word_length + (word[word_length] == '|');
    }
    return pf_cli_fail(command, 2, "%s '%s': expected one of %s", option->name, value,
                       option->choices);
}

int pf_cli_store_tag(const char *command, const pf_cli_option *option, const char *value)
{
    pf_cli_tags *tags = option->target;
    size_t used = strlen(tags->text);
    int written = snprintf(tags->text + used, sizeof tags->text - used, "%s%s", used ? "," : "",
                           value);
    if (written < 0 || (size_t)written >= sizeof tags->text - used)
        return pf_cli_fail(command, 2, "%s '%.40s': too many tags", option->name, value);
    return 0;
}

void pf_cli_format_bytes(int64_t bytes, char *out, size_t size)
{
    if (bytes <= 0)
        snprintf(out, size, "-");
    else if (bytes >= (1ll << 30))
        snprintf(out, size, "%.1f GiB", (double)bytes / (double)(1ll << 30));
    else if (bytes >= (1ll << 20))
        snprintf(out, size, "%.0f MiB", (double)bytes / (double)(1ll << 20));
    else if (bytes >= (1ll << 10))
        snprintf(out, size, "%.0f KiB", (double)bytes / (double)(1ll << 10));
    else
        snprintf(out, size, "%lld B", (long long)bytes);
}

int pf_cli_store_bytes(const char *command, const pf_cli_option *option, const char *value)
{
    char *end = NULL;
    double number = strtod(value, &end);
    double scale = 1.0;
    if (end && *end) {
        switch (*end == 'k' || *end == 'm' || *end == 'g' || *end == 't' ? *end - 32 : *end) {
        case 'K': scale = 1024.0; break;
        case 'M': scale = 1024.0 * 1024.0; break;
        case 'G': scale = 1024.0 * 1024.0 * 1024.0; break;
        case 'T': scale = 1024.0 * 1024.0 * 1024.0 * 1024.0; break;
        default: scale = 0.0; break;
        }
        end++;
        if (*end == 'i' || *end == 'I')
            end++;
        if (*end == 'B' || *end == 'b')
            end++;
    }
    double bytes = number * scale;
    if (end == value || (end && *end) || !(scale > 0.0) || !(bytes >= (double)option->min) ||
        !(bytes <= (double)option->max))
        return pf_cli_fail(command, 2,
                           "%s '%s': expected a size such as 24G, 512M or 1073741824 (bytes), "
                           "at most %lld",
                           option->name, value, (long long)option->max);
    *(int64_t *)option->target = (int64_t)bytes;
    return 0;
}

pf_cli_option pf_cli_db_option(const char **target)
{
    pf_cli_option option = {"--db", NULL, "PATH", "queue database",
                            "$PHOTONFARM_DB, else " PF_CLI_DEFAULT_DB, pf_cli_store_text, target,
                            0, 0, NULL};
    return option;
}

/* The option called arg (its name or alias, the part before '=' when long), or NULL. */
static const pf_cli_option *find_option(const pf_cli_command *command, const char *arg,
                                        size_t length)
{
    const pf_cli_option *tables[2] = {command->options, command->more_options};
    size_t counts[2] = {command->option_count, command->more_option_count};
    for (int t = 0; t < 2; t++) {
        for (size_t i = 0; i < counts[t]; i++) {
            const pf_cli_option *option = &tables[t][i];
            if ((strlen(option->name) == length && !strncmp(option->name, arg, length)) ||
                (option->alias && strlen(option->alias) == length &&
                 !strncmp(option->alias, arg, length)))
                return option;
        }
    }
    return NULL;
}

int pf_cli_parse(pf_cli_command *command, int argc, char **argv, int *help)
{
    *help = 0;
    command->positional_count = 0;
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i];
        if (!strcmp(arg, "--help") || !strcmp(arg, "-h")) {
            pf_cli_print_help(command, stdout);
            *help = 1;
            return 0;
        }
        /* "-" alone and negative numbers ("priority 7 -3") are arguments, not options. */
        if (arg[0] != '-' || arg[1] == '\0' || (arg[1] >= '0' && arg[1] <= '9')) {
            if (command->positional_count >= command->positional_max)
                return pf_cli_fail(command->name, 2, "unexpected argument '%s' (see --help)",
                                   arg);
            command->positional[command->positional_count++] = arg;
            continue;
        }
        const char *equals = !strncmp(arg, "--", 2) ? strchr(arg, '=') : NULL;
        size_t length = equals ? (size_t)(equals - arg) : strlen(arg);
        const pf_cli_option *option = find_option(command, arg, length);
        if (!option)
            return pf_cli_fail(command->name, 2, "unknown option '%.*s' (see --help)",
                               (int)length, arg);
        const char *value = NULL;
        if (!option->value_name) {
            if (equals)
                return pf_cli_fail(command->name, 2, "%s takes no value", option->name);
        } else if (equals) {
            value = equals + 1;
        } else if (i + 1 < argc) {
            value = argv[++i];
        } else {
            return pf_cli_fail(command->name, 2, "%s needs a value %s (see --help)", option->name,
                               option->value_name);
        }
        int code = option->store(command->name, option, value);
        if (code)
            return code;
    }
    return 0;
}

static void print_option(const pf_cli_option *option, FILE *out)
{
    char head[128];
    int used = snprintf(head, sizeof head, "  %s%s%s%s%s", option->alias ? option->alias : "",
                        option->alias ? ", " : "", option->name,
                        option->value_name ? " " : "",
                        option->value_name ? option->value_name : "");
    if (used >= HELP_COLUMN - 1)
        fprintf(out, "%s\n%*s", head, HELP_COLUMN, "");
    else
        fprintf(out, "%-*s", HELP_COLUMN, head);
    size_t column = HELP_COLUMN;
    for (const char *line = option->help; *line;) {
        size_t length = strcspn(line, "\n");
        fprintf(out, "%.*s", (int)length, line);
        column = HELP_COLUMN + length;
        line += length;
        if (*line == '\n') {
            line++;
            fprintf(out, "\n%*s", HELP_COLUMN, "");
        }
    }
    if (option->default_text) {
        /* On its own line when it would run past the terminal's usual width. */
        size_t length = strlen(" (default: )") + strlen(option->default_text);
        if (column + length > HELP_WIDTH)
            fprintf(out, "\n%*s(default: %s)", HELP_COLUMN, "", option->default_text);
        else
            fprintf(out, " (default: %s)", option->default_text);
    }
    fputc('\n', out);
}

void pf_cli_print_help(const pf_cli_command *command, FILE *out)
{
    fprintf(out, "usage: photonfarm %s %s\n\n%s\n\n", command->name, command->synopsis,
            command->description);
    for (size_t i = 0; i < command->option_count; i++)
        print_option(&command->options[i], out);
    for (size_t i = 0; i < command->more_option_count; i++)
        print_option(&command->more_options[i], out);
    fprintf(out, "  %-*s%s\n", HELP_COLUMN - 2, "-h, --help", "this text");
    if (command->epilogue)
        fprintf(out, "\n%s\n", command->epilogue);
    fprintf(out, "\nExit status: 0 ok, 1 runtime failure, 2 bad usage or input.\n");
}

int pf_cli_job_id(const char *command, const char *text, int required, int64_t *job_id)
{
    *job_id = 0;
    if (!text)
        return required ? pf_cli_fail(command, 2, "no job id given (see photonfarm status)") : 0;
    if (!pf_cli_parse_int(text, 1, INT64_MAX, job_id))
        return pf_cli_fail(command, 2, "'%s' is not a job id (a positive integer)", text);
    return 0;
}

/* Appends every job id of value ("3,4") to the prerequisites, each waited for per_frame. */
static int store_prerequisites(const char *command, const pf_cli_option *option,
                               const char *value, bool per_frame)
{
    pf_cli_prerequisites *after = option->target;
    const char *word = value;
    for (;;) {
        size_t length = strcspn(word, ",");
        char text[24];
        int64_t job_id = 0;
        if (length == 0 || length >= sizeof text)
            return pf_cli_fail(command, 2, "%s '%s': expected job ids, e.g. 3 or 3,4",
                               option->name, value);
        memcpy(text, word, length);
        text[length] = '\0';
        if (!pf_cli_parse_int(text, 1, INT64_MAX, &job_id))
            return pf_cli_fail(command, 2, "%s '%s': '%s' is not a job id (a positive integer)",
                               option->name, value, text);
        if (after->count == PF_QUEUE_DEPENDENCIES_MAX)
            return pf_cli_fail(command, 2, "%s: more than %d prerequisite jobs", option->name,
                               PF_QUEUE_DEPENDENCIES_MAX);
        after->jobs[after->count++] = (pf_queue_dependency){job_id, per_frame};
        if (!word[length])
            return 0;
        word += length + 1;
    }
}

int pf_cli_store_after(const char *command, const pf_cli_option *option, const char *value)
{
    return store_prerequisites(command, option, value, false);
}

int pf_cli_store_after_frames(const char *command, const pf_cli_option *option,
                              const char *value)
{
    return store_prerequisites(command, option, value, true);
}
