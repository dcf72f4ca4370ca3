/* features.c - the features of the fluid context, in the order the core calls their hooks (sph_internal.h,
 * sphdem_feature): the SPH-DEM coupling (couple/couple.c), the delta-plus / multiphase fluid (sph/mp.c), the
 * ghost walls, the Runge-Kutta arrays and the kernel sums (sph/fluid_options.c). A new feature adds its object
 * here; sph.c does not change. */
#include "sph_internal.h"

const sphdem_feature *const sphdem_features[] = {&sphdem_feature_couple, &sphdem_feature_mp, &sphdem_feature_ghost,
                                                    &sphdem_feature_rk, &sphdem_feature_iso, NULL};
