/* dem_granular_table.h - the two-type table of the granular model (LAMMPS pair_style granular) that the DEM unit
 * and twin tests share: pair (0,0) hertz/material + tsuji + marshall twisting, the cross pairs (1, 2) hertz with
 * damping `damp12`, pair (1,1) dmt + viscoelastic + mindlin; linear_history tangential, sds rolling everywhere. */
#ifndef SPHDEM_TEST_DEM_GRANULAR_TABLE_H
#define SPHDEM_TEST_DEM_GRANULAR_TABLE_H

#include <string.h>

#include "sphdem.h"

static inline void dem_granular_test_table(sphdem_dem_granular *t, int damp12) {
  memset(t, 0, sizeof(sphdem_dem_granular) * 4);
  for (int k = 0; k < 4; k++) {
    sphdem_dem_granular *c = &t[k];
    c->normal = k == 0 ? SPHDEM_GRAN_HERTZ_MATERIAL : k == 3 ? SPHDEM_GRAN_DMT : SPHDEM_GRAN_HERTZ;
    c->damping = k == 0 ? SPHDEM_GRAN_DAMP_TSUJI : k == 3 ? SPHDEM_GRAN_DAMP_VISCOELASTIC : damp12;
    c->tangential = k == 3 ? SPHDEM_GRAN_TANG_MINDLIN : SPHDEM_GRAN_TANG_LINEAR_HISTORY;
    c->rolling = SPHDEM_GRAN_ROLL_SDS;
    c->twisting = k == 0 ? SPHDEM_GRAN_TWIST_MARSHALL : SPHDEM_GRAN_TWIST_SDS;
    c->kn = k == 1 || k == 2 ? 2e6 : 1e7;
    c->damp = k == 0 ? 0.5 : 1e2;
    c->cohesion = 0.05;
    c->kt = k == 3 ? 5e6 : 5e5;
    c->damp_t = 0.5;
    c->mu = 0.4;
    c->kr = 10;
    c->damp_r = 0.01;
    c->mu_r = 0.2;
    c->ktw = 1e-3;
    c->damp_tw = 1e-6;
    c->mu_tw = 0.1;
  }
}

#endif
