/* test_eos.c - Tait equation of state (He 2018 eqs 7, 8, 15) and the hydrostatic initial density. */
#include <math.h>
#include "sph_bodies.h"
#include "testlib.h"

int main(void) {
  sphdem_params p;
  sphdem_params_default(&p);
  p.dim = 2; p.h = 0.013; p.dx = 0.01; p.rho0 = 1000; p.c0 = 20; p.gravity[1] = -9.81;
  sphdem_dev D;
  memset(&D, 0, sizeof D);
  D.P = p;
  D.B = sphdem_tait_B(&p);
  D.gamma_is_7 = 1;
  TEST_ASSERT(fabs(D.B - 20.0 * 20.0 * 1000.0 / 7.0) < 1e-9, "B = c0^2 rho0 / gamma");
  TEST_ASSERT(tait_pressure(&D, 1000.0) == 0.0, "P(rho0) = 0");
  double rho = 1013.7, pr = tait_pressure(&D, rho);
  TEST_ASSERT(fabs(pr - D.B * (pow(rho / 1000.0, 7.0) - 1.0)) < 1e-9 * fabs(pr), "gamma 7 fast path equals pow()");
  TEST_ASSERT(fabs(tait_density(&D, pr) - rho) < 1e-10 * rho, "eq 15 inverts eq 7");
  /* generic gamma path */
  D.P.gamma = 1.4; D.gamma_is_7 = 0; D.B = sphdem_tait_B(&D.P);
  pr = tait_pressure(&D, rho);
  TEST_ASSERT(fabs(tait_density(&D, pr) - rho) < 1e-10 * rho, "inversion holds for gamma 1.4");
  /* sound speed: dP/drho at rho0 = c0^2 */
  double e = 1e-4, c2 = (tait_pressure(&D, 1000 + e) - tait_pressure(&D, 1000 - e)) / (2 * e);
  TEST_ASSERT(fabs(c2 - 400.0) < 1e-5 * 400.0, "dP/drho(rho0) = c0^2 (got %g)", c2);
  /* hydrostatic density gives P = rho0 g depth exactly */
  D.P.gamma = 7; D.gamma_is_7 = 1; D.B = sphdem_tait_B(&D.P);
  for (double depth = 0.0; depth <= 1.0; depth += 0.25) {
    double r = sphdem_hydrostatic_rho(&p, depth), pp = tait_pressure(&D, r);
    TEST_ASSERT(fabs(pp - 1000 * 9.81 * depth) < 1e-8 * (1 + pp), "hydrostatic rho at depth %g gives P %g", depth, pp);
  }
  return test_summary("eos");
}
