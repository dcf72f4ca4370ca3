/* wallgen.c - ASCII STL reader, dummy-wall layers behind a triangle mesh, point merging and exclusion
 * (the geometry of fix sph/wall and fix sph/fill; see sphdem_geom.h). Host code only. */
#include <ctype.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sphdem_geom.h"

#define GEOM_MSG(...)                              \
  do {                                             \
    if (msg && msglen) snprintf(msg, msglen, __VA_ARGS__); \
  } while (0)

/* ---------------------------------------------------------------- small vector helpers */
static double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static void sub3(const double *a, const double *b, double *o) {
  o[0] = a[0] - b[0];
  o[1] = a[1] - b[1];
  o[2] = a[2] - b[2];
}
static void cross3(const double *a, const double *b, double *o) {
  o[0] = a[1] * b[2] - a[2] * b[1];
  o[1] = a[2] * b[0] - a[0] * b[2];
  o[2] = a[0] * b[1] - a[1] * b[0];
}

/* closest point on triangle abc to p (Ericson, Real-Time Collision Detection §5.1.5); returns squared distance */
static double closest_on_triangle(const double *p, const double *a, const double *b, const double *c, double *q) {
  double ab[3], ac[3], ap[3], bp[3], cp[3], d[3];
  sub3(b, a, ab);
  sub3(c, a, ac);
  sub3(p, a, ap);
  double d1 = dot3(ab, ap), d2 = dot3(ac, ap);
  int i;
  if (d1 <= 0 && d2 <= 0) {
    for (i = 0; i < 3; i++) q[i] = a[i];
    goto done;
  }
  sub3(p, b, bp);
  double d3 = dot3(ab, bp), d4 = dot3(ac, bp);
  if (d3 >= 0 && d4 <= d3) {
    for (i = 0; i < 3; i++) q[i] = b[i];
    goto done;
  }
  double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    double v = d1 / (d1 - d3);
    for (i = 0; i < 3; i++) q[i] = a[i] + v * ab[i];
    goto done;
  }
  sub3(p, c, cp);
  double d5 = dot3(ab, cp), d6 = dot3(ac, cp);
  if (d6 >= 0 && d5 <= d6) {
    for (i = 0; i < 3; i++) q[i] = c[i];
    goto done;
  }
  double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    double w = d2 / (d2 - d6);
    for (i = 0; i < 3; i++) q[i] = a[i] + w * ac[i];
    goto done;
  }
  double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    for (i = 0; i < 3; i++) q[i] = b[i] + w * (c[i] - b[i]);
    goto done;
  }
  {
    double den = 1.0 / (va + vb + vc), v = vb * den, w = vc * den;
    for (i = 0; i < 3; i++) q[i] = a[i] + ab[i] * v + ac[i] * w;
  }
done:
  sub3(p, q, d);
  return dot3(d, d);
}

/* ---------------------------------------------------------------- points */
int sphdem_points_push(sphdem_points *p, double x, double y, double z) {
  if (p->n == p->cap) {
    long cap = p->cap ? 2 * p->cap : 1024;
    double *nx = (double *)realloc(p->x, (size_t)cap * 3 * sizeof(double));
    if (!nx) return SPHDEM_ERR_ALLOC;
    p->x = nx;
    p->cap = cap;
  }
  p->x[3 * p->n] = x;
  p->x[3 * p->n + 1] = y;
  p->x[3 * p->n + 2] = z;
  p->n++;
  return SPHDEM_OK;
}

void sphdem_points_free(sphdem_points *p) {
  free(p->x);
  p->x = NULL;
  p->n = p->cap = 0;
}

/* cell key of a point: 21 bits per axis (cells outside +-2^20 share the edge cell: only slower, never wrong,
 * since every candidate is checked by its distance) */
static int64_t cell_of(double v, double inv) {
  double c = floor(v * inv);
  if (c < -1048575.0) c = -1048575.0;
  if (c > 1048575.0) c = 1048575.0;
  return (int64_t)c;
}
static uint64_t cell_key(int64_t i, int64_t j, int64_t k) {
  return ((uint64_t)(i + 1048576) << 42) | ((uint64_t)(j + 1048576) << 21) | (uint64_t)(k + 1048576);
}
static size_t key_hash(uint64_t k, size_t mask) {
  k ^= k >> 33;
  k *= 0xff51afd7ed558ccdULL;
  k ^= k >> 33;
  return (size_t)(k & mask);
}

/* chained hash of items by cell: head[bucket], next[item], key[item] */
typedef struct {
  long *head, *next;
  uint64_t *key;
  size_t mask;
  double inv;
} cellhash;

static int cellhash_init(cellhash *h, long nitems, double cell) {
  size_t nb = 1024;
  while (nb < (size_t)(2 * nitems)) nb <<= 1;
  h->mask = nb - 1;
  h->inv = 1.0 / cell;
  h->head = (long *)malloc(nb * sizeof(long));
  h->next = (long *)malloc((size_t)(nitems > 0 ? nitems : 1) * sizeof(long));
  h->key = (uint64_t *)malloc((size_t)(nitems > 0 ? nitems : 1) * sizeof(uint64_t));
  if (!h->head || !h->next || !h->key) return SPHDEM_ERR_ALLOC;
  for (size_t b = 0; b < nb; b++) h->head[b] = -1;
  return SPHDEM_OK;
}
static void cellhash_free(cellhash *h) {
  free(h->head);
  free(h->next);
  free(h->key);
}
static void cellhash_insert(cellhash *h, long item, const double *x) {
  uint64_t k = cell_key(cell_of(x[0], h->inv), cell_of(x[1], h->inv), cell_of(x[2], h->inv));
  size_t b = key_hash(k, h->mask);
  h->key[item] = k;
  h->next[item] = h->head[b];
  h->head[b] = item;
}

long sphdem_points_merge(sphdem_points *p, double dmin) {
  cellhash h;
  if (p->n == 0) return 0;
  if (cellhash_init(&h, p->n, dmin) != SPHDEM_OK) {
    cellhash_free(&h);
    return -SPHDEM_ERR_ALLOC;
  }
  double d2min = dmin * dmin;
  long kept = 0;
  for (long i = 0; i < p->n; i++) {
    const double *x = p->x + 3 * i;
    int64_t ci = cell_of(x[0], h.inv), cj = cell_of(x[1], h.inv), ck = cell_of(x[2], h.inv);
    int close = 0;
    for (int a = -1; a <= 1 && !close; a++)
      for (int b = -1; b <= 1 && !close; b++)
        for (int c = -1; c <= 1 && !close; c++) {
          uint64_t k = cell_key(ci + a, cj + b, ck + c);
          for (long m = h.head[key_hash(k, h.mask)]; m >= 0; m = h.next[m]) {
            if (h.key[m] != k) continue;
            const double *y = p->x + 3 * m;
            double d[3];
            sub3(x, y, d);
            if (dot3(d, d) < d2min) {
              close = 1;
              break;
            }
          }
        }
    if (close) continue;
    /* kept points are compacted in place; index kept <= i, so the hash refers to the compacted array */
    if (kept != i) memmove(p->x + 3 * kept, x, 3 * sizeof(double));
    cellhash_insert(&h, kept, p->x + 3 * kept);
    kept++;
  }
  long removed = p->n - kept;
  p->n = kept;
  cellhash_free(&h);
  return removed;
}

/* appends to dst each point of src that is not closer than dmin to a point of dst (earlier ones or those
 * appended); returns the count left out or -SPHDEM_ERR_ALLOC */
long sphdem_points_merge_into(sphdem_points *dst, const sphdem_points *src, double dmin) {
  cellhash h;
  long total = dst->n + src->n;
  if (src->n == 0) return 0;
  if (cellhash_init(&h, total, dmin) != SPHDEM_OK) {
    cellhash_free(&h);
    return -SPHDEM_ERR_ALLOC;
  }
  for (long i = 0; i < dst->n; i++) cellhash_insert(&h, i, dst->x + 3 * i);
  double d2min = dmin * dmin;
  long left = 0;
  for (long s = 0; s < src->n; s++) {
    const double *x = src->x + 3 * s;
    int64_t ci = cell_of(x[0], h.inv), cj = cell_of(x[1], h.inv), ck = cell_of(x[2], h.inv);
    int close = 0;
    for (int a = -1; a <= 1 && !close; a++)
      for (int b = -1; b <= 1 && !close; b++)
        for (int c = -1; c <= 1 && !close; c++) {
          uint64_t k = cell_key(ci + a, cj + b, ck + c);
          for (long m = h.head[key_hash(k, h.mask)]; m >= 0; m = h.next[m]) {
            if (h.key[m] != k) continue;
            double d[3];
            sub3(x, dst->x + 3 * m, d);
            if (dot3(d, d) < d2min) {
              close = 1;
              break;
            }
          }
        }
    if (close) {
      left++;
      continue;
    }
    if (sphdem_points_push(dst, x[0], x[1], x[2]) != SPHDEM_OK) {
      cellhash_free(&h);
      return -SPHDEM_ERR_ALLOC;
    }
    cellhash_insert(&h, dst->n - 1, dst->x + 3 * (dst->n - 1));
  }
  cellhash_free(&h);
  return left;
}

long sphdem_points_exclude(sphdem_points *p, const double *xr, long ns, double gap, double tol) {
  if (p->n == 0 || ns <= 0) return 0;
  double rmax = 0.0;
  for (long j = 0; j < ns; j++)
    if (xr[4 * j + 3] > rmax) rmax = xr[4 * j + 3];
  double cell = rmax + gap;
  if (!(cell > 0.0)) return 0;
  cellhash h;
  if (cellhash_init(&h, ns, cell) != SPHDEM_OK) {
    cellhash_free(&h);
    return -SPHDEM_ERR_ALLOC;
  }
  for (long j = 0; j < ns; j++) cellhash_insert(&h, j, xr + 4 * j);
  long kept = 0;
  for (long i = 0; i < p->n; i++) {
    const double *x = p->x + 3 * i;
    int64_t ci = cell_of(x[0], h.inv), cj = cell_of(x[1], h.inv), ck = cell_of(x[2], h.inv);
    int close = 0;
    for (int a = -1; a <= 1 && !close; a++)
      for (int b = -1; b <= 1 && !close; b++)
        for (int c = -1; c <= 1 && !close; c++) {
          uint64_t k = cell_key(ci + a, cj + b, ck + c);
          for (long m = h.head[key_hash(k, h.mask)]; m >= 0; m = h.next[m]) {
            if (h.key[m] != k) continue;
            const double *y = xr + 4 * m;
            double d[3], lim = y[3] + gap - tol;
            sub3(x, y, d);
            if (lim > 0 && dot3(d, d) < lim * lim) {
              close = 1;
              break;
            }
          }
        }
    if (close) continue;
    if (kept != i) memmove(p->x + 3 * kept, x, 3 * sizeof(double));
    kept++;
  }
  long removed = p->n - kept;
  p->n = kept;
  cellhash_free(&h);
  return removed;
}

/* ---------------------------------------------------------------- STL */
static int facet_normal(sphdem_facet *f) {
  double a[3], b[3], n[3];
  sub3(f->v[1], f->v[0], a);
  sub3(f->v[2], f->v[0], b);
  cross3(a, b, n);
  double l = sqrt(dot3(n, n)), la = sqrt(dot3(a, a)), lb = sqrt(dot3(b, b));
  if (!(l > 1e-14 * la * lb) || !(l > 0)) return 0;
  for (int i = 0; i < 3; i++) f->n[i] = n[i] / l;
  return 1;
}

typedef struct {
  const char *s;
  long line;
  char tok[128];
} lexer;

/* next whitespace-separated token (truncated to 127 characters); 0 at the end */
static int lex_next(lexer *L) {
  while (*L->s && isspace((unsigned char)*L->s)) {
    if (*L->s == '\n') L->line++;
    L->s++;
  }
  if (!*L->s) return 0;
  size_t n = 0;
  while (*L->s && !isspace((unsigned char)*L->s)) {
    if (n < sizeof L->tok - 1) L->tok[n++] = *L->s;
    L->s++;
  }
  L->tok[n] = '\0';
  return 1;
}
static void lex_skip_line(lexer *L) {
  while (*L->s && *L->s != '\n') L->s++;
}

static int lex_numbers(lexer *L, double *v, int n, const char *after, const char *name, char *msg, size_t msglen) {
  for (int i = 0; i < n; i++) {
    char *end = NULL;
    if (!lex_next(L)) {
      GEOM_MSG("%s:%ld: file ends where a number after '%s' is expected", name, L->line, after);
      return SPHDEM_ERR_ARG;
    }
    v[i] = strtod(L->tok, &end);
    if (*end || !isfinite(v[i])) {
      GEOM_MSG("%s:%ld: expected a number after '%s', got '%s'", name, L->line, after, L->tok);
      return SPHDEM_ERR_ARG;
    }
  }
  return SPHDEM_OK;
}

static int lex_expect(lexer *L, const char *want, const char *name, char *msg, size_t msglen) {
  if (!lex_next(L) || strcmp(L->tok, want)) {
    GEOM_MSG("%s:%ld: expected '%s', got '%s'", name, L->line, want, *L->s || L->tok[0] ? L->tok : "end of file");
    return SPHDEM_ERR_ARG;
  }
  return SPHDEM_OK;
}

int sphdem_stl_parse(const char *text, const char *name, sphdem_mesh *m, char *msg, size_t msglen) {
  memset(m, 0, sizeof *m);
  lexer L = {text, 1, {0}};
  long cap = 0;
  int rc;
  if (!lex_next(&L) || strcmp(L.tok, "solid")) {
    GEOM_MSG("%s: not an ASCII STL file (it must begin with 'solid'; binary STL is not read: convert it to ASCII)",
             name);
    return SPHDEM_ERR_ARG;
  }
  lex_skip_line(&L);
  while (lex_next(&L)) {
    if (!strcmp(L.tok, "endsolid") || !strcmp(L.tok, "solid")) {
      lex_skip_line(&L);
      continue;
    }
    if (strcmp(L.tok, "facet")) {
      GEOM_MSG("%s:%ld: expected 'facet' or 'endsolid', got '%s'", name, L.line, L.tok);
      goto fail;
    }
    sphdem_facet f;
    double nfile[3];
    if ((rc = lex_expect(&L, "normal", name, msg, msglen)) ||
        (rc = lex_numbers(&L, nfile, 3, "facet normal", name, msg, msglen)) ||
        (rc = lex_expect(&L, "outer", name, msg, msglen)) || (rc = lex_expect(&L, "loop", name, msg, msglen)))
      goto fail;
    for (int v = 0; v < 3; v++)
      if ((rc = lex_expect(&L, "vertex", name, msg, msglen)) ||
          (rc = lex_numbers(&L, f.v[v], 3, "vertex", name, msg, msglen)))
        goto fail;
    if ((rc = lex_expect(&L, "endloop", name, msg, msglen)) || (rc = lex_expect(&L, "endfacet", name, msg, msglen)))
      goto fail;
    if (!facet_normal(&f)) {
      m->ndegenerate++;
      continue;
    }
    if (dot3(nfile, f.n) < 0) m->ndisagree++;
    if (m->nfacet == cap) {
      cap = cap ? 2 * cap : 256;
      sphdem_facet *nf = (sphdem_facet *)realloc(m->f, (size_t)cap * sizeof *nf);
      if (!nf) {
        GEOM_MSG("%s: out of memory at %ld facets", name, m->nfacet);
        sphdem_mesh_free(m);
        return SPHDEM_ERR_ALLOC;
      }
      m->f = nf;
    }
    m->f[m->nfacet++] = f;
  }
  if (m->nfacet == 0) {
    GEOM_MSG("%s: no facet of non-zero area in the file", name);
    goto fail;
  }
  return SPHDEM_OK;
fail:
  sphdem_mesh_free(m);
  return SPHDEM_ERR_ARG;
}

int sphdem_stl_read(const char *path, sphdem_mesh *m, char *msg, size_t msglen) {
  memset(m, 0, sizeof *m);
  FILE *fp = fopen(path, "rb");
  if (!fp) {
    GEOM_MSG("cannot open STL file '%s'", path);
    return SPHDEM_ERR_ARG;
  }
  fseek(fp, 0, SEEK_END);
  long len = ftell(fp);
  fseek(fp, 0, SEEK_SET);
  if (len < 0) len = 0;
  char *text = (char *)malloc((size_t)len + 1);
  if (!text) {
    fclose(fp);
    GEOM_MSG("out of memory reading '%s'", path);
    return SPHDEM_ERR_ALLOC;
  }
  size_t got = fread(text, 1, (size_t)len, fp);
  fclose(fp);
  text[got] = '\0';
  if (memchr(text, '\0', got)) {
    free(text);
    GEOM_MSG("%s: binary STL is not read (only ASCII STL): convert it to ASCII", path);
    return SPHDEM_ERR_ARG;
  }
  int rc = sphdem_stl_parse(text, path, m, msg, msglen);
  free(text);
  return rc;
}

void sphdem_mesh_free(sphdem_mesh *m) {
  free(m->f);
  memset(m, 0, sizeof *m);
}

void sphdem_mesh_transform(sphdem_mesh *m, double scale, const double move[3]) {
  for (long i = 0; i < m->nfacet; i++)
    for (int v = 0; v < 3; v++)
      for (int d = 0; d < 3; d++) m->f[i].v[v][d] = scale * m->f[i].v[v][d] + move[d];
  if (scale < 0)
    for (long i = 0; i < m->nfacet; i++) facet_normal(&m->f[i]);
}

static void facet_turn(sphdem_facet *f) {
  for (int d = 0; d < 3; d++) {
    double t = f->v[1][d];
    f->v[1][d] = f->v[2][d];
    f->v[2][d] = t;
    f->n[d] = -f->n[d];
  }
}

void sphdem_mesh_flip(sphdem_mesh *m) {
  for (long i = 0; i < m->nfacet; i++) facet_turn(&m->f[i]);
}

long sphdem_mesh_orient(sphdem_mesh *m, const double p[3]) {
  long turned = 0;
  for (long i = 0; i < m->nfacet; i++) {
    sphdem_facet *f = &m->f[i];
    double c[3], d[3];
    for (int k = 0; k < 3; k++) c[k] = (f->v[0][k] + f->v[1][k] + f->v[2][k]) / 3.0;
    sub3(p, c, d);
    if (dot3(f->n, d) < 0) {
      facet_turn(f);
      turned++;
    }
  }
  return turned;
}

void sphdem_mesh_bbox(const sphdem_mesh *m, double lo[3], double hi[3]) {
  for (int d = 0; d < 3; d++) {
    lo[d] = HUGE_VAL;
    hi[d] = -HUGE_VAL;
  }
  for (long i = 0; i < m->nfacet; i++)
    for (int v = 0; v < 3; v++)
      for (int d = 0; d < 3; d++) {
        if (m->f[i].v[v][d] < lo[d]) lo[d] = m->f[i].v[v][d];
        if (m->f[i].v[v][d] > hi[d]) hi[d] = m->f[i].v[v][d];
      }
}

/* ---------------------------------------------------------------- walls behind a mesh */
typedef struct {
  double e1[3], e2[3], op[3]; /* in-plane basis (e1, e2, n right-handed) and lattice origin on the plane */
  double u[3][2];             /* vertices in lattice units (dx) relative to op */
  int open[3];                /* edge v[a] -> v[a+1] touches no other facet */
} facet_frame;

/* facets binned by cell: (key, facet) pairs sorted by key */
typedef struct {
  uint64_t key;
  long facet;
} fpair;
static int fpair_cmp(const void *a, const void *b) {
  const fpair *x = (const fpair *)a, *y = (const fpair *)b;
  if (x->key != y->key) return x->key < y->key ? -1 : 1;
  return x->facet < y->facet ? -1 : (x->facet > y->facet);
}
typedef struct {
  fpair *p;
  long n;
  double inv;
} facetgrid;

/* every facet within distance R of a point is listed in the point's cell */
static int facetgrid_build(facetgrid *g, const sphdem_mesh *m, double R, double cell) {
  long cap = 0;
  g->p = NULL;
  g->n = 0;
  g->inv = 1.0 / cell;
  for (long f = 0; f < m->nfacet; f++) {
    double lo[3], hi[3];
    for (int d = 0; d < 3; d++) {
      lo[d] = fmin(fmin(m->f[f].v[0][d], m->f[f].v[1][d]), m->f[f].v[2][d]) - R;
      hi[d] = fmax(fmax(m->f[f].v[0][d], m->f[f].v[1][d]), m->f[f].v[2][d]) + R;
    }
    int64_t i0 = cell_of(lo[0], g->inv), i1 = cell_of(hi[0], g->inv), j0 = cell_of(lo[1], g->inv),
            j1 = cell_of(hi[1], g->inv), k0 = cell_of(lo[2], g->inv), k1 = cell_of(hi[2], g->inv);
    for (int64_t i = i0; i <= i1; i++)
      for (int64_t j = j0; j <= j1; j++)
        for (int64_t k = k0; k <= k1; k++) {
          if (g->n == cap) {
            cap = cap ? 2 * cap : 4096;
            fpair *np = (fpair *)realloc(g->p, (size_t)cap * sizeof *np);
            if (!np) return SPHDEM_ERR_ALLOC;
            g->p = np;
          }
          g->p[g->n].key = cell_key(i, j, k);
          g->p[g->n].facet = f;
          g->n++;
        }
  }
  qsort(g->p, (size_t)g->n, sizeof *g->p, fpair_cmp);
  return SPHDEM_OK;
}

/* the facets of the cell of x: [*first, *first + return) in g->p */
static long facetgrid_cell(const facetgrid *g, const double *x, long *first) {
  uint64_t k = cell_key(cell_of(x[0], g->inv), cell_of(x[1], g->inv), cell_of(x[2], g->inv));
  long lo = 0, hi = g->n;
  while (lo < hi) {
    long mid = (lo + hi) / 2;
    if (g->p[mid].key < k) lo = mid + 1;
    else hi = mid;
  }
  long e = lo;
  while (e < g->n && g->p[e].key == k) e++;
  *first = lo;
  return e - lo;
}

/* is the in-plane point q (lattice units) over the facet's triangle extended by ext across its shared edges
 * (not across open ones) and within sqrt(2) ext of the triangle (which bounds the spikes at acute corners)? */
static int over_extended(const facet_frame *F, const double q[2], double ext, double tol) {
  double dmin2 = HUGE_VAL;
  int inside = 1;
  for (int a = 0; a < 3; a++) {
    const double *p0 = F->u[a], *p1 = F->u[(a + 1) % 3];
    double ex = p1[0] - p0[0], ey = p1[1] - p0[1], len = sqrt(ex * ex + ey * ey);
    double qx = q[0] - p0[0], qy = q[1] - p0[1];
    double out = -(ex * qy - ey * qx) / len; /* counter-clockwise triangle: the inside is on the left */
    if (out > (F->open[a] ? tol : ext + tol)) return 0;
    if (out > 0) inside = 0;
    double t = (qx * ex + qy * ey) / (len * len);
    t = t < 0 ? 0 : (t > 1 ? 1 : t);
    double dx = qx - t * ex, dy = qy - t * ey, d2 = dx * dx + dy * dy;
    if (d2 < dmin2) dmin2 = d2;
  }
  if (inside) return 1;
  double cap = sqrt(2.0) * ext + tol;
  return dmin2 <= cap * cap;
}

static void frame_of(const sphdem_facet *f, const double origin[3], double dx, facet_frame *F) {
  /* e1: the coordinate axis least aligned with n (first of equals), made perpendicular to n; e2 = n x e1 */
  int ax = 0;
  for (int d = 1; d < 3; d++)
    if (fabs(f->n[d]) < fabs(f->n[ax])) ax = d;
  double a[3] = {0, 0, 0};
  a[ax] = 1.0;
  double an = dot3(a, f->n);
  for (int d = 0; d < 3; d++) F->e1[d] = a[d] - an * f->n[d];
  double l = sqrt(dot3(F->e1, F->e1));
  for (int d = 0; d < 3; d++) F->e1[d] /= l;
  cross3(f->n, F->e1, F->e2);
  double ov[3];
  sub3(origin, f->v[0], ov);
  double s = dot3(ov, f->n);
  for (int d = 0; d < 3; d++) F->op[d] = origin[d] - s * f->n[d];
  for (int v = 0; v < 3; v++) {
    double r[3];
    sub3(f->v[v], F->op, r);
    F->u[v][0] = dot3(r, F->e1) / dx;
    F->u[v][1] = dot3(r, F->e2) / dx;
  }
}

/* the nearest of the n listed facets to x (squared distance *d2, signed distance of x to its plane *s, > 0 on
 * the fluid side); on ties (an edge or a corner is nearest) the one whose plane is farthest decides, which gives
 * the side of x. Returns the facet, or -1 when none is listed. */
static long nearest_facet(const sphdem_mesh *m, const fpair *list, long n, const double *x, double tie, double *d2o,
                          double *so) {
  long best = -1;
  double bd2 = HUGE_VAL, bs = 0.0;
  for (long t = 0; t < n; t++) {
    long o = list ? list[t].facet : t;
    double q[3], r[3];
    double d2 = closest_on_triangle(x, m->f[o].v[0], m->f[o].v[1], m->f[o].v[2], q);
    sub3(x, m->f[o].v[0], r);
    double s = dot3(r, m->f[o].n);
    if (d2 < bd2 - tie || (d2 <= bd2 + tie && fabs(s) > fabs(bs))) {
      if (d2 < bd2) bd2 = d2;
      bs = s;
      best = o;
    }
  }
  *d2o = bd2;
  *so = bs;
  return best;
}

int sphdem_wall_from_mesh(const sphdem_mesh *m, double dx, int layers, const double origin[3], sphdem_points *out,
                          char *msg, size_t msglen) {
  if (!(dx > 0) || layers < 1 || !m || m->nfacet < 1) {
    GEOM_MSG("wall from mesh: spacing > 0, layers >= 1 and a mesh with facets are required");
    return SPHDEM_ERR_ARG;
  }
  const double ext = (double)layers, tol = 1e-9, R = sqrt(3.0) * (layers + 1) * dx;
  double lo[3], hi[3];
  sphdem_mesh_bbox(m, lo, hi);
  double L = fmax(fmax(hi[0] - lo[0], hi[1] - lo[1]), hi[2] - lo[2]) + 2 * R;
  facetgrid g;
  facet_frame *F = (facet_frame *)malloc((size_t)m->nfacet * sizeof *F);
  sphdem_points cand = {NULL, 0, 0}, fill = {NULL, 0, 0};
  int rc = SPHDEM_OK;
  if (!F || facetgrid_build(&g, m, R, fmax(R, L / 128.0)) != SPHDEM_OK) {
    free(F);
    GEOM_MSG("wall from mesh: out of memory (%ld facets)", m->nfacet);
    return SPHDEM_ERR_ALLOC;
  }
  /* frames and open edges: an edge is shared when its midpoint lies on another facet */
  for (long f = 0; f < m->nfacet; f++) {
    frame_of(&m->f[f], origin, dx, &F[f]);
    for (int a = 0; a < 3; a++) {
      double mid[3], q[3];
      for (int d = 0; d < 3; d++) mid[d] = 0.5 * (m->f[f].v[a][d] + m->f[f].v[(a + 1) % 3][d]);
      long first, n = facetgrid_cell(&g, mid, &first);
      int shared = 0;
      for (long t = first; t < first + n && !shared; t++) {
        long o = g.p[t].facet;
        if (o == f) continue;
        double d2 = closest_on_triangle(mid, m->f[o].v[0], m->f[o].v[1], m->f[o].v[2], q);
        if (d2 < 1e-6 * dx * dx) shared = 1;
      }
      F[f].open[a] = !shared;
    }
  }
  const double deep = ext * dx * (1.0 + tol), tie = 1e-10 * dx * dx;
  for (long f = 0; f < m->nfacet && rc == SPHDEM_OK; f++) {
    const facet_frame *Fr = &F[f];
    double umin = HUGE_VAL, umax = -HUGE_VAL, vmin = HUGE_VAL, vmax = -HUGE_VAL;
    for (int v = 0; v < 3; v++) {
      umin = fmin(umin, Fr->u[v][0]);
      umax = fmax(umax, Fr->u[v][0]);
      vmin = fmin(vmin, Fr->u[v][1]);
      vmax = fmax(vmax, Fr->u[v][1]);
    }
    double pad = sqrt(2.0) * ext + 1.0;
    long i0 = (long)floor(umin - pad), i1 = (long)ceil(umax + pad);
    long j0 = (long)floor(vmin - pad), j1 = (long)ceil(vmax + pad);
    const double *n = m->f[f].n;
    for (long j = j0; j <= j1 && rc == SPHDEM_OK; j++)
      for (long i = i0; i <= i1 && rc == SPHDEM_OK; i++) {
        double q2[2] = {(double)i, (double)j};
        if (!over_extended(Fr, q2, ext, tol)) continue;
        for (int k = 0; k < layers; k++) {
          double c[3], depth = (k + 0.5) * dx;
          for (int d = 0; d < 3; d++) c[d] = Fr->op[d] + (i * dx) * Fr->e1[d] + (j * dx) * Fr->e2[d] - depth * n[d];
          long first, nf = facetgrid_cell(&g, c, &first);
          double bd2, bs;
          long best = nearest_facet(m, &g.p[first], nf, c, tie, &bd2, &bs);
          if (best < 0 || bs > -1e-6 * dx) continue; /* on the fluid side of its nearest facet, or on the mesh */
          /* a point over another facet's slab is that facet's: this one keeps it first only where it is (one of)
           * the nearest (its slab, or behind an edge or corner, where the extensions fill the wedge); elsewhere it
           * is a filler, used only where no kept point is within 0.9 dx (facets narrower than dx have no lattice
           * column of their own) */
          int filler = 0;
          {
            double q[3];
            if (closest_on_triangle(c, m->f[f].v[0], m->f[f].v[1], m->f[f].v[2], q) > bd2 + tie) filler = 1;
          }
          /* nothing beyond an open edge: drop the point when the nearest point of the mesh lies on an open edge
           * (of any facet) and the point is beyond it in that facet's plane */
          {
            double q[3];
            closest_on_triangle(c, m->f[best].v[0], m->f[best].v[1], m->f[best].v[2], q);
            int beyond = 0;
            for (long t = first; t < first + nf && !beyond; t++) {
              long o = g.p[t].facet;
              for (int a = 0; a < 3 && !beyond; a++) {
                if (!F[o].open[a]) continue;
                const double *pa = m->f[o].v[a], *pb = m->f[o].v[(a + 1) % 3];
                double e[3], w[3], r[3], mo[3];
                sub3(pb, pa, e);
                sub3(q, pa, w);
                double t01 = dot3(w, e) / dot3(e, e);
                t01 = t01 < 0 ? 0 : (t01 > 1 ? 1 : t01);
                for (int d = 0; d < 3; d++) r[d] = q[d] - (pa[d] + t01 * e[d]);
                if (dot3(r, r) > 1e-12 * dx * dx) continue; /* q is not on this open edge */
                cross3(e, m->f[o].n, mo);                   /* in-plane, away from the facet */
                sub3(c, q, r);
                if (dot3(r, mo) > 1e-6 * dx * sqrt(dot3(mo, mo))) beyond = 1;
              }
            }
            if (beyond) continue;
          }
          if (sqrt(bd2) > deep) {
            /* far from the mesh: keep it only if no facet it lies over has it deeper than `layers` behind */
            int too_deep = 0;
            for (long t = first; t < first + nf && !too_deep; t++) {
              long o = g.p[t].facet;
              double r[3];
              sub3(c, m->f[o].v[0], r);
              double s = dot3(r, m->f[o].n);
              if (-s <= deep) continue;
              double rr[3], qo[2];
              sub3(c, F[o].op, rr);
              qo[0] = dot3(rr, F[o].e1) / dx;
              qo[1] = dot3(rr, F[o].e2) / dx;
              if (over_extended(&F[o], qo, ext, tol)) too_deep = 1;
            }
            if (too_deep) continue;
          }
          if (sphdem_points_push(filler ? &fill : &cand, c[0], c[1], c[2]) != SPHDEM_OK) rc = SPHDEM_ERR_ALLOC;
        }
      }
  }
  free(F);
  free(g.p);
  if (rc == SPHDEM_OK && sphdem_points_merge(&cand, 0.5 * dx) < 0) rc = SPHDEM_ERR_ALLOC;
  /* the fillers after the kept points, each kept only where nothing is within 0.9 dx (a lattice of spacing dx
   * leaves no point of space farther than 0.87 dx from it, so fillers go only into holes) */
  if (rc == SPHDEM_OK && fill.n) {
    long nk = cand.n;
    for (long i = 0; i < fill.n && rc == SPHDEM_OK; i++)
      if (sphdem_points_push(&cand, fill.x[3 * i], fill.x[3 * i + 1], fill.x[3 * i + 2]) != SPHDEM_OK)
        rc = SPHDEM_ERR_ALLOC;
    if (rc == SPHDEM_OK) {
      /* merge at 0.9 dx over the whole list keeps the first of each close group; the kept points come first and
       * are at least 0.5 dx apart, so re-add those the 0.9 dx merge would drop among themselves */
      sphdem_points tail = {NULL, 0, 0};
      for (long i = nk; i < cand.n && rc == SPHDEM_OK; i++)
        if (sphdem_points_push(&tail, cand.x[3 * i], cand.x[3 * i + 1], cand.x[3 * i + 2]) != SPHDEM_OK)
          rc = SPHDEM_ERR_ALLOC;
      cand.n = nk;
      if (rc == SPHDEM_OK && sphdem_points_merge_into(&cand, &tail, 0.9 * dx) < 0) rc = SPHDEM_ERR_ALLOC;
      sphdem_points_free(&tail);
    }
  }
  sphdem_points_free(&fill);
  for (long i = 0; i < cand.n && rc == SPHDEM_OK; i++)
    if (sphdem_points_push(out, cand.x[3 * i], cand.x[3 * i + 1], cand.x[3 * i + 2]) != SPHDEM_OK) rc = SPHDEM_ERR_ALLOC;
  sphdem_points_free(&cand);
  if (rc != SPHDEM_OK) GEOM_MSG("wall from mesh: out of memory");
  return rc;
}

/* ---------------------------------------------------------------- fluid points on the fluid side of a mesh */
/* lattice key of a point of a lattice of spacing dx through x0 */
static uint64_t lattice_key(const double *x, const double *x0, double dx) {
  int64_t i[3];
  for (int d = 0; d < 3; d++) {
    double c = floor((x[d] - x0[d]) / dx + 0.5);
    if (c < -1048575.0) c = -1048575.0;
    if (c > 1048575.0) c = 1048575.0;
    i[d] = (int64_t)c;
  }
  return cell_key(i[0], i[1], i[2]);
}

static long uf_find(long *parent, long i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

long sphdem_points_clip_mesh(sphdem_points *p, const sphdem_mesh *m, double dx, double gap) {
  if (p->n == 0 || !m || m->nfacet < 1 || !(dx > 0) || !(gap >= 0)) return 0;
  /* near: within R of the mesh, where the nearest facet gives the side; R > dx, so two lattice neighbours that are
   * both farther than R from the mesh lie on one side (the segment between them does not cross it) */
  const double R = fmax(1.5 * dx, gap + 0.5 * dx), tie = 1e-10 * dx * dx, tol = 1e-9 * dx;
  double lo[3], hi[3];
  sphdem_mesh_bbox(m, lo, hi);
  double L = fmax(fmax(hi[0] - lo[0], hi[1] - lo[1]), hi[2] - lo[2]) + 2 * R;
  facetgrid g;
  if (facetgrid_build(&g, m, R, fmax(R, L / 128.0)) != SPHDEM_OK) {
    free(g.p);
    return -SPHDEM_ERR_ALLOC;
  }
  const long n = p->n;
  signed char *keep = (signed char *)malloc((size_t)n); /* 1 keep, 0 drop, -1 far (decided below) */
  long *parent = (long *)malloc((size_t)n * sizeof(long));
  cellhash h;
  int rc = (keep && parent && cellhash_init(&h, n, 1.0) == SPHDEM_OK) ? SPHDEM_OK : SPHDEM_ERR_ALLOC;
  if (rc != SPHDEM_OK) {
    free(keep);
    free(parent);
    free(g.p);
    return -SPHDEM_ERR_ALLOC;
  }
  long nfar = 0;
  for (long i = 0; i < n; i++) {
    const double *x = p->x + 3 * i;
    long first, nf = facetgrid_cell(&g, x, &first);
    double d2 = HUGE_VAL, s = 0.0;
    long best = nf ? nearest_facet(m, &g.p[first], nf, x, tie, &d2, &s) : -1;
    parent[i] = i;
    if (best >= 0 && d2 <= R * R) {
      keep[i] = (s > -tol && sqrt(d2) >= gap - tol) ? 1 : 0;
    } else {
      keep[i] = -1;
      nfar++;
    }
  }
  if (nfar) {
    /* far points: lattice neighbours (6) form components; a component takes the side of a near point next to it,
     * or (none next to it) of the nearest facet of its first point over the whole mesh */
    const double *x0 = p->x;
    for (long i = 0; i < n; i++) {
      uint64_t k = lattice_key(p->x + 3 * i, x0, dx);
      size_t b = key_hash(k, h.mask);
      h.key[i] = k;
      h.next[i] = h.head[b];
      h.head[b] = i;
    }
    long *side = (long *)malloc((size_t)n * sizeof(long)); /* per root: -1 unknown, else 0/1 */
    if (!side) rc = SPHDEM_ERR_ALLOC;
    for (long i = 0; i < n && rc == SPHDEM_OK; i++) side[i] = -1;
    static const int nb[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (int pass = 0; pass < 2 && rc == SPHDEM_OK; pass++)
      for (long i = 0; i < n; i++) {
        if (keep[i] != -1) continue;
        for (int a = 0; a < 6; a++) {
          double y[3];
          for (int d = 0; d < 3; d++) y[d] = p->x[3 * i + d] + nb[a][d] * dx;
          uint64_t k = lattice_key(y, x0, dx);
          for (long j = h.head[key_hash(k, h.mask)]; j >= 0; j = h.next[j]) {
            if (h.key[j] != k) continue;
            if (pass == 0 && keep[j] == -1) { /* pass 0: join the far components */
              long ri = uf_find(parent, i), rj = uf_find(parent, j);
              if (ri != rj) parent[ri < rj ? rj : ri] = ri < rj ? ri : rj;
            } else if (pass == 1 && keep[j] != -1) { /* pass 1: a near neighbour decides */
              long r = uf_find(parent, i);
              if (side[r] < 0) side[r] = keep[j];
            }
          }
        }
      }
    for (long i = 0; i < n && rc == SPHDEM_OK; i++) {
      if (keep[i] != -1) continue;
      long r = uf_find(parent, i);
      if (side[r] < 0) {
        double d2, s;
        nearest_facet(m, NULL, m->nfacet, p->x + 3 * r, tie, &d2, &s);
        side[r] = s > -tol ? 1 : 0;
      }
      keep[i] = (signed char)side[r];
    }
    free(side);
  }
  long kept = 0;
  if (rc == SPHDEM_OK) {
    for (long i = 0; i < n; i++) {
      if (!keep[i]) continue;
      if (kept != i) memmove(p->x + 3 * kept, p->x + 3 * i, 3 * sizeof(double));
      kept++;
    }
    p->n = kept;
  }
  cellhash_free(&h);
  free(keep);
  free(parent);
  free(g.p);
  return rc == SPHDEM_OK ? n - kept : -SPHDEM_ERR_ALLOC;
}
