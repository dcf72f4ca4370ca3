/* sphdem.h - the one public C API of the sphdem core (SPH fluid on CPU or CUDA). */
#ifndef SPHDEM_H
#define SPHDEM_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define SPHDEM_VERSION "0.1.0"

/* Error codes: defined once here; sphdem_strerror() gives their generic text,
 * sphdem_last_error() the specific message of the last failed call. */
#define SPHDEM_ERROR_LIST(X)                                                   \
  X(SPHDEM_OK, 0, "no error")                                                  \
  X(SPHDEM_ERR_ARG, 1, "invalid argument")                                     \
  X(SPHDEM_ERR_ALLOC, 2, "out of memory")                                      \
  X(SPHDEM_ERR_NO_GPU, 3, "no usable GPU")                                     \
  X(SPHDEM_ERR_CUDA, 4, "CUDA runtime error")                                  \
  X(SPHDEM_ERR_STATE, 5, "call not valid in the current state")               \
  X(SPHDEM_ERR_UNSTABLE, 6, "time step beyond a stability limit")              \
  X(SPHDEM_ERR_NAN, 7, "non-finite value in the fluid state")                  \
  X(SPHDEM_ERR_LOST, 8, "fluid particle left the domain")                      \
  X(SPHDEM_ERR_DENSITY, 9, "density error beyond the allowed bound")

enum sphdem_status {
#define SPHDEM_ENUM_(name, val, msg) name = val,
  SPHDEM_ERROR_LIST(SPHDEM_ENUM_)
#undef SPHDEM_ENUM_
  SPHDEM_NSTATUS
};

typedef enum { SPHDEM_DEVICE_AUTO = 0, SPHDEM_DEVICE_CPU = 1, SPHDEM_DEVICE_GPU = 2 } sphdem_device;
typedef enum { SPHDEM_PREC_DOUBLE = 0, SPHDEM_PREC_MIXED = 1, SPHDEM_PREC_SINGLE = 2 } sphdem_precision;
typedef enum { SPHDEM_VISC_NONE = 0, SPHDEM_VISC_MORRIS = 1, SPHDEM_VISC_ARTIFICIAL = 2 } sphdem_visc;

/* Many MPI ranks: the engine's reductions, given to a context by the shim (sphdem_set_comm,
 * sphdem_cfd_set_comm). allreduce combines buf[0..n) in place over every rank with op and returns 0 on
 * success; a context without one (allreduce NULL) is alone. The core never calls MPI itself. */
typedef enum { SPHDEM_RED_SUM = 0, SPHDEM_RED_MAX = 1, SPHDEM_RED_MIN = 2 } sphdem_red_op;
typedef struct {
  void *user;
  int (*allreduce)(void *user, double *buf, int n, int op);
  int rank, nranks;
  /* Halo exchange of a decomposed gas grid (sphdem_cfd_set_subdomain): send nsend doubles to the face neighbour
   * at dir (+1: the next rank along axis 0-2, -1: the previous one) and receive nrecv doubles from the neighbour
   * on the other side; a count of 0 means there is no message that way (no neighbour holding gas cells).
   * Returns 0 on success. May be NULL for contexts that do not decompose. */
  int (*exchange)(void *user, int axis, int dir, const double *send, int nsend, double *recv, int nrecv);
} sphdem_comm;

/* Physical and numerical parameters (He 2018 §2.1). Plain struct, passed by value to both backends.
 * Every optional term is off when its coefficient is 0. */
typedef struct {
  int dim;              /* 2 or 3; in 2D the z components are ignored and kept at their input value */
  double h;             /* smoothing length; kernel support is 2h (eq 5) */
  double dx;            /* initial particle spacing Δp (eq 11, default repulsion distance) */
  double rho0;          /* reference density */
  double c0;            /* artificial sound speed: B = c0^2 rho0 / gamma (eqs 7-8) */
  double gamma;         /* Tait exponent (7) */
  double gravity[3];    /* body acceleration g (eq 9, eq 14) */
  int visc;             /* sphdem_visc */
  double mu;            /* dynamic viscosity for Morris (eq 10) */
  double alpha;         /* Monaghan artificial viscosity coefficient */
  double tensile_eps;   /* Monaghan tensile correction coefficient, eq 11 (paper: 0.01); 0 = off */
  double tensile_n;     /* exponent of eq 11 (paper: 4) */
  double xsph_eps;      /* XSPH coefficient, eq 12 (paper: 0.3); 0 = off */
  double delta;         /* delta-SPH density diffusion coefficient (Molteni & Colagrossi 2009; 0.1 typical); 0 = off */
  int delta_hydro;      /* 1: subtract the hydrostatic density difference (Fourtakas et al. 2019), 0: plain */
  int wall_clamp;       /* 1: the extrapolated Adami wall pressure (eq 14) is floored at 0, so walls never pull
                           on fluid beside a free surface; 0 (default): as the paper */
  double isolated;      /* > 0: a fluid particle whose kernel sum sum_b V_b W_ab over fluid (V_b = m_b/rho_b, itself
                           included) and wall particles (V_w = m_w/rho0) (~1 inside the fluid and beside walls,
                           ~0.6 at a flat free surface) is below this value is isolated
                           (a splash, drops, water carried in a lifted grain bed) and its EOS density is kept at
                           or above the reference: it never goes into tension. 0 (default): off, as the papers */
  double rep_D;         /* Monaghan wall repulsion strength (m^2/s^2); 0 = off */
  double rep_r0;        /* repulsion cut-off distance (default dx) */
  double skin;          /* gap added to the 2h cell size; resort when a particle moved skin/2 */
  double cfl;           /* CFL number for the stable time step (0.25) */
  double rho_err_max;   /* blow-up bound on max |rho/rho0 - 1| (0.2) */
  double boxlo[3], boxhi[3];
  int periodic[3];
  int precision;        /* sphdem_precision: the fluid's pair arithmetic (rates pass, fluid and wall pairs) in double
                           (default), mixed (float pair terms from double positions, sums and state in double) or
                           single (as mixed, with the positions rounded to float in the pair terms and the state
                           x, v, rho and its rates kept at float precision, stored in the double arrays) */
} sphdem_params;

/* Global statistics, reduced on the device. */
typedef struct {
  int64_t nfluid, nwall;
  double vmax;          /* max |v| of fluid particles */
  double amax;          /* max |a| of fluid particles */
  double rho_err;       /* max |rho/rho0 - 1| */
  double ke;            /* fluid kinetic energy 1/2 sum m v^2 */
  double dt_cfl, dt_visc, dt_force, dt_stable; /* stable time step and its three limits */
  int64_t nnan;         /* particles with a non-finite x, v or rho */
  int64_t nlost;        /* fluid particles outside a non-periodic box side */
} sphdem_stats;

/* Wall-clock time spent per phase (seconds, accumulated since create or reset). SPHDEM_T_COUPLE: the SPH-DEM
 * coupling passes inside the rate evaluation (grain sort, porosity, grain forces, reaction; not in RATES). */
enum { SPHDEM_T_SORT = 0, SPHDEM_T_WALL, SPHDEM_T_RATES, SPHDEM_T_INTEGRATE,
       SPHDEM_T_TRANSFER, SPHDEM_T_REDUCE, SPHDEM_T_COUPLE, SPHDEM_NTIMERS };

/* Per-particle rate state carried by the engine between runs and through restarts,
 * SPHDEM_NSTATE doubles per particle: drho, ax, ay, az, ux, uy, uz (XSPH correction). */
#define SPHDEM_NSTATE 7

typedef struct sphdem_ctx_s *sphdem_ctx;

/* Fill p with the documented defaults (dim 3, gamma 7, Tait, no optional term). */
void sphdem_params_default(sphdem_params *p);
/* Check p; on error return SPHDEM_ERR_ARG and write a message naming the parameter to msg. */
int sphdem_params_check(const sphdem_params *p, char *msg, size_t msglen);

/* Create a context. dev AUTO picks the GPU when one is usable, else the CPU; the reason for a
 * fallback is kept in sphdem_backend_note(). On failure *out is NULL and msg (if given) says why. */
int sphdem_create(sphdem_ctx *out, const sphdem_params *p, sphdem_device dev, char *msg, size_t msglen);
int sphdem_destroy(sphdem_ctx *ctx);

const char *sphdem_strerror(int code);
const char *sphdem_last_error(sphdem_ctx ctx);
int sphdem_backend(sphdem_ctx ctx);          /* SPHDEM_DEVICE_CPU or SPHDEM_DEVICE_GPU */
const char *sphdem_backend_note(sphdem_ctx ctx); /* "" or one line: why AUTO fell back, GPU name */
int sphdem_gpu_available(void);              /* 1 if the CUDA backend is built and a device is usable */
/* Many ranks: this process uses GPU local_rank mod (GPUs on the node) for every context created afterwards
 * (several ranks may share one); msg gets "GPU k: name ..." or why there is none (SPHDEM_ERR_NO_GPU). */
int sphdem_gpu_select(int local_rank, char *msg, size_t msglen);

/* Change parameters that may vary between runs (box, gravity, coefficients); not dim or h. */
int sphdem_set_params(sphdem_ctx ctx, const sphdem_params *p);
/* The reductions over the engine's ranks (NULL: one rank); the core calls them inside collective calls only. */
int sphdem_set_comm(sphdem_ctx ctx, const sphdem_comm *comm);
int sphdem_get_params(sphdem_ctx ctx, sphdem_params *p);

/* Upload the fluid particles. tag[i] > 0 is a unique id (engine atom tag). Arrays are in the
 * caller's order; x, v are 3n interleaved; state is n*SPHDEM_NSTATE or NULL (rates zero).
 * If n and the set of tags equal the resident ones, data are replaced in place and the device
 * order is kept (so a download/upload round trip changes nothing); otherwise the fluid is rebuilt. */
int sphdem_set_fluid(sphdem_ctx ctx, int n, const int64_t *tag, const double *x, const double *v,
                     const double *rho, const double *mass, const double *state);
/* Many ranks: the last nghost fluid and nwghost wall particles of the last sphdem_set_fluid / sphdem_set_walls
 * are ghost copies (other ranks' particles within the communication cutoff, periodic images): they enter every
 * pair sum; the statistics, stability checks and kinetic energy count the owned particles only, reduced over
 * the ranks (sphdem_set_comm). Valid until the next sphdem_set_fluid / sphdem_set_walls; a negative count leaves
 * that set as it is. */
int sphdem_set_ghosts(sphdem_ctx ctx, int nghost, int nwghost);
/* Replace the ghost fluid particles' x, v, rho and state (drho, a: SPHDEM_NSTATE per particle, only the first
 * four used; NULL keeps them) in place, same set and caller order as the last sphdem_set_fluid (nghost values
 * each, for the caller indices n - nghost .. n - 1); the owned particles are left as they are. */
int sphdem_update_ghosts(sphdem_ctx ctx, int nghost, const double *x, const double *v, const double *rho,
                         const double *state);
/* Many ranks: the owners' values handed to their ghost copies in the middle of a rate evaluation, so that each
 * rank evaluates its owned particles only (the ghosts' own sums would miss neighbours beyond the band anyway).
 * The core calls fn at fixed points of every sphdem_compute_rates, on every rank in the same order (fn is
 * collective: the shim's forward communication), with the values of the nown owned particles of the set in the
 * caller's order (ncomp per particle) in own, and takes the nghost ghosts' values (same order as the ghosts of
 * the last upload) from ghost. what: SPHDEM_XCHG_RATES drho, a (4: after the rate pass; 7 with the XSPH /
 * shift velocity u inside sphdem_step_rk4, whose stages move the ghosts too); SPHDEM_XCHG_EPS the
 * coupling's porosity (1: after the porosity pass); SPHDEM_XCHG_GRAIN a grain's fluid force and Shepard sum
 * (4: grains in the order of their upload, after the grain pass); SPHDEM_XCHG_ACC a (3: after the reaction on
 * the fluid); SPHDEM_XCHG_WALL the wall state of the plain fluid's Adami walls: pressure, density, extrapolated
 * velocity (3) and, coupled with superficial density, porosity (5 or 6: wall particles in the order of the last
 * sphdem_set_walls, after the wall pass; not with ghost mirror walls or the delta-plus fluid, whose wall passes
 * run over the ghosts too). fn returns 0 on success. NULL (the default): every rank evaluates its ghosts too. */
typedef enum {
  SPHDEM_XCHG_RATES = 0, SPHDEM_XCHG_EPS = 1, SPHDEM_XCHG_GRAIN = 2, SPHDEM_XCHG_ACC = 3, SPHDEM_XCHG_WALL = 4
} sphdem_xchg;
typedef int (*sphdem_exchange_fn)(void *user, int what, int ncomp, int nown, int nghost, const double *own,
                                  double *ghost);
int sphdem_set_exchange(sphdem_ctx ctx, sphdem_exchange_fn fn, void *user);
/* Many ranks: the owned particles of a set (0: the fluid, in the order of sphdem_set_fluid; 1: the walls, in the
 * order of sphdem_set_walls) whose values the exchange function reads, n caller indices below the set's owned count
 * (those the engine sends to other ranks); n < 0: every owned one (the default, and again after each
 * sphdem_set_fluid for the fluid). The exchanges then move only these rows and the ghosts between the device and
 * the host, and own holds the values of these rows only. */
int sphdem_set_exchange_rows(sphdem_ctx ctx, int set, int n, const int *rows);
/* Many ranks: x, v, rho and the state's drho and a (its first four of SPHDEM_NSTATE columns) of the fluid rows of
 * sphdem_set_exchange_rows, written at their caller indices into arrays laid out as for sphdem_get_fluid (every
 * other entry is left as it is); any pointer may be NULL. The slice of the fluid that the engine's forward
 * communication sends each step. */
int sphdem_get_fluid_rows(sphdem_ctx ctx, double *x, double *v, double *rho, double *state);
/* The largest squared distance an owned fluid particle has moved since the last sphdem_set_fluid (a wrap through a
 * periodic boundary counts as the period, as the engine counts it), on this rank: the test for the engine's next
 * neighbour build without a download of every position. */
int sphdem_fluid_moved(sphdem_ctx ctx, double *d2max);
/* Upload wall (dummy) particles: positions, prescribed velocity, acceleration (NULL = 0), mass. */
int sphdem_set_walls(sphdem_ctx ctx, int n, const double *x, const double *v, const double *a,
                     const double *mass);
/* Fixed ghost walls (Shi & Huang 2022 §3.4, eqs 29-31): xi (3n) is the interpolation point of each wall
 * particle of the last sphdem_set_walls (same order): its mirror image across the wall surface, inside
 * the fluid. The wall particle then takes the moving-least-squares interpolation of the fluid at xi:
 * pressure P_I + rho_f g.(x_G - x_I) (eq 29, rho_f the reference density of the phase with the larger
 * share of M11, 1 phase: rho0), velocity 2 v_wall - u_I (no slip), and in the multiphase viscous term the
 * viscosity of that phase's rheology at the interpolated shear rate (§3.4). Where fewer than dim + 1
 * fluid particles are in reach the MLS matrix is singular and the Shepard interpolation is used. Must
 * follow every sphdem_set_walls (which switches the ghosts back to the Adami walls); xi NULL: Adami. */
int sphdem_set_wall_mirror(sphdem_ctx ctx, int n, const double *xi);
/* Download the fluid in the order of the last sphdem_set_fluid call. Any pointer may be NULL. */
int sphdem_get_fluid(sphdem_ctx ctx, double *x, double *v, double *rho, double *p, double *state);

/* Time stepping (velocity Verlet, kick-drift-kick; forces see the half-step velocity). */
int sphdem_kick(sphdem_ctx ctx, double dt_half);   /* v += dt/2 a; rho += dt/2 drho */
int sphdem_drift(sphdem_ctx ctx, double dt);       /* x += dt (v + XSPH); periodic wrap */
int sphdem_compute_rates(sphdem_ctx ctx);
/* One whole step of the classical fourth-order Runge-Kutta scheme (Shi & Huang 2022 §3.5) on x, v, rho:
 * four rate evaluations (each as sphdem_compute_rates, resorting when particles moved skin/2), walls
 * held at their state for the whole step. Not with the SPH-DEM coupling (SPHDEM_ERR_STATE). Do not mix
 * with sphdem_kick/drift inside a step; the rates left behind are those of the last stage. */
int sphdem_step_rk4(sphdem_ctx ctx, double dt);          /* resort if needed; wall state (eqs 13-15); drho, a, XSPH */
/* Statistics; returns SPHDEM_ERR_NAN / _LOST / _DENSITY (with a message naming the likely cause)
 * when the state is broken, SPHDEM_OK otherwise. s is filled in either case. dt is the time step
 * in use: when dt > s->dt_stable it returns SPHDEM_ERR_UNSTABLE. Pass dt = 0 to skip that check. */
int sphdem_stats_get(sphdem_ctx ctx, double dt, sphdem_stats *s);

/* Fluid fields at npts points (xyz interleaved), interpolated with the kernel and Shepard-normalised
 * (He 2018 eq 4: sum_b A_b m_b/rho_b W / sum_b m_b/rho_b W). out gets SPHDEM_NPROBE values per point:
 * pressure, density, vx, vy, vz and the Shepard sum (0 where no fluid particle is within 2h; the
 * other values are then 0). Reads the device state as it is (call at full steps). */
#define SPHDEM_NPROBE 6
int sphdem_probe(sphdem_ctx ctx, int npts, const double *pts, double *out);

/* Number of resorts so far; bytes of device memory held; bytes per fluid particle. */
int64_t sphdem_nsorts(sphdem_ctx ctx);
size_t sphdem_device_bytes(sphdem_ctx ctx);
void sphdem_timers(sphdem_ctx ctx, double t[SPHDEM_NTIMERS]);
void sphdem_timers_reset(sphdem_ctx ctx);

/* Closed forms shared with the engine shims and tests. */
double sphdem_tait_B(const sphdem_params *p);
/* Hydrostatically consistent initial density at depth (zsurf - z) (Tait inverted). */
double sphdem_hydrostatic_rho(const sphdem_params *p, double depth);
/* Stokes relaxation time rho_p d^2 / (18 mu) of a grain of density rho_p and diameter d in a fluid of
 * dynamic viscosity mu (the set-up checks of the explicit drag against the fluid or gas step). */
double sphdem_stokes_time(double rho_p, double d, double mu);

/* Testing hooks: neighbor pairs within 2h found by the cell search (i<j, indices in upload order),
 * written to pairs (2*maxpairs); returns the pair count or a negative error code. */
int64_t sphdem_debug_pairs(sphdem_ctx ctx, int64_t *pairs, int64_t maxpairs);

/* Set-up check (one cell search, not per step): fluid pairs and fluid-wall pairs closer than rmin.
 * out[0] fluid pairs, out[1] fluid-wall pairs; the closest of each: out[2], out[3] the two fluid tags,
 * out[4] their distance; out[5] the fluid tag, out[6] the wall's index in the last sphdem_set_walls
 * upload, out[7] their distance (-1 where there is none). */
int sphdem_check_spacing(sphdem_ctx ctx, double rmin, double out[8]);
/* Wall pressure and density of the last rate evaluation, in the order of the last sphdem_set_walls
 * (either may be NULL). */
int sphdem_get_wall_state(sphdem_ctx ctx, double *p, double *rho);

/* ---- Grain store (shared by the coupling, the DEM contacts and the gas grid) ----------------------
 * The grains of one engine step, handed once and read by every context that needs them: a host view (the
 * caller's arrays, borrowed until the next put) and a device copy on the store's backend (on the CPU backend
 * the host view itself). Own grains first, then ghost copies of other ranks' grains. The stamp says which
 * step and atom ordering the grains belong to; a reader that finds the stamp current reads what is there
 * (no copy). The readers (sphdem_set_grains_store, sphdem_dem_compute_store, sphdem_cfd_step_store) take
 * the first n grains of the store or a list of indices into it; a store is read by contexts of its backend. */
typedef struct sphdem_grains_s *sphdem_grain_store;
#define SPHDEM_GRAINS_STAMP 6 /* the stamp: 6 integers (the shims: step, run, setup flag, list builds, own, ghosts) */
int sphdem_grains_create(sphdem_grain_store *out, sphdem_device dev, char *msg, size_t msglen); /* dev CPU or GPU */
int sphdem_grains_destroy(sphdem_grain_store *g);
const char *sphdem_grains_last_error(sphdem_grain_store g);
/* The grains of a step: nown own grains then nghost ghosts; x, v, omega 3 per grain, radius and mass one;
 * omega and mass may be NULL (readers that need them refuse the store). The arrays stay the caller's and
 * must not change until the next put; the device copy is made here (one upload). */
int sphdem_grains_put(sphdem_grain_store g, const int64_t stamp[SPHDEM_GRAINS_STAMP], int nown, int nghost,
                      const double *x, const double *v, const double *omega, const double *radius,
                      const double *mass);
/* 1 if the last put had this stamp (the grains are current), 0 if not. */
int sphdem_grains_current(sphdem_grain_store g, const int64_t stamp[SPHDEM_GRAINS_STAMP]);
/* Grains of the last put: own and ghost counts (either pointer may be NULL). */
int sphdem_grains_count(sphdem_grain_store g, int *nown, int *nghost);
/* Host-to-device grain uploads so far: of this store, or (g NULL) of every store of the process, including
 * the private stores behind sphdem_set_grains, sphdem_dem_compute and sphdem_cfd_step. On the CPU backend an
 * upload is counted where the GPU backend would copy (the device view is the host view there). */
int64_t sphdem_grains_uploads(sphdem_grain_store g);

/* ---- SPH-DEM coupling (He 2018 §2.3, unresolved, two-way) -------------------------------------
 * The engine keeps the DEM (contacts, integration); each fluid step it uploads the grains, the
 * core computes the porosity at fluid particles (eq 26), uses it as superficial density in
 * continuity and the equation of state (eqs 6-7 with eps), the fluid force on each grain
 * (eqs 27-32 and the other drag laws) and the reaction on the fluid (eq 33), all inside
 * sphdem_compute_rates. Off (and free) until sphdem_couple_set enables it. */
typedef enum {
  SPHDEM_DRAG_NONE = 0,             /* pressure-gradient/viscous part only */
  SPHDEM_DRAG_ERGUN_WENYU = 1,      /* He 2018 eqs 30-32 (Ergun below eps 0.8, Wen-Yu above) */
  SPHDEM_DRAG_DIFELICE = 2,         /* Di Felice 1994 voidage function */
  SPHDEM_DRAG_SCHILLER_NAUMANN = 3  /* single sphere, C_D of eq 32, no voidage correction */
} sphdem_drag;

typedef struct {
  int enabled;          /* 0: coupling off (default) */
  double hc;            /* coupling smoothing length h_c of eqs 26 and 33 (support 2 hc); default: the fluid h */
  int drag;             /* sphdem_drag */
  double mu;            /* fluid dynamic viscosity in the drag laws (Pa s) */
  double eps_min;       /* floor of the porosity used in the fluid equations and drag (default 0.2) */
  int superficial;      /* 1 (default): eps enters continuity and the EOS (eqs 6-7); 0: porosity only reported */
  int torque;           /* 1: fluid torque on grains (rotational drag); 0 (default): none */
  double immersion;     /* S in (0, 1]: the fluid force on a grain (pressure gradient, drag, torque) is scaled by
                           min(1, sigma_f / (S (1 - sigma_w))), sigma_f = sum_b V_b W_jb over the fluid (the Shepard
                           sum of eq 28), sigma_w the same over wall particles (V_w = m_w/rho0): a grain in air or
                           touched by a few fluid particles feels a share of the force, not the whole (eq 28's
                           Shepard correction alone gives it the full force, and eq 33 puts the reaction on those
                           few particles). 0 (default): off, as the paper */
  int wall_porosity;    /* with superficial density: 1 = wall particles carry the Shepard average of the porosity of
                           the fluid beside them (superficial wall density eps_w rho_w); 0 (default) = walls are
                           plain fluid (eps_w = 1). See doc/fix_sph_couple.md for what each does. */
  double dmax;          /* largest grain diameter expected (sizes the DEM cells); 0 = from the grains */
  int eps_walls;        /* 1: eq 26 divided by the share of the coupling kernel inside the domain, 1 - sigma_w
                           (sigma_w = sum_w V_w W_aw over wall particles): grains lie only inside the walls, so
                           beside a wall eq 26 counts a truncated kernel and gives too high a porosity (0.80
                           instead of 0.75 for a uniform bed). 0 (default): eq 26 as the paper */
  int pressure_form;    /* pair terms of the fluid while coupled. 0 (default): eq 9 as printed, m_b (P_a/rho_a^2 +
                           P_b/rho_b^2) grad W, continuity sum_b m_b v_ab.grad W (eq 6); 1: volume form, force on a
                           from b -V_a V_b (P_a + P_b) grad W and continuity rho_a sum_b V_b v_ab.grad W (V = m/rho,
                           the same pair with each side's volume). With superficial density the masses carry the
                           porosity (m = eps m_0); the mass form then weights the pressure gradient with the
                           neighbours' porosity, and a packed bed at rest drives a flow at its edges (see
                           doc/fix_sph_couple.md, "Packed beds"); the volume form does not. Fluid and wall pairs. */
} sphdem_couple_params;

void sphdem_couple_params_default(sphdem_couple_params *c);
/* Enable, change or disable the coupling; checks c and names the bad field in the message. */
int sphdem_couple_set(sphdem_ctx ctx, const sphdem_couple_params *c);
int sphdem_couple_get(sphdem_ctx ctx, sphdem_couple_params *c);
/* Upload the grains: n grains, x and v 3n interleaved, radius n, omega 3n or NULL (needed only
 * for torque). Called before each sphdem_compute_rates that should see them; n may change. */
int sphdem_set_grains(sphdem_ctx ctx, int n, const double *x, const double *v, const double *radius,
                      const double *omega);
/* The same from a grain store of the context's backend: n grains, the first n of the store (idx NULL) or
 * store grains idx[0..n); with_omega takes their spin (the store must have it), else zero. */
int sphdem_set_grains_store(sphdem_ctx ctx, sphdem_grain_store g, int n, const int32_t *idx, int with_omega);
/* Fluid force on each grain from the last sphdem_compute_rates, in the order of the last
 * sphdem_set_grains: total f (eq 27), its drag part fdrag (eq 30) and pressure-gradient/viscous
 * part fpg (eqs 28-29), torque. 3n each; any pointer may be NULL. */
int sphdem_get_grain_forces(sphdem_ctx ctx, double *f, double *fdrag, double *fpg, double *torque);
/* Many ranks: the last nghost grains of the last sphdem_set_grains are ghost copies (their forces are computed
 * and not used; sphdem_couple_stats_get sums the owned grains and fluid over the ranks, collectively). */
int sphdem_couple_set_ghosts(sphdem_ctx ctx, int nghost);
/* Porosity eps at each fluid particle (eq 26, before the floor), in the order of sphdem_set_fluid. */
int sphdem_get_porosity(sphdem_ctx ctx, double *eps);
/* Porosity from an earlier run (a restart file), n values in the order of sphdem_set_fluid, each in (0, 1]:
 * what the density check, the reductions and the outputs read until the next sphdem_compute_rates computes
 * eq 26. A continued run whose stored rates are valid needs it: without it the intrinsic density of a fluid
 * in a packed bed (rho_bar / eps) is taken as rho_bar, and the setup check sees a density error of 1 - eps. */
int sphdem_couple_seed_porosity(sphdem_ctx ctx, int n, const double *eps);

typedef struct {
  double f_grains[3];   /* sum of the fluid forces on the grains */
  double f_fluid[3];    /* sum of the reaction forces on the fluid (m_a * S_a); ~ -f_grains */
  double eps_min;       /* smallest porosity at a fluid particle */
  int64_t ngrains;
} sphdem_couple_stats;
int sphdem_couple_stats_get(sphdem_ctx ctx, sphdem_couple_stats *s);

/* Testing hook: (fluid, grain) pairs within the coupling range found by the dual-grid search,
 * indices in upload order, written to pairs (2*maxpairs); returns the count or a negative code. */
int64_t sphdem_debug_couple_pairs(sphdem_ctx ctx, int64_t *pairs, int64_t maxpairs);

/* ---- Multiphase delta-plus SPH with Herschel-Bulkley phases (Shi & Huang 2022 §2-§3) -------------
 * Off (and free) until sphdem_mp_set enables it. When on, every fluid particle carries a phase index
 * (sphdem_set_fluid_phase; default 0) and the rates pass uses the multiphase forms of the paper instead
 * of the Morris/Tait single-phase ones:
 *   - per-phase reference density and equation of state: Tait (B_k = c0^2 rho0_k / gamma) or linear
 *     P = c0^2 (rho - rho0_k) + P0 (eq 4); the background pressure P0 is added to either;
 *   - continuity rho_i sum_j V_j (u_i + du_i - u_j - du_j).grad W (eq 15, first term), which does not
 *     mix the densities of the two sides of an interface;
 *   - pressure -1/m_i sum_j (P_i V_i^2 + P_j V_j^2) grad W (eq 20);
 *   - Hu-Adams viscous term with the harmonic mean of the particle viscosities (eq 24);
 *   - particle viscosity mu_i = Herschel-Bulkley mu_d(|D_i|) with the cut-off shear rate (eq 23) plus
 *     the Smagorinsky mu_t = rho_i (Cs 2h)^2 |D_i| (eq 25); D_i from the renormalised velocity gradient
 *     (eq 26, L_i of eq 19);
 *   - density diffusion delta_d h c0 D_i on delta rho = (P - P0)/c0^2 (continuous across interfaces):
 *     Molteni-Colagrossi psi = 2 (drho_j - drho_i), or the renormalised multiphase form
 *     psi = 2 (drho_j - drho_i) - (<grad drho>_i^L + <grad drho>_j^L).(r_j - r_i) (eqs 16-19);
 *   - particle shifting (delta-plus, eqs 27-29): shifting velocity from the same-phase kernel gradient
 *     sum with the limiter, set to 0 at interfaces and free surfaces (lambda_i < lam_surface), made
 *     tangential near them (lambda_i <= lam_near) when it points outwards; its terms in continuity
 *     (eq 15) and momentum (eq 3: div(u x du) - u div(du)), same-phase sums. The particle moves with
 *     v + du (+ XSPH). Wall (dummy) particles count as interior neighbours in lambda_i and the shift.
 * Walls are the Adami dummy particles of the single-phase fluid (eqs 13-15 of He 2018), with volume
 * m_w / rho0 (sphdem_params rho0) and, in eq 24, the viscosity of the fluid particle they face. */
#define SPHDEM_MAX_PHASES 4
typedef enum { SPHDEM_EOS_TAIT = 0, SPHDEM_EOS_LINEAR = 1 } sphdem_eos;
typedef enum { SPHDEM_DIFF_NONE = 0, SPHDEM_DIFF_MOLTENI = 1, SPHDEM_DIFF_RENORM = 2 } sphdem_diffusion;
typedef struct {
  double rho0;          /* reference density of the phase (> 0) */
  double tau_y;         /* Herschel-Bulkley yield stress (Pa, >= 0); 0: no yield */
  double K;             /* consistency (Pa s^N, > 0); Newtonian: the dynamic viscosity */
  double N;             /* flow index (> 0); 1: Newtonian (tau_y 0) or Bingham */
  double gdot_cut;      /* cut-off shear rate (1/s): below it mu = tau_y/gdot_cut + K gdot_cut^(N-1) (eq 23);
                           required (> 0) when tau_y > 0 or N < 1 */
  double c0;            /* sound speed of the phase (> 0), or 0: the fluid's c0. A light phase beside a heavy one
                           (air/water) needs its own: with one c0 stiff enough for the light phase the heavy
                           phase's pressure noise blows the light one apart */
} sphdem_phase;
typedef struct {
  int enabled;          /* 0: the fluid of sphdem_params alone (default); 1: the delta-plus fluid below */
  int single;           /* 1: one fluid, no phases: phase 0 is filled from sphdem_params (rho0; visc morris mu
                           as its Newtonian viscosity, visc none: inviscid), every particle is in it and the
                           EOS stays the fluid's (tait unless eos says otherwise): the delta-plus terms
                           (shifting, diffusion, les, p0) for a plain fluid. sphdem_mp_single_phase fills it */
  int nphase;           /* phases in use, 1..SPHDEM_MAX_PHASES */
  sphdem_phase phase[SPHDEM_MAX_PHASES];
  int eos;              /* sphdem_eos */
  double p0;            /* background pressure P0 (Pa, >= 0) */
  int diffusion;        /* sphdem_diffusion */
  double delta;         /* delta_d of the diffusion (paper 0.1) */
  int shifting;         /* 1: particle shifting with its continuity and momentum terms */
  double shift_R, shift_n;        /* eq 27: R (0.2) and n (4) */
  double lam_surface, lam_near;   /* §3.3 thresholds on lambda_i (0.55, 0.90) */
  double cs_les;        /* Smagorinsky constant (paper 0.12); 0: no LES viscosity */
  double alpha_visc;    /* viscous time-step factor alpha_d of eq 34 (0.125) */
} sphdem_mp_params;
void sphdem_mp_params_default(sphdem_mp_params *m);
/* Check m against the fluid parameters p (XSPH, tensile and Morris terms are single-phase options);
 * names the bad field in msg. */
int sphdem_mp_params_check(const sphdem_mp_params *m, const sphdem_params *p, char *msg, size_t msglen);
int sphdem_mp_set(sphdem_ctx ctx, const sphdem_mp_params *m);
/* One fluid without phases (m->single): sets nphase 1 and phase 0 from p (rho0, K = mu of visc morris or 0,
 * Newtonian, the fluid's c0). sphdem_mp_set calls it too; a caller that keeps its own copy calls it first. */
void sphdem_mp_single_phase(const sphdem_params *p, sphdem_mp_params *m);
/* Why the delta-plus terms of one fluid are refused with the SPH-DEM coupling. */
#define SPHDEM_MP_COUPLE_WHY                                                                                  \
  "the delta-plus terms (shifting, diffusion, les, eos, p0) are not defined for the coupled fluid: its "     \
  "equations (He 2018) carry the superficial density eps rho, and neither the shifting of Shi & Huang 2022 "  \
  "nor its diffusion of (P - P0)/c0^2 has been derived for a porous fluid; with grains use delta D "          \
  "(density diffusion of eps rho_f) and xsph EPS"

int sphdem_mp_get(sphdem_ctx ctx, sphdem_mp_params *m);
/* Phase index (0..nphase-1) of each fluid particle, in the order of the last sphdem_set_fluid. */
int sphdem_set_fluid_phase(sphdem_ctx ctx, int n, const int *phase);
/* Per-particle diagnostics of the last compute_rates, in the order of sphdem_set_fluid: viscosity mu_i
 * (Pa s), shear rate |D_i| (1/s), lambda_i (min eigenvalue of the same-phase B_i; 0 without shifting),
 * shifting velocity (3n). Any pointer may be NULL. */
int sphdem_mp_get_fields(sphdem_ctx ctx, double *mu, double *gdot, double *lambda, double *shift);
/* Equation of state of phase k (as the core evaluates it: P = c_k^2 (rho - rho0_k) + P0, or Tait with
 * B_k = c_k^2 rho0_k / gamma, c_k the phase's c0 or the fluid's) and its inverse; for initial states. */
double sphdem_mp_pressure(const sphdem_mp_params *m, const sphdem_params *p, int k, double rho);
double sphdem_mp_density(const sphdem_mp_params *m, const sphdem_params *p, int k, double pressure);
/* Herschel-Bulkley viscosity of phase k at shear rate gdot with the cut-off (eq 23). */
double sphdem_mp_viscosity(const sphdem_phase *ph, double gdot);

/* ---- GPU DEM (Yu 2024 §2.2-2.3, He 2018 §2.2) ----------------------------------------------------
 * Soft-sphere contacts between grains and with fixed planes, on the CPU (OpenMP) or CUDA. A separate
 * context: the caller (engine pair style or test driver) integrates; each call uploads the grains,
 * the core finds contacts on a cell grid of size d_max + skin, carries the per-pair history (keyed by
 * the two tags, so it survives any reordering) and returns force and torque on every grain. */
typedef enum {
  SPHDEM_DEM_HOOKE = 0,         /* linear spring-dashpot (Yu 2024 eqs 7-13; LAMMPS gran/hooke/history) */
  SPHDEM_DEM_HERTZ = 1,         /* LAMMPS gran/hertz/history: the Hooke law times sqrt(delta R*) */
  SPHDEM_DEM_HERTZ_MINDLIN = 2, /* Hertz normal + Mindlin-Deresiewicz tangential (He 2018 eqs 18-23) */
  SPHDEM_DEM_HERTZ_LIGGGHTS = 3, /* LIGGGHTS model hertz tangential history [rolling_friction cdt]: stiffness
                                   and damping from E, nu, en (Y*, G*, beta of its material model) */
  SPHDEM_DEM_HOOKE_LIGGGHTS = 4, /* LIGGGHTS model hooke tangential history: linear spring-dashpot whose
                                   k_n = 16/15 sqrt(R*) Y* (15 m* V^2 / (16 sqrt(R*) Y*))^(1/5) comes from E, nu and
                                   the characteristic velocity V (charvel), k_t = k_n (2/7 k_n with kt_to_kn),
                                   gamma_n = gamma_t = sqrt(4 m* k_n / (1 + (pi / ln e)^2)) */
  SPHDEM_DEM_HOOKE_HYSTERESIS_LIGGGHTS = 5, /* LIGGGHTS model hooke/hysteresis (Walton-Braun): loading on the
                                   k_n of HOOKE_LIGGGHTS (k_t = k_n), unloading and reloading on k_2 between k_n
                                   and kn2kcmax k_n (growing with the largest overlap, kept per pair), adhesion
                                   down to -kn2kc k_n delta; plasticity depth phif */
  SPHDEM_DEM_GRANULAR = 6       /* LAMMPS pair_style granular: normal, damping, tangential, rolling and twisting
                                   sub-models chosen per pair of grain types (sphdem_dem_set_granular) */
} sphdem_dem_model;

/* SPHDEM_DEM_GRANULAR sub-models (LAMMPS pair_style granular, 29 Sep 2021), one of each per type pair. */
typedef enum { SPHDEM_GRAN_HOOKE = 0, SPHDEM_GRAN_HERTZ = 1, SPHDEM_GRAN_HERTZ_MATERIAL = 2, SPHDEM_GRAN_DMT = 3 }
    sphdem_gran_normal;
typedef enum { SPHDEM_GRAN_DAMP_VELOCITY = 0, SPHDEM_GRAN_DAMP_MASS_VELOCITY = 1, SPHDEM_GRAN_DAMP_VISCOELASTIC = 2,
               SPHDEM_GRAN_DAMP_TSUJI = 3 } sphdem_gran_damping;
typedef enum { SPHDEM_GRAN_TANG_LINEAR_NOHISTORY = 0, SPHDEM_GRAN_TANG_LINEAR_HISTORY = 1, SPHDEM_GRAN_TANG_MINDLIN = 2 }
    sphdem_gran_tangential;
typedef enum { SPHDEM_GRAN_ROLL_NONE = 0, SPHDEM_GRAN_ROLL_SDS = 1 } sphdem_gran_rolling;
typedef enum { SPHDEM_GRAN_TWIST_NONE = 0, SPHDEM_GRAN_TWIST_MARSHALL = 1, SPHDEM_GRAN_TWIST_SDS = 2 } sphdem_gran_twisting;

/* The coefficients of one type pair, as LAMMPS keeps them after pair_coeff and its mixing (init_one). */
typedef struct {
  int normal, damping, tangential, rolling, twisting; /* sphdem_gran_* */
  int limit_damping;    /* 1: the normal force (elastic + damping) is never attractive */
  double kn;            /* hooke: k_n (force/distance); hertz: k_n (pressure); hertz/material, dmt: 4/3 E_eff */
  double damp;          /* normal damping coefficient eta_n0 (tsuji: alpha(e) already) */
  double cohesion;      /* dmt: surface energy w (pull-off 4 pi w R*) */
  double kt;            /* linear_history: k_t; mindlin: k_t per a = sqrt(R* delta) (8 G_eff for NULL) */
  double damp_t;        /* tangential damping as a multiple of the normal damping prefactor */
  double mu;            /* sliding friction */
  double kr, damp_r, mu_r;    /* rolling sds: k_roll, gamma_roll, mu_roll */
  double ktw, damp_tw, mu_tw; /* twisting sds: k_twist, gamma_twist, mu_twist (marshall: from the tangential) */
} sphdem_dem_granular;

/* Cohesion of the LIGGGHTS models, between overlapping grains: F = -k A along the normal (attractive),
 * k the cohesion energy density. */
typedef enum {
  SPHDEM_DEM_COH_NONE = 0,
  SPHDEM_DEM_COH_SJKR = 1,  /* A = -pi/4 (r-ri-rj)(r+ri-rj)(r-ri+rj)(r+ri+rj)/r^2 (wall: pi (ri^2 - r^2)) */
  SPHDEM_DEM_COH_SJKR2 = 2  /* A = 2 pi R* delta, R* = 2 ri rj/(ri + rj) (wall: 2 pi ri delta) */
} sphdem_dem_cohesion;

/* Rolling friction of the LIGGGHTS models (mu_r > 0). */
typedef enum {
  SPHDEM_DEM_ROLL_CDT = 0,   /* constant directional torque mu_r k_n delta R* against the relative rotation */
  SPHDEM_DEM_ROLL_EPSD2 = 1, /* LIGGGHTS epsd2: elastic-plastic spring torque, k_r = k_t R*^2 on the
                                tangential relative rotation, capped at mu_r R* |F_n|, kept per pair */
  SPHDEM_DEM_ROLL_EPSD = 2   /* LIGGGHTS epsd (3D): the same with k_r = 2.25 k_n mu_r^2 R*^2 and, below the
                                cap, the dashpot eta_r 2 sqrt(I_r k_r) (eta_r = rvd, I_r = 1.4 m_i r_i^2 m_j r_j^2 /
                                (m_i r_i^2 + m_j r_j^2)) on the tangential relative rotation */
} sphdem_dem_rolling;

typedef enum {
  SPHDEM_DEM_PAIR_PARALLEL = 0,     /* Yu 2024 §2.3: one thread per collision pair, atomic sums */
  SPHDEM_DEM_PARTICLE_PARALLEL = 1  /* one thread per grain over its pairs, no atomics, deterministic */
} sphdem_dem_algo;

typedef struct {
  int model;            /* sphdem_dem_model */
  int algo;             /* sphdem_dem_algo */
  double kn, kt;        /* HOOKE / HERTZ: normal and tangential stiffness (N/m; HERTZ N/m^1.5) */
  double gamman, gammat;/* HOOKE / HERTZ: damping per unit effective mass (1/s), used when en == 0 */
  double en;            /* restitution coefficient in (0,1]: HOOKE damping from Yu eq 11 (per pair,
                           eta = 2 sqrt(k m_eff) |ln e| / sqrt(pi^2 + ln^2 e), tangential alike with kt);
                           HERTZ_MINDLIN: c_n of He eq 23. 0: use gamman, gammat (HOOKE/HERTZ) */
  double ct;            /* HERTZ_MINDLIN tangential damping coefficient c_t (eq 21); < 0: equal to c_n */
  double E, nu;         /* HERTZ_MINDLIN, HERTZ_LIGGGHTS: Young's modulus (Pa), Poisson ratio (one material) */
  double mu;            /* sliding friction coefficient (Coulomb limit) */
  double mu_r;          /* constant-torque rolling friction (He eq 25); 0 = off */
  int limit_damping;    /* 1: the normal force is never attractive (LAMMPS limit_damping) */
  int first_contact;    /* HOOKE / HERTZ: 1 starts the tangential displacement of a new contact at
                           v_t min(delta / |v_n|, dt) (Yu eq 12), 0 (default, as LAMMPS) at v_t dt */
  double skin;          /* search gap: cells of d_max + skin; pairs rebuilt when a grain moved skin/2 */
  double boxlo[3], boxhi[3];
  int periodic[3];      /* minimum image on these axes (a pair interacts through its nearest image only) */
  double charvel;       /* HOOKE_LIGGGHTS: characteristic velocity V (m/s) of the stiffness */
  int kt_to_kn;         /* HOOKE_LIGGGHTS: 1 gives k_t = 2/7 k_n (LIGGGHTS ktToKnUser on), 0 k_t = k_n */
  int rolling_model;    /* HERTZ_LIGGGHTS, HOOKE_LIGGGHTS with mu_r > 0: sphdem_dem_rolling */
  int cohesion;         /* HERTZ_LIGGGHTS, HOOKE_LIGGGHTS: sphdem_dem_cohesion */
  double ced;           /* cohesion energy density k (J/m^3) of the params' one material */
  double rvd;           /* ROLL_EPSD: rolling viscous damping coefficient of the params' one material */
  double kn2kcmax, kn2kc, phif; /* HOOKE_HYSTERESIS_LIGGGHTS, one material: k_2,max / k_n (> 1), k_c / k_n
                           (>= 0), plasticity depth (>= 0) (coefficientMaxElasticStiffness,
                           coefficientAdhesionStiffness, coefficientPlasticityDepth) */
  int no_tangential_damping; /* HERTZ_LIGGGHTS, HOOKE_LIGGGHTS: 1 sets gamma_t = 0 (LIGGGHTS
                           tangential_damping off); 0 (default) damps the tangential force */
  int keep_history;     /* 0 (LAMMPS): a pair that stops touching has its tangential history zeroed at
                           once; 1 (LIGGGHTS, contactDistanceFactor 1): it keeps it until the next build
                           asked for by sphdem_dem_request_build, which carries the history only of the
                           pairs that touch at that moment (the core's own rebuilds carry all of it) */
} sphdem_dem_params;

/* A fixed plane: grains interact with it on the side its unit normal n points to. */
typedef struct { double point[3]; double normal[3]; } sphdem_dem_wall;

typedef struct sphdem_dem_s *sphdem_dem;

/* Per-grain flag bits (sphdem_dem_compute flags array). */
#define SPHDEM_DEM_FROZEN 1     /* effective mass of its contacts is the partner's (LAMMPS fix freeze) */
/* Many MPI ranks (the engine's ghost atoms given after the rank's own grains): GHOST a copy of a grain that
 * another rank owns, IMAGE a periodic image of a grain given here too. They take part only in pairs with a
 * grain of this rank (no wall contacts); a pair with an IMAGE is kept once (as the image of the grain of
 * higher tag); the force and torque computed on them are the caller's to drop (GHOST) or to add to the
 * grain they are an image of (IMAGE). A pair with a GHOST counts half in the virial, and the stats count a
 * pair on the rank that owns its grain of lower tag, so both sum over the ranks. */
#define SPHDEM_DEM_GHOST 2
#define SPHDEM_DEM_IMAGE 4
/* Many MPI ranks: a copy that takes no part in any pair (not binned, no force), e.g. a periodic image along an
 * axis the ranks do not cut, whose pairs the core finds itself by the minimum image (params periodic[d] = 1). */
#define SPHDEM_DEM_SKIP 8
/* flags >> SPHDEM_DEM_MATERIAL_SHIFT: the grain's material (0-based) in the table of
 * sphdem_dem_set_materials; 0 without a table */
#define SPHDEM_DEM_MATERIAL_SHIFT 8
#define SPHDEM_DEM_MAX_MATERIALS 4096

/* flags bits 4..7: the grain's exclusion class (sphdem_dem_set_exclusions), (flags & SPHDEM_DEM_CLASS_MASK) >>
 * SPHDEM_DEM_CLASS_SHIFT; 0 without exclusions */
#define SPHDEM_DEM_CLASS_SHIFT 4
#define SPHDEM_DEM_CLASS_MASK 0xf0
#define SPHDEM_DEM_MAX_CLASSES 16

void sphdem_dem_params_default(sphdem_dem_params *p);
/* Check p; on error SPHDEM_ERR_ARG and a message naming the field. */
int sphdem_dem_params_check(const sphdem_dem_params *p, char *msg, size_t msglen);
int sphdem_dem_create(sphdem_dem *out, const sphdem_dem_params *p, sphdem_device dev, char *msg, size_t msglen);
int sphdem_dem_destroy(sphdem_dem *dem);
const char *sphdem_dem_last_error(sphdem_dem dem);
int sphdem_dem_backend(sphdem_dem dem);            /* SPHDEM_DEVICE_CPU or SPHDEM_DEVICE_GPU */
/* Change parameters between calls (history is kept). */
int sphdem_dem_set_params(sphdem_dem dem, const sphdem_dem_params *p);
int sphdem_dem_set_comm(sphdem_dem dem, const sphdem_comm *comm); /* NULL: one rank */
/* Several materials (the LIGGGHTS models): n materials (LIGGGHTS atom types) with Young's
 * modulus E and Poisson ratio nu (n each) and, per pair of materials (n x n, row-major [i n + j],
 * symmetric), the restitution coefficient en, the friction mu, the rolling friction mu_r and the cohesion
 * energy density ced (NULL: 0).
 * Each pair's Y*, G*, beta, ln e are derived as LIGGGHTS' property registry does; a grain's material is
 * flags >> SPHDEM_DEM_MATERIAL_SHIFT. The params' E, nu, en, mu, mu_r are then unused by the contact law
 * (mu_r > 0 still switches rolling friction on). mat NULL or n 0: one material, from the params. */
typedef struct {
  int n;
  const double *E, *nu;
  const double *en, *mu, *mu_r;
  const double *ced;    /* n x n cohesion energy density (NULL: 0) */
  const double *rvd;    /* n x n rolling viscous damping of ROLL_EPSD (NULL: 0) */
  const double *kn2kcmax, *kn2kc, *phif; /* n x n, HOOKE_HYSTERESIS_LIGGGHTS (needed there) */
} sphdem_dem_materials;
int sphdem_dem_set_materials(sphdem_dem dem, const sphdem_dem_materials *mat);
/* SPHDEM_DEM_GRANULAR: the coefficients of every pair of n grain types (n x n, row-major [i n + j], symmetric);
 * a grain's type (0-based) is flags >> SPHDEM_DEM_MATERIAL_SHIFT. The params' kn, kt, mu, ... are unused. */
int sphdem_dem_set_granular(sphdem_dem dem, int n, const sphdem_dem_granular *pairs);
/* SPHDEM_DEM_GRANULAR: negate the rolling and twisting history of the listed pairs (keys (tag_a << 32) | tag_b,
 * tag_a < tag_b) in the history the next list build carries over: the current list, or the history given by
 * sphdem_dem_set_history(_rolling) since the last build; pairs not in it are skipped. LAMMPS' fix neigh/history stores the history with
 * the pair's first atom in the engine's neighbour list and negates every value when the other atom becomes
 * first at a list build; the tangential history is antisymmetric in the two atoms and the core keeps it in
 * the frame of the lower tag, but the rolling and twisting ones are symmetric, so the stock style flips them:
 * the shim lists the pairs whose order in the engine's list changed. */
int sphdem_dem_flip_history(sphdem_dem dem, int64_t n, const uint64_t *keys);
/* Pairs of grains that are never kept (an engine's neigh_modify exclude type / group): n exclusion classes
 * (0..SPHDEM_DEM_MAX_CLASSES; 0: none, the default), each grain's class in its flags (SPHDEM_DEM_CLASS_MASK); bit c2
 * of rows[c1] set: no pair of a grain of class c1 and one of class c2 is kept (symmetric: bit c1 of rows[c2] must
 * be set too). Walls are not affected. The next call rebuilds the pair list when the table changed. */
int sphdem_dem_set_exclusions(sphdem_dem dem, int n, const uint16_t *rows);
/* Fixed planes (replaces the previous set); nw may be 0. */
int sphdem_dem_set_walls(sphdem_dem dem, int nw, const sphdem_dem_wall *walls);
/* The next sphdem_dem_compute rebuilds the pair list (call when the engine rebuilt its neighbour lists:
 * pairs leave the list, and with keep_history separated pairs lose their history, on the engine's steps). */
int sphdem_dem_request_build(sphdem_dem dem);
/* on != 0: the next sphdem_dem_compute calls add the contact forces and torques to what f and torque hold
 * (an engine's force arrays after its force clear) instead of overwriting them; 0 (the default): overwrite. */
int sphdem_dem_set_accumulate(sphdem_dem dem, int on);
/* The next sphdem_dem_compute(_store) is given the tags of the last call again (the same grains in the same order,
 * e.g. an engine's atoms between its list builds): it does not compare them with the last call's. Applies to that
 * call only. */
int sphdem_dem_same_tags(sphdem_dem dem);
/* Grains of other ranks (SPHDEM_DEM_GHOST): on = 0 (the default), a pair of this rank's grain and another rank's is
 * kept and evaluated on both ranks, each taking the force on its own grain (the other grain's share is written to
 * its row and is for the caller to drop); on != 0, it is kept only on the rank of its grain of lower tag, whose
 * call adds the other grain's share to that grain's row for the engine to send to its rank (newton on). */
int sphdem_dem_set_ghost_once(sphdem_dem dem, int on);
/* Contact forces for n grains given in the caller's order. tag[i] in [1, 2^31) unique; x, v, omega 3n;
 * radius, mass n; flags n or NULL. dt: the time step that advances the tangential history (eq 13);
 * update_history 0 evaluates forces without changing the history (engine setup). f and torque (3n)
 * are overwritten; virial (6: xx yy zz xy xz yz, sum over grain pairs of r_ab F_ab) if not NULL. */
int sphdem_dem_compute(sphdem_dem dem, int n, const int64_t *tag, const double *x, const double *v,
                       const double *omega, const double *radius, const double *mass, const int *flags,
                       double dt, int update_history, double *f, double *torque, double *virial);
/* The same for every grain of a store of the context's backend (own then ghosts, which need the flags);
 * the store must have omega and mass. */
int sphdem_dem_compute_store(sphdem_dem dem, sphdem_grain_store g, const int64_t *tag, const int *flags, double dt,
                             int update_history, double *f, double *torque, double *virial);
/* Counters: candidate pairs (within r_a + r_b + skin, walls included), touching contacts at the
 * last call, pair-list builds so far. */
typedef struct { int64_t npairs, ncontacts, nbuilds; } sphdem_dem_stats;
int sphdem_dem_stats_get(sphdem_dem dem, sphdem_dem_stats *s);
/* Testing hooks: candidate pairs of the last build as caller indices (a, b), b = -1 - w for wall w,
 * a the grain of lower tag; returns the count or a negative code. History of the pair (tag_a, tag_b)
 * (tag_b = -1 - w for a wall): 4 doubles (tangential displacement xyz, touch flag: > 0 touching, 0 no
 * history; keep_history: < 0 not touching with the history kept, |flag| >= 2 codes the periodic image);
 * 0 if found. */
int64_t sphdem_dem_debug_pairs(sphdem_dem dem, int64_t *pairs, int64_t maxpairs);
int sphdem_dem_debug_history(sphdem_dem dem, int64_t tag_a, int64_t tag_b, double hist[4]);
/* The contacts of the current pair list for output (LIGGGHTS' compute pair/gran/local): every touching pair of two
 * grains evaluated again with the grains of g (the grains of the last sphdem_dem_compute(_store), in the same
 * order; their velocities and spins may have changed since), the history read as that evaluation left it and not
 * changed (no force is added anywhere, nothing of the context changes). Per touching pair k, in key order, at
 * most max of them: the grain indices a, b (ab[2k], ab[2k + 1]); in ft[SPHDEM_DEM_CONTACT_DOUBLES k..] the force on
 * a, the torques on a and on b, and x_a - x_b as the law took it (the minimum image along the axes the context
 * treats as periodic); the history (SPHDEM_DEM_HIST_DOUBLES per pair in hist, may be NULL) and the rolling torques
 * (3 per pair in roll, 0 where none are kept; may be NULL). Returns the number of touching pairs (which may
 * exceed max: call again with room for them), or a negative code. */
#define SPHDEM_DEM_CONTACT_DOUBLES 12 /* per contact of sphdem_dem_contacts: F_a, T_a, T_b, x_a - x_b */
int64_t sphdem_dem_contacts(sphdem_dem dem, sphdem_grain_store g, int64_t max, int32_t *ab, double *ft, double *hist,
                            double *roll);
/* The contacts of one step exactly as that step evaluated them (a per-atom virial for laws whose evaluation with the
 * kept history does not give the step's force again, e.g. LIGGGHTS' tangential damping of a sliding contact):
 * sphdem_dem_keep_step_history before a sphdem_dem_compute(_store) has that evaluation keep a copy of the history it
 * starts from (after its list build); sphdem_dem_step_contacts after it, with the same grains, evaluates every
 * touching pair again from that copy, the history advanced into scratch as the step did (nothing of the context
 * changes), and gives ab and ft as sphdem_dem_contacts does. Refused when the last evaluation kept no copy. */
int sphdem_dem_keep_step_history(sphdem_dem dem);
int64_t sphdem_dem_step_contacts(sphdem_dem dem, sphdem_grain_store g, int64_t max, int32_t *ab, double *ft);
/* Heat conduction through the contacts (LIGGGHTS fix heat/gran/conduction): for every touching pair of two grains
 * of the current pair list, with the grains of g (those of the last sphdem_dem_compute(_store), in the same order),
 * the heat flow Q = h (T_b - T_a) into a and out of b, h = 4 k_a k_b / (k_a + k_b) sqrt(A) (0 where a conductivity
 * is 0), A the contact area: SPHDEM_DEM_HEAT_AREA_OVERLAP the circle where the two spheres intersect (the smaller
 * grain's cross-section where it lies within the other), PROJECTION
 * pi max(r_a, r_b)^2, CONSTANT area_value. temp and cond: per grain (own then ghosts, as g); member (per grain,
 * may be NULL: all): a pair of two grains with member 0 is left out (LIGGGHTS' fix group); heat (n) is
 * overwritten with each grain's sum of Q; dheat (3n, may be NULL) with the sum of Q (x_a - x_b) / 2 over its
 * contacts (x_a - x_b the minimum image along the axes the context treats as periodic). Walls take no part. A pair
 * with another rank's grain adds to that grain's row too (the caller drops it or sends it on, as the forces). */
#define SPHDEM_DEM_HEAT_AREA_OVERLAP 0
#define SPHDEM_DEM_HEAT_AREA_PROJECTION 1
#define SPHDEM_DEM_HEAT_AREA_CONSTANT 2
int sphdem_dem_heat(sphdem_dem dem, sphdem_grain_store g, const double *temp, const double *cond, const int *member,
                    int area, double area_value, double *heat, double *dheat);
/* h of one contact of sphdem_dem_heat (the flow into a is h (T_b - T_a)): rsq = |x_a - x_b|^2 of two touching grains
 * of radii ra, rb and conductivities ka, kb; area and area_value as there. For output per contact (LIGGGHTS'
 * compute pair/gran/local heatFlux). */
double sphdem_dem_heat_conductance(double rsq, double ra, double rb, double ka, double kb, int area, double area_value);
/* Contact history for restart files: the current pair list's keys ((tag_a << 32) | tag_b, walls
 * 0xffffffff - w) and SPHDEM_DEM_HIST_DOUBLES doubles per pair. get: returns the pair count; writes
 * at most max pairs (keys/hist may be NULL with max 0 to ask the count). set: the given list (any
 * order) becomes the history that the next pair-list build carries over, as if it were the list of
 * the previous build; call before the first sphdem_dem_compute after a restart. */
#define SPHDEM_DEM_HIST_DOUBLES 5 /* the 4 of sphdem_dem_debug_history, then the largest overlap of
                                     HOOKE_HYSTERESIS_LIGGGHTS (0 for the other models) */
int64_t sphdem_dem_get_history(sphdem_dem dem, uint64_t *keys, double *hist, int64_t max);
int sphdem_dem_set_history(sphdem_dem dem, int64_t n, const uint64_t *keys, const double *hist);
/* The rolling torques of rolling_model epsd/epsd2 (3 doubles per pair, in the order of sphdem_dem_get_history;
 * returns the pair count, 0 when none are kept) and a history given with them (roll NULL: as
 * sphdem_dem_set_history, the rolling torques start from zero), as the hand-over between MPI ranks needs them. */
int64_t sphdem_dem_get_rolling(sphdem_dem dem, double *roll, int64_t max);
int sphdem_dem_set_history_rolling(sphdem_dem dem, int64_t n, const uint64_t *keys, const double *hist,
                                   const double *roll);
/* The history of the pairs of the current list with a grain among the ntags tags (sorted ascending; a wall
 * pair by its grain): keys, SPHDEM_DEM_HIST_DOUBLES per pair in hist and, where roll is not NULL, 3 rolling
 * torques per pair (0 where none are kept), in key order. Writes at most max pairs (keys, hist, roll may be
 * NULL with max 0); returns the count of such pairs, or a negative code. What a rank hands over when atoms leave
 * it, without reading the whole history. */
int64_t sphdem_dem_get_history_of(sphdem_dem dem, int64_t ntags, const int64_t *tags, uint64_t *keys, double *hist,
                                  double *roll, int64_t max);
/* Pairs (keys unique, any order) added to the history that the next pair-list build carries over: a pair that
 * history holds already keeps its own values. roll: 3 rolling torques per pair, or NULL (they start from zero).
 * Several calls before a build add up (a key given twice keeps its first values). The hand-over of the history
 * of atoms that joined a rank, without writing the whole history again. */
int sphdem_dem_add_history(sphdem_dem dem, int64_t n, const uint64_t *keys, const double *hist, const double *roll);
/* Time split of the sphdem_dem_compute calls since creation or the last reset, in seconds of the
 * host clock: upload of the grains, the rebuild check (displacements against skin/2), contact
 * detection (cell grid, candidate pairs, history carry: only on calls that rebuild the pair list),
 * contact forces, download of force and torque. On the GPU the kernels are asynchronous; a phase's
 * time ends when the host waits for its result (the pair count, the contact count, the download).
 * Returns the number of calls timed. */
enum { SPHDEM_DEM_T_UPLOAD = 0, SPHDEM_DEM_T_CHECK, SPHDEM_DEM_T_DETECT, SPHDEM_DEM_T_FORCE,
       SPHDEM_DEM_T_DOWNLOAD, SPHDEM_DEM_NTIMERS };
int64_t sphdem_dem_timers(sphdem_dem dem, double t[SPHDEM_DEM_NTIMERS]);
void sphdem_dem_timers_reset(sphdem_dem dem);

/* ---- Coarse-grid gas phase for CFD-DEM (Yu 2024 §2.1-2.4) ----------------------------------------
 * A structured staggered (MAC) grid over a box: voidage and pressure at cell centres, gas velocity
 * normal to each cell face. Volume-averaged incompressible gas (eqs 1-2, constant density, model A:
 * -eps grad p in the gas, -V_p grad p on a grain), first-order upwind convection, explicit viscous
 * term, drag implicit in the gas velocity, projection with a line-preconditioned conjugate-gradient
 * pressure solve, so div(eps u) + d eps/dt = 0 holds in every cell to the solver tolerance.
 * Interphase force: Gidaspow (eqs 14-17; Ergun below eps 0.8, Wen-Yu above) or Wen-Yu alone. The
 * gas drag on face f is sum_i w_if K_i (u_f - v_i) with the same weights w_if that interpolate the
 * gas velocity to grain i, so the drag on the grains and on the gas (plus the share taken by boundary
 * faces, whose velocity is prescribed) sum to zero to round-off (Newton's third law). */
typedef enum {
  SPHDEM_CFD_NOSLIP = 0,   /* wall, u = 0 */
  SPHDEM_CFD_SLIP = 1,     /* wall, normal u = 0, tangential stress 0 */
  SPHDEM_CFD_INLET = 2,    /* superficial velocity eps u_n = inlet_u (into the domain), tangential u = 0 */
  SPHDEM_CFD_OUTLET = 3    /* pressure outlet p = 0, zero-gradient velocity */
} sphdem_cfd_bc;
typedef enum { SPHDEM_CFD_VOID_CENTROID = 0, SPHDEM_CFD_VOID_SMOOTH = 1 } sphdem_cfd_voidage;
typedef enum { SPHDEM_CFD_DRAG_GIDASPOW = 0, SPHDEM_CFD_DRAG_WENYU = 1, SPHDEM_CFD_DRAG_NONE = 2 } sphdem_cfd_drag;
typedef enum {
  SPHDEM_CFD_SOLVER_MG = 0,    /* CG preconditioned by an aggregation multigrid V-cycle (default) */
  SPHDEM_CFD_SOLVER_LINE = 1   /* CG preconditioned by tridiagonal solves along the longest axis */
} sphdem_cfd_solver;

#define SPHDEM_CFD_MAX_PATCH 4
typedef struct {
  int side;             /* 0 xlo, 1 xhi, 2 ylo, 3 yhi, 4 zlo, 5 zhi; must be an inlet side */
  double lo[2], hi[2];  /* rectangle in the two other coordinates (in x,y,z order), box units */
  double u;             /* superficial inflow velocity through the patch (faces whose centre is inside) */
} sphdem_cfd_patch;

typedef struct {
  int nc[3];            /* cells per axis (>= 1) */
  double boxlo[3], boxhi[3];
  double rho_g, mu_g;   /* gas density (kg/m^3) and dynamic viscosity (Pa s) */
  double gravity[3];    /* body acceleration on the gas (rho_g eps g) */
  int bc[6];            /* per side (xlo xhi ylo yhi zlo zhi): sphdem_cfd_bc; at least one OUTLET */
  double inlet_u[6];    /* superficial inflow velocity on INLET sides (m/s, > 0 flows into the box) */
  int npatch;           /* patches (spouts) on inlet sides with their own velocity */
  sphdem_cfd_patch patch[SPHDEM_CFD_MAX_PATCH];
  int voidage;          /* sphdem_cfd_voidage: centroid (eq 3) or smooth (trilinear spread to 8 cells) */
  int drag;             /* sphdem_cfd_drag */
  double eps_min;       /* floor of the voidage in the gas equations and the drag law (default 0.2) */
  int ddt_eps;          /* 1 (default): continuity keeps d eps / dt (eq 1); 0: div(eps u) = 0 */
  int pressure_force;   /* 1 (default): f = -V_p grad p on grains (buoyancy included); 0: drag only */
  int solver;           /* sphdem_cfd_solver: preconditioner of the pressure solve */
  double tol;           /* pressure solve: relative residual |r| / |b| (default 1e-10) */
  int maxiter;          /* pressure solve iteration limit (default 2000); reaching it is an error */
  double cfl_max;       /* stop when dt max |u_d| / h_d exceeds it (eq 18; default 1) */
} sphdem_cfd_params;

typedef struct sphdem_cfd_s *sphdem_cfd;

typedef struct {
  int64_t nsteps;       /* gas steps so far */
  int iters;            /* pressure-solve iterations of the last step */
  double residual;      /* its final relative residual */
  double mass_err;      /* max over cells of |div(eps u) + d eps/dt| * dt (dimensionless) after the step */
  double eps_min;       /* smallest cell voidage (before the floor) */
  double eps_mean;      /* mean cell voidage */
  double umax;          /* largest |u| at a face (interstitial) */
  double cfl;           /* dt max |u_d| / h_d of the last step */
  double dp;            /* mean pressure of the first minus the last cell layer along the flow axis */
  int flow_axis;        /* axis of the first inlet side (2 if none) */
  double f_grains[3];   /* sum of the drag forces on the grains (last step) */
  double f_gas[3];      /* sum of the drag reaction on the gas at interior faces (face-based) */
  double f_bound[3];    /* the share of boundary faces (prescribed velocity): f_grains + f_gas = f_bound */
  double f_pg[3];       /* sum of the pressure-gradient forces on the grains */
} sphdem_cfd_stats;

/* Wall-clock time per phase (s): voidage + drag coefficients (coupling), momentum predictor,
 * pressure solve, correction + grain forces, host<->device transfers. */
enum { SPHDEM_CFD_T_COUPLE = 0, SPHDEM_CFD_T_PREDICT, SPHDEM_CFD_T_SOLVE, SPHDEM_CFD_T_CORRECT,
       SPHDEM_CFD_T_TRANSFER, SPHDEM_CFD_NTIMERS };

void sphdem_cfd_params_default(sphdem_cfd_params *p);
int sphdem_cfd_params_check(const sphdem_cfd_params *p, char *msg, size_t msglen);
int sphdem_cfd_create(sphdem_cfd *out, const sphdem_cfd_params *p, sphdem_device dev, char *msg, size_t msglen);
int sphdem_cfd_destroy(sphdem_cfd *c);
const char *sphdem_cfd_last_error(sphdem_cfd c);
int sphdem_cfd_backend(sphdem_cfd c);
/* Change parameters between steps: everything but nc and the box (e.g. inlet_u for a sweep). */
int sphdem_cfd_set_params(sphdem_cfd c, const sphdem_cfd_params *p);
int sphdem_cfd_set_comm(sphdem_cfd c, const sphdem_comm *comm); /* NULL: one rank */
/* Many ranks, decomposed grid (collective use; call after sphdem_cfd_set_comm, before the first step): this rank
 * owns the global cells [lo[d], hi[d]) along each axis (the ranks' blocks tile the grid on a regular processor
 * grid) and stores them plus a halo of 2 cells towards each neighbour, exchanged through comm->exchange. Without
 * it every rank holds the whole grid (replicated: the deposits are summed with allreduce). SPHDEM_ERR_ARG for a
 * block outside the grid or thinner than 2 cells along an axis that is cut. The gas state restarts at rest. */
int sphdem_cfd_set_subdomain(sphdem_cfd c, const int lo[3], const int hi[3]);
/* cells stored on this rank (owned and halo) */
int64_t sphdem_cfd_local_cells(sphdem_cfd c);
/* bytes this rank sent in halo exchanges, and the exchanges, since creation */
void sphdem_cfd_halo_traffic(sphdem_cfd c, double *bytes, long *calls);
int sphdem_cfd_get_params(sphdem_cfd c, sphdem_cfd_params *p);
/* Advance the gas by dt with n grains (x, v 3n; radius n). Voidage and drag coefficients from the
 * grains (slip of the previous gas field), momentum predictor with implicit drag, pressure solve,
 * correction. Then the force on each grain from the new field: fdrag = K_i (u_g(x_i) - v_i),
 * fpg = -V_i grad p(x_i); 3n each, either may be NULL. n may change between calls; grains outside
 * the box are clamped into the boundary cells. Errors: CFL above cfl_max, solver not converged,
 * non-finite field (the message names the likely cause). */
int sphdem_cfd_step(sphdem_cfd c, double dt, int n, const double *x, const double *v, const double *radius,
                    double *fdrag, double *fpg);
/* The same from a grain store of the context's backend: the first n grains (idx NULL) or grains idx[0..n). */
int sphdem_cfd_step_store(sphdem_cfd c, double dt, sphdem_grain_store g, int n, const int32_t *idx, double *fdrag,
                          double *fpg);
int sphdem_cfd_stats_get(sphdem_cfd c, sphdem_cfd_stats *s);
/* Cell fields of the whole grid, x fastest (index i + nx (j + ny k)): voidage (before the floor), pressure, gas
 * velocity at the cell centre (interstitial, 3 per cell, mean of the two faces). Any may be NULL. On a
 * decomposed grid collective: every rank gets the whole grid. */
int sphdem_cfd_get_fields(sphdem_cfd c, double *eps, double *p, double *u);
/* Gas state for restart files: SPHDEM_CFD state_size() doubles (face velocities, pressure, voidage) of the whole
 * grid, the same layout at any rank count. On a decomposed grid get_state is collective (every rank gets the
 * whole state) and set_state takes this rank's cells and halo from the whole state. */
int64_t sphdem_cfd_state_size(sphdem_cfd c);
int sphdem_cfd_get_state(sphdem_cfd c, double *state);
int sphdem_cfd_set_state(sphdem_cfd c, const double *state);
/* Set the gas to a uniform interstitial velocity u (boundary faces keep their conditions), p = 0. */
int sphdem_cfd_set_velocity(sphdem_cfd c, const double u[3]);
void sphdem_cfd_timers(sphdem_cfd c, double t[SPHDEM_CFD_NTIMERS]);
void sphdem_cfd_timers_reset(sphdem_cfd c);
size_t sphdem_cfd_device_bytes(sphdem_cfd c);
/* Drag law of eqs 15-17 as the coefficient K = beta V_p / (1 - eps) (N s/m) of f = K (u - v), for a
 * grain of diameter d, voidage eps, slip speed |u - v|; drag is a sphdem_cfd_drag. */
double sphdem_cfd_drag_coef(int drag, double eps, double slip, double d, double rho_g, double mu_g);

/* ---- set-up of a fluid at rest (sph/sph_setup.c): context-free, for the engine shims ----------------- */
/* The free surface for a hydrostatic start from the n particles x (3n): the highest one against gravity, along
 * the axis of the largest gravity component (as sphdem_initial_density takes it), plus dx/2; over every rank
 * with comm (collective; NULL: this rank alone). axis (0-2) and up (+1: the surface is the highest particle,
 * -1: the lowest, gravity along +axis) may be NULL. SPHDEM_ERR_ARG for bad arguments. */
int sphdem_free_surface(const sphdem_params *p, int n, const double *x, const sphdem_comm *comm, double *zsurf,
                        int *axis, int *up);
/* The factor rho / rho0 (rho0 of the particle's phase when m is enabled) by which a lattice particle's mass
 * m0 = rho0 V is scaled when it starts at density rho, so that its SPH volume m / rho stays V. */
double sphdem_volume_mass_factor(const sphdem_params *p, const sphdem_mp_params *m, int phase, double rho);
/* Superficial SPH-DEM coupling (He 2018 eq 6: the density variable is eps rho_f): fresh particles which[j]
 * (j < nout) among grains start at rho = e rho and, when mass is given, m = e m, e = max(eps, eps_min) the
 * porosity of the first rate evaluation, so that their volume m / rho stays the lattice volume. */
int sphdem_superficial_start(double eps_min, int nout, const int *which, const double *eps, double *rho,
                             double *mass);
/* Initial density of fluid particles that have no state yet. n particles (x 3n; phase n, the phase index
 * of each, used when m is given and m->enabled) are the whole fluid; rho[j] is written for particle
 * which[j], j < nout. Single phase (m NULL or not enabled): rho0, or with hydrostatic the Tait-inverted
 * density sphdem_hydrostatic_rho at the depth below zsurf (along the axis of the largest gravity
 * component). Multiphase: the phase's EOS inverted (sphdem_mp_density) at P0, plus with hydrostatic the
 * pressure of the layers above it (the fluid binned by dx in depth, each bin's mean reference density
 * integrated from zsurf down: exact for horizontal layers, an estimate elsewhere). SPHDEM_ERR_ARG for a
 * bad index or phase, SPHDEM_ERR_ALLOC. */
int sphdem_initial_density(const sphdem_params *p, const sphdem_mp_params *m, int hydrostatic, double zsurf, int n,
                           const double *x, const int *phase, int nout, const int *which, double *rho);
/* The same on many ranks: n, x, phase are this rank's owned particles; the layers are binned over every rank
 * (collective when the multiphase hydrostatic start is on: every rank calls it, with or without fresh particles). */
int sphdem_initial_density_ranks(const sphdem_params *p, const sphdem_mp_params *m, int hydrostatic, double zsurf,
                                 int n, const double *x, const int *phase, int nout, const int *which, double *rho,
                                 const sphdem_comm *comm);
/* Fixed ghost walls (Shi & Huang 2022 §3.4): xi (3n) of each of n wall particles (x 3n) is its mirror image
 * across the faces of the fluid box [lo, hi] it lies outside of (unbounded axes: -1e300, 1e300). A particle
 * inside the box: SPHDEM_ERR_ARG with *inside its index (xi written up to it); else *inside = -1. */
int sphdem_mirror_points(int n, const double *x, const double lo[3], const double hi[3], double *xi, int *inside);
/* ---- end of the set-up of a fluid at rest ---------------------------------------------------------------- */

#ifdef __cplusplus
}
#endif
#endif
