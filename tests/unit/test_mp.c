/* test_mp.c - unit tests of the multiphase fluid (Shi & Huang 2022; gpu/sph/mp.c, gpu/sph/mp_bodies.h) on the CPU:
 * rheology and EOS closed forms, parameter checks, the renormalised shear rate of a linear shear field
 * (2D and 3D), the lambda classification of interior and free-surface particles, momentum conservation
 * of the pair terms, phase handling through resorts. */
#include <math.h>
#include "scene.h"
#include "testlib.h"

static sphdem_phase phase(double rho0, double ty, double K, double N, double cut) {
  sphdem_phase f = {rho0, ty, K, N, cut, 0};
  return f;
}

/* A periodic lattice block (all axes periodic) of n^dim particles at spacing dx; velocity u_x = gd * y
 * (shear) when gd != 0, or a pseudo-random field of amplitude 0.01 when gd == 0. */
static sphdem_ctx lattice(int dim, int n, double dx, double gd, const sphdem_mp_params *m, int periodic_y,
                          scene *s, int **ph) {
  sphdem_params p;
  sphdem_params_default(&p);
  p.dim = dim; p.dx = dx; p.h = 1.5 * dx; p.rho0 = 1000; p.c0 = 10; p.skin = 0.3 * dx;
  double L = n * dx;
  for (int d = 0; d < dim; d++) { p.periodic[d] = 1; p.boxlo[d] = 0; p.boxhi[d] = L; }
  if (!periodic_y) { p.periodic[1] = 0; p.boxlo[1] = -L; p.boxhi[1] = 2 * L; }
  memset(s, 0, sizeof *s);
  int nz = dim == 3 ? n : 1;
  unsigned seed = 12345;
  *ph = (int *)malloc(sizeof(int) * n * n * nz);
  for (int k = 0; k < nz; k++)
    for (int j = 0; j < n; j++)
      for (int i = 0; i < n; i++) {
        double x[3] = {(i + 0.5) * dx, (j + 0.5) * dx, dim == 3 ? (k + 0.5) * dx : 0.0};
        scene_push_fluid(s, x, 1000.0, 1000.0 * pow(dx, dim));
        int q = s->nf - 1;
        (*ph)[q] = j < n / 2 ? 0 : 1;
        for (int d = 0; d < 3; d++) {
          seed = seed * 1103515245u + 12345u;
          s->v[3 * q + d] = gd != 0 ? (d == 0 ? gd * x[1] : 0.0) : (d < dim ? 0.01 * ((seed >> 8) % 1000 / 500.0 - 1) : 0);
        }
      }
  sphdem_ctx c;
  char msg[256];
  if (sphdem_create(&c, &p, test_device(), msg, sizeof msg)) { fprintf(stderr, "%s\n", msg); exit(1); }
  SPHDEM_CHECK_RC(c, sphdem_mp_set(c, m));
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s->nf, s->tag, s->x, s->v, s->rho, s->mass, NULL));
  SPHDEM_CHECK_RC(c, sphdem_set_fluid_phase(c, s->nf, *ph));
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  return c;
}

int main(void) {
  /* ---- rheology (eqs 13, 23) */
  sphdem_phase newt = phase(1000, 0, 2.5, 1, 0), bing = phase(1000, 10, 2, 1, 0.5), pl = phase(1000, 0, 3, 0.5, 0.1);
  TEST_ASSERT(sphdem_mp_viscosity(&newt, 0) == 2.5 && sphdem_mp_viscosity(&newt, 100) == 2.5, "Newtonian viscosity is K");
  TEST_ASSERT(fabs(sphdem_mp_viscosity(&bing, 4) - (10 / 4.0 + 2)) < 1e-14, "Bingham above the cut-off: tau_y/g + K");
  TEST_ASSERT(fabs(sphdem_mp_viscosity(&bing, 0.1) - (10 / 0.5 + 2)) < 1e-14, "Bingham below the cut-off: held at mu(cut)");
  TEST_ASSERT(fabs(sphdem_mp_viscosity(&pl, 4) - 3 / 2.0) < 1e-14, "power law N = 0.5 at 4/s: K g^(N-1) = 1.5");
  TEST_ASSERT(fabs(sphdem_mp_viscosity(&pl, 0) - 3 / sqrt(0.1)) < 1e-12, "power law at rest: K cut^(N-1)");

  /* ---- EOS (eq 4 and per-phase Tait) and its inverse */
  sphdem_params p;
  sphdem_params_default(&p);
  p.dim = 2; p.h = 0.015; p.dx = 0.01; p.rho0 = 1000; p.c0 = 20;
  sphdem_mp_params m;
  sphdem_mp_params_default(&m);
  m.enabled = 1; m.nphase = 2; m.phase[0] = phase(2000, 0, 1, 1, 0); m.phase[1] = phase(1000, 0, 1e-3, 1, 0);
  m.p0 = 100;
  TEST_ASSERT(fabs(sphdem_mp_pressure(&m, &p, 0, 2001) - (400 * 1 + 100)) < 1e-9, "linear EOS c0^2 (rho - rho0) + P0");
  for (int eos = 0; eos < 2; eos++) {
    m.eos = eos;
    double worst = 0;
    for (int k = 0; k < 2; k++)
      for (double pr = 0; pr < 5e4; pr += 1e3) {
        double r = sphdem_mp_density(&m, &p, k, pr);
        worst = fmax(worst, fabs(sphdem_mp_pressure(&m, &p, k, r) - pr));
      }
    TEST_ASSERT(worst < 1e-7, "%s EOS inverted to 1e-7 Pa (worst %.2e)", eos ? "linear" : "Tait", worst);
  }
  m.eos = SPHDEM_EOS_LINEAR;
  m.p0 = 0;

  /* ---- parameter checks name the field */
  char msg[256];
  sphdem_mp_params bad = m;
  bad.phase[1] = phase(1000, 5, 1, 1, 0);
  TEST_ASSERT(sphdem_mp_params_check(&bad, &p, msg, sizeof msg) == SPHDEM_ERR_ARG && strstr(msg, "phase 2: a yield stress"),
              "yield stress without cut-off rejected (%s)", msg);
  bad = m; bad.nphase = 9;
  TEST_ASSERT(sphdem_mp_params_check(&bad, &p, msg, sizeof msg) == SPHDEM_ERR_ARG && strstr(msg, "nphase"), "nphase > 4 rejected");
  sphdem_params pv = p;
  pv.visc = SPHDEM_VISC_MORRIS; pv.mu = 1e-3;
  TEST_ASSERT(sphdem_mp_params_check(&m, &pv, msg, sizeof msg) == SPHDEM_ERR_ARG && strstr(msg, "visc none"),
              "Morris viscosity with phases rejected (%s)", msg);

  /* ---- shear rate of u_x = gd y in the interior, renormalised (eq 26), 2D and 3D; power-law viscosity */
  for (int dim = 2; dim <= 3; dim++) {
    sphdem_mp_params ms = m;
    ms.phase[0] = phase(1000, 0, 3, 0.5, 0.1); ms.phase[1] = ms.phase[0];
    ms.phase[0].rho0 = ms.phase[1].rho0 = 1000;
    scene s;
    int *ph;
    int n = dim == 2 ? 24 : 12;
    double gd = 4.0, dx = 0.01;
    sphdem_ctx c = lattice(dim, n, dx, gd, &ms, 0, &s, &ph);
    double *mu = malloc(8 * s.nf), *g = malloc(8 * s.nf), worst = 0, worstmu = 0;
    SPHDEM_CHECK_RC(c, sphdem_mp_get_fields(c, mu, g, NULL, NULL));
    int cnt = 0;
    for (int i = 0; i < s.nf; i++) {
      double y = s.x[3 * i + 1];
      if (y < 3 * dx || y > (n - 3) * dx) continue; /* away from the free top and bottom */
      worst = fmax(worst, fabs(g[i] - gd) / gd);
      worstmu = fmax(worstmu, fabs(mu[i] - 3 / 2.0) / 1.5);
      cnt++;
    }
    TEST_ASSERT(cnt > 0 && worst < 1e-9, "%dD: |D| of a linear shear = 4/s in the interior (worst rel. error %.1e, %d "
                "particles)", dim, worst, cnt);
    TEST_ASSERT(worstmu < 1e-9, "%dD: power-law viscosity K |D|^(N-1) = 1.5 (worst %.1e)", dim, worstmu);
    free(mu); free(g); free(ph);
    scene_free(&s);
    sphdem_destroy(&c);
  }

  /* ---- lambda (§3.3): ~1 inside, < 0.55 at a free surface; interface particles of two phases are
   * classified as interface too (same-phase sums), 2D and 3D */
  for (int dim = 2; dim <= 3; dim++) {
    sphdem_mp_params ms = m;
    ms.shifting = 1;
    scene s;
    int *ph;
    int n = dim == 2 ? 24 : 12;
    double dx = 0.01;
    sphdem_ctx c = lattice(dim, n, dx, 0, &ms, 0, &s, &ph);
    double *lam = malloc(8 * s.nf);
    SPHDEM_CHECK_RC(c, sphdem_mp_get_fields(c, NULL, NULL, lam, NULL));
    double in_min = 1e9, surf_max = 0, int_max = 0;
    for (int i = 0; i < s.nf; i++) {
      double y = s.x[3 * i + 1];
      int row = (int)floor(y / dx);
      if (row == 0 || row == n - 1) surf_max = fmax(surf_max, lam[i]);
      else if (row == n / 2 - 1 || row == n / 2) int_max = fmax(int_max, lam[i]);
      else if (row >= 3 && row <= n - 4 && abs(row - n / 2) >= 3) in_min = fmin(in_min, lam[i]);
    }
    TEST_ASSERT(in_min > 0.95, "%dD: lambda > 0.95 inside a phase (min %.3f)", dim, in_min);
    TEST_ASSERT(surf_max < 0.55, "%dD: lambda < 0.55 on the free surfaces (max %.3f)", dim, surf_max);
    TEST_ASSERT(int_max < 0.9, "%dD: lambda < 0.90 beside the phase interface (max %.3f)", dim, int_max);
    free(lam); free(ph);
    scene_free(&s);
    sphdem_destroy(&c);
  }

  /* ---- momentum: pressure (eq 20) and viscous (eq 24) pair terms are antisymmetric: sum m a = 0 for a
   * random velocity field in a fully periodic box of two phases (no gravity, no shifting, no walls) */
  {
    sphdem_mp_params ms = m;
    ms.phase[0] = phase(2000, 5, 2, 0.7, 0.3);
    ms.diffusion = SPHDEM_DIFF_RENORM;
    ms.cs_les = 0.12;
    scene s;
    int *ph;
    sphdem_ctx c = lattice(2, 20, 0.01, 0, &ms, 1, &s, &ph);
    /* density of phase 0 as its rho0 (mass rho dx^2) would be 2000: use the upload's 1000 for both so that
     * the pressures differ between the phases (eq 4 with different rho0) */
    double *st = malloc(8 * SPHDEM_NSTATE * s.nf), sum[3] = {0, 0, 0}, ref = 0;
    SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, NULL, NULL, NULL, NULL, st));
    for (int i = 0; i < s.nf; i++)
      for (int d = 0; d < 2; d++) {
        double f = s.mass[i] * st[SPHDEM_NSTATE * i + 1 + d];
        sum[d] += f;
        ref = fmax(ref, fabs(f));
      }
    TEST_ASSERT(fabs(sum[0]) < 1e-12 * ref * s.nf && fabs(sum[1]) < 1e-12 * ref * s.nf,
                "sum of m a = (%.1e, %.1e), largest |m a| %.1e: Newton's third law", sum[0], sum[1], ref);
    /* phases survive a resort: move every particle by half a period and recompute */
    for (int i = 0; i < s.nf; i++) s.x[3 * i] = fmod(s.x[3 * i] + 0.1, 0.2);
    SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
    SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
    double *p1 = malloc(8 * s.nf);
    SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, NULL, NULL, NULL, p1, NULL));
    int wrong = 0;
    for (int i = 0; i < s.nf; i++) /* rho 1000 everywhere: phase 0 (rho0 2000) has -c0^2 1000, phase 1 zero */
      wrong += fabs(p1[i] - (ph[i] == 0 ? -100.0 * 1000.0 : 0.0)) > 1e-6;
    TEST_ASSERT(wrong == 0, "every particle keeps its phase through a resort (%d wrong pressures)", wrong);
    free(st); free(p1); free(ph);
    scene_free(&s);
    sphdem_destroy(&c);
  }
  return test_summary("mp");
}
