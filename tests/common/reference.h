/* reference.h - reads the published data files of data/reference/ for the verification tests. */
#ifndef SPHDEM_REFERENCE_H
#define SPHDEM_REFERENCE_H
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef SPHDEM_DEFAULT_REFERENCE_DIR
#define SPHDEM_DEFAULT_REFERENCE_DIR "data/reference"
#endif

/* Reads the rows of $SPHDEM_REFERENCE_DIR/`file` (whitespace-separated columns, '#' comments) whose first
 * column equals `key` (e.g. 2.25 for the a = 2.25 in series of martin_moyce_1952.dat) and stores their second
 * and third columns in c1, c2. Returns the row count (0 on failure, with a message on stderr). */
static int reference_series(const char *file, double key, double *c1, double *c2, int maxrows) {
  const char *dir = getenv("SPHDEM_REFERENCE_DIR");
  char path[1024], line[512];
  snprintf(path, sizeof path, "%s/%s", dir ? dir : SPHDEM_DEFAULT_REFERENCE_DIR, file);
  FILE *f = fopen(path, "r");
  if (!f) { fprintf(stderr, "cannot open reference data %s\n", path); return 0; }
  int n = 0;
  while (fgets(line, sizeof line, f)) {
    double k, a, b;
    if (line[0] == '#' || sscanf(line, "%lf %lf %lf", &k, &a, &b) != 3) continue;
    if (k == key && n < maxrows) { c1[n] = a; c2[n] = b; n++; }
  }
  fclose(f);
  if (n == 0) fprintf(stderr, "%s: no rows with first column %g\n", path, key);
  return n;
}
#endif
