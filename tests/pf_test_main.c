/* Storage for the harness counters shared by every test executable. */
#include "pf_test.h"

int pf_test_failures;
const char *pf_test_current = "";
