/* bench_bed.c - the packed bed at rest of tests/common/couple_bed.h (SPH-DEM coupling, He 2018 eqs 6-7, 26, 33):
 * how eps enters the momentum equation. Prints the fluid's vmax, the pressure error and the grains' Archimedes
 * ratio; asserts nothing (unit_couple's bed_floating is the test: pressure_form volume, the bed inside the water).
 *   usage: [BED_...=value ...] bench_bed [cpu|gpu]
 * With the defaults (pressure_form mass, the bed against the side walls and the floor) the fluid does not stay at
 * rest (the bounds printed are those of a bed at rest: vmax < 1 % of sqrt(g H), pressure within 5 %, Archimedes
 * within 2 %). Knobs (environment): BED_PFORM, BED_STEPS, BED_DELTA, BED_DRAG, BED_SUPERFICIAL,
 * BED_NOGRAINS, BED_WALLEPS, BED_EPSWALLS, BED_TRACE and those below. Over 1000 steps the fluid at the bed's corners with the
 * walls accelerates into the walls (vmax ~0.1 m/s vs 6e-3 without grains), with or without superficial density
 * and drag (commit 1df9a2f). With BED_EPSWALLS=1 (eps_walls, commit f552615) the bed's porosity
 * is uniform up to the walls (0.748 beside them, 0.749 inside), Archimedes 0.993, pressure error 5.9 %, but vmax
 * still grows about twofold per 100 steps (5.1e-3 at 100, 6.4e-2 at 600), also with BED_SUPERFICIAL=0 and
 * BED_DELTA=0.
 * Measured 2026-11-24, commit beec234 (knobs BED_DTF: time step in h / (1.2 c0), default 0.2; BED_MU: fluid viscosity; BED_HCF: hc / h;
 * BED_INSET / BED_LIFT: grains kept that far from the side walls / lifted off the floor), all with
 * BED_EPSWALLS=1, vmax after 600 steps (0.065 s):
 *   - half the time step, 1200 steps: vmax and ke the same to 4 digits at the same time: the growth is a
 *     property of the spatial discretisation, not of the time integration;
 *   - viscosity 1e-6 / 1e-3 / 1e-2 Pa s: 6.5e-2 / 6.4e-2 / 6.2e-2 (not the viscous terms);
 *   - a bed away from the side walls (inset 15 mm), lifted 20 mm, or both: 5.8e-2 / 5.8e-2 / 4.5e-2, fastest
 *     fluid at the bed's edges: not the walls; it starts where the porosity changes;
 *   - without the reaction (eq 33 skipped, a temporary switch): vmax stays 4e-3 to 1.2e-2, no growth (but the
 *     pressure is off by 14 %, as it must be without the reaction);
 *   - a pairwise reaction (each fluid particle gets back its own term of eqs 28 and 30, its own theta_a and
 *     v_a instead of the Shepard averages around the grain; same grain forces, same momentum balance; tried
 *     and not kept): 5.3e-2, so the reaction's second smoothing is not the cause;
 *   - hc = 0.6 / 0.8 / 1 / 1.5 / 2 h: 7.1e-3 (no growth, but Archimedes 0.92) / 3.3e-2 / 6.4e-2 / 8.0e-2 /
 *     8.8e-2.
 *   Hypothesis tested and not confirmed: that the scheme lacks a discrete energy balance once eps depends on
 *   position (the EOS P(rho_bar / eps(x)) changes a particle's internal energy as it moves through a porosity
 *   gradient, and no force does the matching work). An energy-consistent (variational) prototype was written
 *   and tried, then not kept. It used -sum_b m_b (eps_a P_a / rho_a^2 + eps_b P_b / rho_b^2) grad W plus
 *   V_a P_a grad eps_a (grad eps_a from eq 26) on the fluid, and the exact pairwise opposite
 *   V_j sum_a V_a P_a grad_a W_aj on the grains. The floating bed (inset 15 mm, lifted 20 mm) still grew:
 *   vmax 5.7e-2 after 600 steps. The bed on the floor got worse (1.1e-1, and Archimedes wrong: that form
 *   has no Shepard correction and its grain sum misses the walls).
 *   More knobs: BED_RELAX=N (the water alone first, N steps, velocities zeroed every 20), BED_DAMP=N (with the
 *   bed, N steps, velocities zeroed every 20; prints the drift and the fastest particles), BED_SHIFT=f and
 *   BED_JITTER=f (the grain lattice shifted by f dx, or each grain moved by up to +-f dx per axis).
 *   - The growth saturates. vmax is 0.10 / 0.12 / 0.09 m/s at 1000 / 1100 / 1500 steps, and ke levels off
 *     at 1.6e-4 J after ~1200 steps (0.13 s). That is 3e-4 of the water's rho g H V scale, and the weak
 *     viscosity does not take it out. So it is not a runaway.
 *   - The tank without grains also leaves its lattice, later: vmax 6e-3 at 1000 steps, 5.0e-2 at 1500
 *     (ke 5.6e-5 J). After BED_RELAX=2000 the water alone stays quiet for 1000 steps (ke <= 8.5e-7 J).
 *     With the bed, BED_RELAX=2000 changes nothing: 6.49e-2 at 600 steps. The bed drives the flow.
 *   - BED_DAMP shows that the bed has no rest state near the lattice. With velocities zeroed every 20
 *     steps, the largest acceleration stays at 0.48-0.69 m/s^2 and grows as the particles drift (max
 *     displacement 1.8e-5 m at 200 steps, 1.3e-4 m at 2000): a negative stiffness. The drifting particles are
 *     the two columns at each vertical edge of the tank inside the bed: the corner column (0.5 dx from both
 *     walls) moves up and the diagonal one (1.5 dx) moves down, over the whole bed height. The floating bed
 *     drifts the same way at its own vertical edges.
 *   - The test puts the grains on the fluid particles (both lattices at (i + 1/2) dx). Shifting them by
 *     dx/4 or dx/2, or jittering them by up to 0.3 dx, makes it worse: vmax 0.17 / 0.26 / 0.13 m/s at 1000
 *     steps, against 0.10.
 *   Cause (2026-12-01, commit 5c63aae): the mass form of eq 9 (m_b P_b / rho_b^2 with m_b = eps_b m_0) weights the pressure gradient
 *   with the neighbours' porosity (-<1/eps> grad P / rho instead of -grad P / (eps_a rho)), so the columns at the
 *   bed's edges do not balance (water weight + reaction). BED_PFORM=1 (keyword pressure_form volume,
 *   -V_a V_b (P_a + P_b) grad W) removes it wherever the bed's edges are in the water: BED_INSET=0.015 with or
 *   without BED_LIFT=0.02 gives vmax 5.5e-3 / ke 1.7e-7 J at 600 steps, BED_NOGRAINS=1 5.5e-3 / 9e-8 J (the default-run
 *   test bed_floating of unit_couple asserts it). Against the side walls (no inset) it stays 5.4e-2: there eq 26 (cut kernel) and
 *   eq 33 (shared among fewer particles) disagree. A porosity from eq 33's weights (V_j / sigma_j in eq 26; a
 *   prototype, not kept) made the side columns quiet (ke 1e-6 J) but the bottom-corner particles (three walls)
 *   ran into the corner and left the tank at ~1000 steps (2 m/s), also with sigma_j floored at 0.3 or 0.5.
 * Grains held fixed on a lattice in the lower half of a 3D tank (solid fraction ~0.26 in the bed). The fluid is
 * uploaded consistently with the superficial formulation: rho = eps rho_hydro, m = rho V_lattice (so m/rho is
 * the mixture volume of the lattice). Then the fluid must stay at rest, the pressure must stay hydrostatic in
 * the intrinsic density (P(rho/eps)), and each grain feels Archimedes' rho_f V g. */

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "couple_bed.h"

static double knob(const char *k, double def) { const char *e = getenv(k); return e ? atof(e) : def; }

int main(int argc, char **argv) {
  sphdem_device dev = argc > 1 && !strcmp(argv[1], "gpu") ? SPHDEM_DEVICE_GPU : SPHDEM_DEVICE_CPU;
  bed_opts o;
  bed_opts_default(&o);
  o.delta = knob("BED_DELTA", o.delta); o.mu = knob("BED_MU", 0);
  o.drag = (int)knob("BED_DRAG", o.drag); o.superficial = (int)knob("BED_SUPERFICIAL", -1);
  o.wall_porosity = (int)knob("BED_WALLEPS", o.wall_porosity); o.eps_walls = (int)knob("BED_EPSWALLS", -1);
  o.hc_over_h = knob("BED_HCF", 0); o.pressure_form = (int)knob("BED_PFORM", 0);
  o.nograins = getenv("BED_NOGRAINS") != NULL; o.shift = knob("BED_SHIFT", 0); o.jitter = knob("BED_JITTER", 0);
  o.inset = knob("BED_INSET", 0); o.lift = knob("BED_LIFT", 0);
  o.relax = (int)knob("BED_RELAX", 0); o.damp = (int)knob("BED_DAMP", 0);
  o.dt_factor = knob("BED_DTF", o.dt_factor); o.steps = (int)knob("BED_STEPS", o.steps);
  o.trace = getenv("BED_TRACE") != NULL;
  bed_result r;
  bed_run(&o, dev, &r);
  printf("BED vmax %.3e m/s (at rest: < %.3e) pressure_error %.4f (< 0.05) archimedes %.4f (1 +- 0.02)\n", r.vmax,
         0.01 * r.vscale, r.perr, r.buo);
  return 0;
}
