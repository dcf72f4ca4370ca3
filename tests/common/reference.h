/* reference.h - reads the published tables of ../shared/reference/README.md for the verification tests. */
#ifndef SPHDEM_REFERENCE_H
#define SPHDEM_REFERENCE_H
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef SPHDEM_DEFAULT_REFERENCE_DIR
#define SPHDEM_DEFAULT_REFERENCE_DIR "../shared/reference"
#endif

/* Reads the two-column markdown table that follows the line starting with `heading`
 * (e.g. "a = 2.25 in:") in $SPHDEM_REFERENCE_DIR/README.md. Returns the row count (0 on failure). */
static int reference_table(const char *heading, double *c1, double *c2, int maxrows) {
  const char *dir = getenv("SPHDEM_REFERENCE_DIR");
  char path[1024], line[512];
  snprintf(path, sizeof path, "%s/README.md", dir ? dir : SPHDEM_DEFAULT_REFERENCE_DIR);
  FILE *f = fopen(path, "r");
  if (!f) { fprintf(stderr, "cannot open reference data %s\n", path); return 0; }
  int found = 0, n = 0;
  while (fgets(line, sizeof line, f)) {
    if (!found) { if (strncmp(line, heading, strlen(heading)) == 0) found = 1; continue; }
    double a, b;
    if (sscanf(line, "| %lf | %lf |", &a, &b) == 2) { if (n < maxrows) { c1[n] = a; c2[n] = b; n++; } }
    else if (n > 0 && line[0] != '|') break;
  }
  fclose(f);
  return n;
}
#endif
