/*
 * The one command-line parser (cli_options.c): every subcommand describes its
 * options in a table, and the same code parses them (--name VALUE and
 * --name=VALUE, strict integers, unknown options and missing values refused
 * with exit 2 naming the option) and prints --help from the same table, each
 * option with its default. So every subcommand gets the same help, errors
 * and exit codes, and an option cannot be accepted without being documented.
 */
#ifndef PF_CLI_OPTIONS_H
#define PF_CLI_OPTIONS_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

typedef struct pf_cli_option pf_cli_option;

/* Stores value (NULL for a flag) into option->target: 0, or the exit code (2) after printing why. */
typedef int (*pf_cli_store)(const char *command, const pf_cli_option *option, const char *value);

struct pf_cli_option {
    const char *name;         /* "--db" */
    const char *alias;        /* "-o", or NULL */
    const char *value_name;   /* "PATH"; NULL: a flag, which takes no value */
    const char *help;         /* what it does; lines separated by \n */
    const char *default_text; /* shown as "(default: ...)"; NULL: none to show */
    pf_cli_store store;
    void *target;
    int64_t min, max;         /* pf_cli_store_int's range */
    const char *choices;      /* pf_cli_store_choice's words, "a|b|c" */
};

/* --tag NAME, repeatable: the names joined by ',' (checked by pf_queue_tags_normalize). */
typedef struct pf_cli_tags {
    char text[512];
} pf_cli_tags;

/* Stores: flag (int = 1), text (const char *), integer in [min, max] (int64_t), choice (const
 * char *), a tag appended (pf_cli_tags), bytes as N with an optional K, M, G or T (binary:
 * 24G = 24 GiB) in [min, max] (int64_t). */
int pf_cli_store_flag(const char *command, const pf_cli_option *option, const char *value);
int pf_cli_store_text(const char *command, const pf_cli_option *option, const char *value);
int pf_cli_store_int(const char *command, const pf_cli_option *option, const char *value);
int pf_cli_store_choice(const char *command, const pf_cli_option *option, const char *value);
int pf_cli_store_tag(const char *command, const pf_cli_option *option, const char *value);
int pf_cli_store_bytes(const char *command, const pf_cli_option *option, const char *value);

/* "24.0 GiB", "512 MiB", "12 KiB", "300 B" (binary units, as pf_cli_store_bytes reads
 * them); "-" when unknown (0 or less). */
void pf_cli_format_bytes(int64_t bytes, char *out, size_t size);

typedef struct pf_cli_command {
    const char *name;        /* "worker" */
    const char *synopsis;    /* after "usage: photonfarm NAME " */
    const char *description; /* paragraph(s) before the options */
    const char *epilogue;    /* after the options (NULL: none) */
    const pf_cli_option *options;
    size_t option_count;
    const pf_cli_option *more_options; /* a second table (render's and enqueue's settings) */
    size_t more_option_count;
    /* Positional arguments go here in order, at most positional_max of them (0: none). */
    const char **positional;
    size_t positional_max;
    size_t positional_count; /* filled by pf_cli_parse */
} pf_cli_command;

/*
 * Parses argv[1..argc) by the command's tables. Returns 0 (parsed; *help set
 * when --help or -h was given, after printing the help on stdout) or the exit
 * code (2) after printing why: an unknown option, a missing or bad value, a
 * value given to a flag, too many positional arguments.
 */
int pf_cli_parse(pf_cli_command *command, int argc, char **argv, int *help);

/* The command's help: synopsis, description, every option with its default, epilogue. */
void pf_cli_print_help(const pf_cli_command *command, FILE *out);

/* The option after "--db PATH": every queue command's (default: $PHOTONFARM_DB, else farm.db). */
pf_cli_option pf_cli_db_option(const char **target);

/*
 * A queue command's JOB argument: text (NULL: not given) as a job id of 1 or
 * more into *job_id (0 when absent and not required). 0, or 2 after printing
 * why.
 */
int pf_cli_job_id(const char *command, const char *text, int required, int64_t *job_id);

#endif
