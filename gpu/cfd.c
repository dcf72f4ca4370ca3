/* cfd.c - placeholder while the gas grid is written (replaced in the next commit). */
#include <string.h>
#include "sphdem.h"
void sphdem_cfd_params_default(sphdem_cfd_params *p) { memset(p, 0, sizeof *p); }
int sphdem_cfd_params_check(const sphdem_cfd_params *p, char *m, size_t l) { (void)p; (void)m; (void)l; return SPHDEM_ERR_STATE; }
int sphdem_cfd_create(sphdem_cfd *o, const sphdem_cfd_params *p, sphdem_device d, char *m, size_t l) { (void)p; (void)d; (void)m; (void)l; *o = 0; return SPHDEM_ERR_STATE; }
int sphdem_cfd_destroy(sphdem_cfd *c) { (void)c; return 0; }
const char *sphdem_cfd_last_error(sphdem_cfd c) { (void)c; return "not implemented"; }
int sphdem_cfd_backend(sphdem_cfd c) { (void)c; return 1; }
int sphdem_cfd_set_params(sphdem_cfd c, const sphdem_cfd_params *p) { (void)c; (void)p; return SPHDEM_ERR_STATE; }
int sphdem_cfd_get_params(sphdem_cfd c, sphdem_cfd_params *p) { (void)c; (void)p; return SPHDEM_ERR_STATE; }
int sphdem_cfd_step(sphdem_cfd c, double dt, int n, const double *x, const double *v, const double *r, double *fd, double *fp) { (void)c; (void)dt; (void)n; (void)x; (void)v; (void)r; (void)fd; (void)fp; return SPHDEM_ERR_STATE; }
int sphdem_cfd_stats_get(sphdem_cfd c, sphdem_cfd_stats *s) { (void)c; (void)s; return SPHDEM_ERR_STATE; }
int sphdem_cfd_get_fields(sphdem_cfd c, double *e, double *p, double *u) { (void)c; (void)e; (void)p; (void)u; return SPHDEM_ERR_STATE; }
int64_t sphdem_cfd_state_size(sphdem_cfd c) { (void)c; return 0; }
int sphdem_cfd_get_state(sphdem_cfd c, double *s) { (void)c; (void)s; return SPHDEM_ERR_STATE; }
int sphdem_cfd_set_state(sphdem_cfd c, const double *s) { (void)c; (void)s; return SPHDEM_ERR_STATE; }
int sphdem_cfd_set_velocity(sphdem_cfd c, const double u[3]) { (void)c; (void)u; return SPHDEM_ERR_STATE; }
void sphdem_cfd_timers(sphdem_cfd c, double t[SPHDEM_CFD_NTIMERS]) { (void)c; memset(t, 0, sizeof(double) * SPHDEM_CFD_NTIMERS); }
void sphdem_cfd_timers_reset(sphdem_cfd c) { (void)c; }
size_t sphdem_cfd_device_bytes(sphdem_cfd c) { (void)c; return 0; }
double sphdem_cfd_drag_coef(int drag, double eps, double slip, double d, double rho, double mu) { (void)drag; (void)eps; (void)slip; (void)d; (void)rho; (void)mu; return 0; }
