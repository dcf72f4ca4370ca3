/* bench_dambreak.c - dam-break throughput benchmark over the public sphdem API.
 *
 * Scene (tests/common/scene.h): water column a wide and 2a high at the left end of a tank 5a long
 * (3a high walls), 3 layers of dummy wall particles, dx = a/res, h = 1.3 dx,
 * c0 = 10 sqrt(2 g a), Monaghan artificial viscosity alpha = 0.02, Monaghan tensile correction
 * eps = 0.01 n = 4 (off with --tensile 0), dt = 0.2 h / (1.2 c0). In 3D the tank and the column
 * get a width W = width*a (SPHERIC-like box, walls on all sides and the bottom).
 *
 * It runs `warmup` steps (not timed), resets the phase timers, runs `steps` timed velocity-Verlet
 * steps and prints ONE machine-readable line starting with "BENCH" (key=value pairs):
 *   code backend dim threads nfluid nwall steps wall_s psteps_per_s, the phase split from
 *   sphdem_timers (t_sort t_wall t_rates t_integrate t_transfer t_reduce, seconds, timed steps
 *   only), bytes_per_particle (sphdem_device_bytes / nfluid), nsorts, the final fluid kinetic
 *   energy ke and surge front (max x / a) for a physics cross-check, and the final state check.
 * particle-steps/s counts fluid particles only (nfluid * steps / wall_s).
 *
 * --write-liggghts FILE writes the same particles (fluid type 1, wall type 2, hydrostatic
 * density) as a LIGGGHTS atom_style sph data file and exits: the LIGGGHTS side of
 * bench/run_cpu_vs_liggghts.py reads it so that both codes start from identical particles.
 *
 * This is a benchmark, not a test: it asserts nothing about speed. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene.h"
#include "bench_util.h"
#include "sphdem.h"


static void usage(const char *prog) {
  fprintf(stderr,
          "usage: %s [--n NFLUID | --res R] [--steps S] [--warmup W] [--device cpu|gpu|auto]\n"
          "          [--threads T] [--dim 2|3] [--width W/a] [--skin S/h] [--tensile EPS]\n"
          "          [--alpha A] [--write-liggghts FILE [--liggghts-split 1]] [--mp 0|1|2]\n"
          "          [--precision double|mixed|single]\n"
          "  --n        target fluid particle count (res chosen so that nfluid ~ NFLUID), default 1e4\n"
          "  --res      particles across the column width a (overrides --n)\n"
          "  --steps    timed steps (default 100); --warmup untimed steps before (default 5)\n"
          "  --precision the fluid's pair arithmetic (sphdem_params.precision), default double\n"
          "  --threads  OpenMP threads (omp_set_num_threads), default: OpenMP's default\n"
          "  --dim 3    3D box of width W*a (default W = 1)\n"
          "  --skin     resort skin in units of h (default 0.25, as LIGGGHTS' sph tutorials)\n"
          "  --mp       multiphase fluid (Shi & Huang 2022): the column's left half phase 0 (Herschel-Bulkley\n"
          "             tau_y 1, K 0.1, N 0.8, cut 1), right half phase 1 (Newtonian 1e-3), both rho0 1000, linear\n"
          "             EOS; 1: no delta-plus terms, 2: renormalised diffusion, shifting and LES on (default 0:\n"
          "             the single-phase fluid with artificial viscosity and tensile correction)\n",
          prog);
}

/* Hydrostatic density of a wall particle for the LIGGGHTS dynamic-boundary start: depth below the
 * free surface where fluid is above it (inside the column's horizontal extent), else rho0. */
static double wall_rho(const sphdem_params *p, const double *x, double a, double W, double fh) {
  int up = p->dim - 1;
  int under = x[0] < a && (p->dim == 2 || x[1] < W);
  double depth = fh - x[up];
  return under && depth > 0 ? sphdem_hydrostatic_rho(p, depth) : p->rho0;
}

static int write_liggghts_data(const char *fn, const scene *s, const sphdem_params *p, double a, double W,
                               double fh, const double *lo, const double *hi) {
  FILE *f = fopen(fn, "w");
  if (!f) { perror(fn); return 1; }
  fprintf(f, "sphdem dam break (bench_dambreak --write-liggghts), dim %d, dx %.17g\n\n", p->dim, p->dx);
  fprintf(f, "%d atoms\n2 atom types\n\n", s->nf + s->nw);
  fprintf(f, "%.17g %.17g xlo xhi\n%.17g %.17g ylo yhi\n%.17g %.17g zlo zhi\n\n", lo[0], hi[0], lo[1], hi[1],
          lo[2], hi[2]);
  double m = p->dim == 3 ? p->rho0 * p->dx * p->dx * p->dx : p->rho0 * p->dx * p->dx;
  fprintf(f, "Masses\n\n1 %.17g\n2 %.17g\n\nAtoms\n\n", m, m);
  /* atom_style sph in LIGGGHTS 3.8 (Debian): AtomVecSPH declares 6 data columns but reads the
   * coordinates from columns 5-7 (x column index off by one), so a 6-column line "id type rho x y z"
   * is read as x = y, y = z, z = past the end of the line (garbage; segfaults beyond ~10^4 atoms).
   * The form that reads correctly is 9 columns: "id type rho 0 x y z ix iy", where z doubles as
   * the first image flag (0 in 2D, image flags do not matter with boundary f f p). */
  if (p->dim != 2) fprintf(stderr, "bench_dambreak: note: the LIGGGHTS data file layout is only checked in 2D\n");
  for (int i = 0; i < s->nf; i++)
    fprintf(f, "%d 1 %.12g 0 %.12g %.12g 0 0 0\n", i + 1, s->rho[i], s->x[3 * i], s->x[3 * i + 1]);
  for (int i = 0; i < s->nw; i++)
    fprintf(f, "%d 2 %.12g 0 %.12g %.12g 0 0 0\n", s->nf + i + 1, wall_rho(p, s->wx + 3 * i, a, W, fh),
            s->wx[3 * i], s->wx[3 * i + 1]);
  return fclose(f) != 0;
}

int main(int argc, char **argv) {
  double ntarget = 1e4, width = 1.0, skin_h = 0.25, tensile = 0.01, alpha = 0.02;
  int res = 0, steps = 100, warmup = 5, threads = 0, dim = 2;
  int lig_split = 0, mpmode = 0;
  const char *devname = "cpu", *lig = NULL, *precname = "double";
  const bench_opt opts[] = {{"--n", 'd', &ntarget}, {"--res", 'i', &res}, {"--steps", 'i', &steps},
                            {"--warmup", 'i', &warmup}, {"--device", 's', &devname}, {"--threads", 'i', &threads},
                            {"--dim", 'i', &dim}, {"--width", 'd', &width}, {"--skin", 'd', &skin_h},
                            {"--tensile", 'd', &tensile}, {"--alpha", 'd', &alpha}, {"--write-liggghts", 's', &lig},
                            {"--liggghts-split", 'i', &lig_split}, {"--mp", 'i', &mpmode},
                            {"--precision", 's', &precname}};
  int parsed = bench_parse(argc, argv, opts, (int)(sizeof opts / sizeof opts[0]));
  if (parsed) { usage(argv[0]); return parsed == 1 ? 0 : 2; }
  sphdem_device dev;
  if (bench_device(devname, &dev)) { usage(argv[0]); return 2; }
  if ((dim != 2 && dim != 3) || steps < 1 || warmup < 0 || width <= 0) { usage(argv[0]); return 2; }
  threads = bench_threads(threads);
  int prec = !strcmp(precname, "double") ? SPHDEM_PREC_DOUBLE : !strcmp(precname, "mixed") ? SPHDEM_PREC_MIXED
             : !strcmp(precname, "single") ? SPHDEM_PREC_SINGLE : -1;
  if (prec < 0) {
    fprintf(stderr, "bench_dambreak: --precision must be double, mixed or single (got %s)\n", precname);
    return 2;
  }

  /* fluid count: 2D res * 2res, 3D res * (width res) * 2res */
  if (res <= 0) res = dim == 2 ? (int)lround(sqrt(ntarget / 2.0)) : (int)lround(cbrt(ntarget / (2.0 * width)));
  if (res < 4) res = 4;
  const double a = 1.0, g = 9.81, L = 5.0 * a, Ht = 3.0 * a, fh = 2.0 * a;
  const double W = dim == 3 ? width * a : 0.0;
  const int nl = 3;

  sphdem_params p;
  sphdem_params_default(&p);
  p.dim = dim;
  p.dx = a / res;
  p.h = 1.3 * p.dx;
  p.rho0 = 1000.0;
  p.c0 = 10.0 * sqrt(2.0 * g * a);
  p.gamma = 7.0;
  p.gravity[dim - 1] = -g;
  p.visc = SPHDEM_VISC_ARTIFICIAL;
  p.alpha = alpha;
  p.tensile_eps = tensile;
  p.tensile_n = 4.0;
  p.skin = skin_h * p.h;
  p.precision = prec;
  const double dt = 0.2 * p.h / (1.2 * p.c0);

  scene s;
  scene_tank(&s, &p, L, W, Ht, a, fh, nl);

  if (lig) {
    /* LIGGGHTS box: walls plus a margin; 2D: thin periodic z slab (dimension 2). LIGGGHTS 3.8 has
     * no balance command and cuts the box into equal slabs, which would put the whole column on
     * one of 2 ranks: --liggghts-split 1 extends the box to the left so that its middle lies at
     * x = a/2 and a 2 x 1 grid splits the column in two. */
    double lo[3], hi[3], m = (nl + 1) * p.dx;
    lo[0] = lig_split ? a - L - m : -m; hi[0] = L + m;
    if (dim == 2) { lo[1] = -m; hi[1] = Ht + m; lo[2] = -0.5 * p.dx; hi[2] = 0.5 * p.dx; }
    else { lo[1] = -m; hi[1] = W + m; lo[2] = -m; hi[2] = Ht + m; }
    int rc = write_liggghts_data(lig, &s, &p, a, W, fh, lo, hi);
    /* the parameters the LIGGGHTS input needs, one line */
    printf("LIGGGHTS_DATA file=%s dim=%d nfluid=%d nwall=%d dx=%.17g h=%.17g c0=%.17g rho0=%.17g "
           "B=%.17g gamma=%.17g alpha=%.17g tensile=%.17g dt=%.17g skin=%.17g g=%.17g mass=%.17g\n",
           lig, dim, s.nf, s.nw, p.dx, p.h, p.c0, p.rho0, sphdem_tait_B(&p), p.gamma, p.alpha, p.tensile_eps,
           dt, p.skin, g, dim == 3 ? p.rho0 * p.dx * p.dx * p.dx : p.rho0 * p.dx * p.dx);
    scene_free(&s);
    return rc;
  }

  char msg[512] = "";
  sphdem_ctx c = NULL;
  double t_setup = wtime();
  if (sphdem_create(&c, &p, dev, msg, sizeof msg) != SPHDEM_OK) {
    fprintf(stderr, "bench_dambreak: sphdem_create failed: %s\n", msg);
    printf("BENCH code=sphdem status=create_failed device=%s\n", devname);
    return 1;
  }
  if (mpmode > 0) {
    sphdem_params pm = p;
    pm.visc = SPHDEM_VISC_NONE; pm.tensile_eps = 0.0;
    SPHDEM_CHECK_RC(c, sphdem_set_params(c, &pm));
    sphdem_mp_params m;
    sphdem_mp_params_default(&m);
    m.enabled = 1; m.nphase = 2;
    sphdem_phase mud = {1000, 1.0, 0.1, 0.8, 1.0, 0}, water = {1000, 0, 1e-3, 1, 0, 0};
    m.phase[0] = mud; m.phase[1] = water;
    if (mpmode == 2) { m.diffusion = SPHDEM_DIFF_RENORM; m.shifting = 1; m.cs_les = 0.12; }
    SPHDEM_CHECK_RC(c, sphdem_mp_set(c, &m));
  }
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  if (mpmode > 0) {
    int *ph = (int *)malloc(sizeof(int) * s.nf);
    for (int i = 0; i < s.nf; i++) ph[i] = s.x[3 * i] < 0.5 * a ? 0 : 1;
    SPHDEM_CHECK_RC(c, sphdem_set_fluid_phase(c, s.nf, ph));
    free(ph);
  }
  SPHDEM_CHECK_RC(c, sphdem_set_walls(c, s.nw, s.wx, s.wv, NULL, s.wmass));
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  for (int k = 0; k < warmup; k++) SPHDEM_CHECK_RC(c, scene_step(c, dt));
  t_setup = wtime() - t_setup;

  sphdem_timers_reset(c);
  int64_t sorts0 = sphdem_nsorts(c);
  double t0 = wtime();
  int rc = SPHDEM_OK, done = 0;
  for (; done < steps && rc == SPHDEM_OK; done++) rc = scene_step(c, dt);
  double wall_s = wtime() - t0;

  double tm[SPHDEM_NTIMERS];
  sphdem_timers(c, tm);
  sphdem_stats st;
  int src = rc == SPHDEM_OK ? sphdem_stats_get(c, dt, &st) : rc;
  if (rc != SPHDEM_OK) memset(&st, 0, sizeof st);
  const char *status = src == SPHDEM_OK ? "ok" : sphdem_strerror(src);
  if (src != SPHDEM_OK) fprintf(stderr, "bench_dambreak: state check after %d steps: %s\n", done, sphdem_last_error(c));

  /* surge front (max x of the fluid, in units of a): a cheap physics cross-check against the
   * LIGGGHTS run of the same scene, steps and dt (not timed) */
  double front = NAN;
  if (src == SPHDEM_OK && sphdem_get_fluid(c, s.x, NULL, NULL, NULL, NULL) == SPHDEM_OK) {
    front = -1e300;
    for (int i = 0; i < s.nf; i++) front = fmax(front, s.x[3 * i]);
    front /= a;
  }
  double psteps = (double)s.nf * done / wall_s;
  printf("BENCH code=sphdem mp=%d precision=%s backend=%s dim=%d threads=%d res=%d nfluid=%d nwall=%d steps=%d warmup=%d "
         "dt=%.6e wall_s=%.6f psteps_per_s=%.6e t_sort=%.6f t_wall=%.6f t_rates=%.6f t_integrate=%.6f "
         "t_transfer=%.6f t_reduce=%.6f bytes_per_particle=%.1f nsorts=%lld setup_s=%.3f "
         "vmax=%.4g ke=%.12g front=%.7f rho_err=%.4g status=%s\n",
         mpmode, precname, sphdem_backend(c) == SPHDEM_DEVICE_GPU ? "gpu" : "cpu", dim, sphdem_backend(c) == SPHDEM_DEVICE_GPU ? 0 : threads,
         res, s.nf, s.nw, done, warmup, dt, wall_s, psteps, tm[SPHDEM_T_SORT], tm[SPHDEM_T_WALL], tm[SPHDEM_T_RATES],
         tm[SPHDEM_T_INTEGRATE], tm[SPHDEM_T_TRANSFER], tm[SPHDEM_T_REDUCE],
         (double)sphdem_device_bytes(c) / (double)s.nf, (long long)(sphdem_nsorts(c) - sorts0), t_setup, st.vmax, st.ke, front,
         st.rho_err, status);
  const char *note = sphdem_backend_note(c);
  if (note && note[0]) fprintf(stderr, "bench_dambreak: backend note: %s\n", note);
  sphdem_destroy(&c);
  scene_free(&s);
  return src == SPHDEM_OK ? 0 : 1;
}
