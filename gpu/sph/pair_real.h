/* pair_real.h - the fluid's pair arithmetic (the plain fluid of He 2018 §2.1: kernel eq 5, continuity eq 6,
 * momentum eqs 9-11, XSPH eq 12, the Adami wall pair, delta-SPH; the delta-plus fluid's pair terms of Shi & Huang
 * 2022 eqs 3, 15-20, 24) in one real type, written once and included once per
 * precision by sph_bodies.h: SPHDEM_REAL double with names as written (the precision double, and every other
 * user of these functions), SPHDEM_REAL float with the suffix _f (the precisions mixed and single: the pair
 * terms in float, the caller's sums in double). The caller computes the separation r_ab (double positions in
 * mixed, float positions in single) and rejects pairs out of reach. The terms that are on come in O
 * (sphdem_pair_opts, pair_opts of sph_bodies.h): the float pair loop of the CPU passes them as constants, so that
 * each variant of the loop has no branch per pair for a term that is off.
 * The includer defines SPHDEM_REAL, SPHDEM_RNAME(name), SPHDEM_RSQRT, SPHDEM_RFABS, SPHDEM_RPOW and SPHDEM_RFLOAT
 * (1 for float); the file undefines them at its end. No include guard: included once per real type. Not public. */

#define R SPHDEM_REAL
#define RN(name) SPHDEM_RNAME(name)

/* The constants the pair terms read (RN(pair_consts) of sph_internal.h), converted to the real type; derived once
 * per change of the parameters (sph_ctx.c): D->K, D->Kf. */
SPHDEM_RINLINE void RN(pair_consts_set)(const sphdem_dev *D, RN(pair_consts) *K) {
  K->inv_h = (R)D->inv_h; K->alphaD = (R)D->alphaD; K->eta2 = (R)D->eta2; K->mp_eta2 = (R)(SPHDEM_MP_ETA2 * D->h * D->h);
  K->h = (R)D->h; K->w_dx_inv = (R)D->w_dx_inv;
  K->tensile_eps = (R)D->P.tensile_eps; K->tensile_n = (R)D->P.tensile_n; K->mu = (R)D->P.mu; K->alpha = (R)D->P.alpha;
  K->c0 = (R)D->P.c0; K->delta = (R)D->P.delta; K->rho0 = (R)D->P.rho0;
  SPHDEM_FOR3(d, K->g[d] = (R)D->P.gravity[d];)
  K->xsph_eps = (R)D->P.xsph_eps; K->rep_D = (R)D->P.rep_D; K->rep_r0 = (R)D->P.rep_r0;
}

/* W(q) (eq 5). */
SPHDEM_RINLINE R RN(wendland_w)(R alphaD, R q) {
  if (q >= (R)2) return (R)0;
  R t = (R)1 - (R)0.5 * q, t2 = t * t;
  return alphaD * t2 * t2 * ((R)1 + (R)2 * q);
}

/* F(q) such that grad_a W_ab = F * r_ab (r_ab = r_a - r_b): F = dW/dr / r = -5 alpha_D (1-q/2)^3 / h^2. */
SPHDEM_RINLINE R RN(wendland_grad_factor)(R alphaD, R inv_h, R q) {
  if (q >= (R)2) return (R)0;
  R t = (R)1 - (R)0.5 * q;
  return (R)-5 * alphaD * t * t * t * inv_h * inv_h;
}

/* Pairwise momentum terms shared by fluid-fluid and fluid-wall pairs: pressure (eq 9) with the
 * tensile correction (eq 11) and the viscous term (eq 10 Morris, or Monaghan artificial).
 * pra/prb are P/rho^2 of a and b, ie = 1/(r^2 + 0.01 h^2), vab the velocity difference seen by
 * viscosity. Adds to acc. */
SPHDEM_RINLINE void RN(pair_momentum)(const RN(pair_consts) *K, sphdem_pair_opts O, R mb, R pra, R rhoa, R prb, R rhob, R W, R F, const R *r,
                                 R r2, R ie, const R *vab, R *acc) {
  R pterm = pra + prb;
  if (O.tensile) {
    /* eq 11, with |P| so that the correction is repulsive for negative pressures too */
    R f = W * K->w_dx_inv, fn;
    if (O.tensile4) { fn = f * f; fn *= fn; } else fn = SPHDEM_RPOW(f, K->tensile_n);
    pterm += K->tensile_eps * (SPHDEM_RFABS(pra) + SPHDEM_RFABS(prb)) * fn;
  }
  R s = -mb * pterm * F; /* -m_b (...) grad W, grad W = F r */
  if (O.visc == SPHDEM_VISC_MORRIS) {
    /* eq 10: m_b (mu_a + mu_b) r.gradW / (rho_a rho_b (r^2 + 0.01 h^2)) v_ab */
    R k = mb * (R)2 * K->mu * F * r2 * ie / (rhoa * rhob);
    SPHDEM_FOR3(d, acc[d] += k * vab[d];)
  } else if (O.visc == SPHDEM_VISC_ARTIFICIAL) {
    R vr = (R)0;
    SPHDEM_FOR3(d, vr += vab[d] * r[d];)
#if SPHDEM_RFLOAT
    /* float: branch-free (muab = 0 unless the pair approaches), so that the float pair loop vectorises */
    R muab = vr < (R)0 ? K->h * vr * ie : (R)0;
    s += mb * K->alpha * K->c0 * muab * F * (R)2 / (rhoa + rhob); /* -m_b Pi_ab grad W */
#else
    if (vr < (R)0) {
      R muab = K->h * vr * ie;
      s += mb * K->alpha * K->c0 * muab * F * (R)2 / (rhoa + rhob); /* -m_b Pi_ab grad W */
    }
#endif
  }
  SPHDEM_FOR3(d, acc[d] += s * r[d];)
}

/* Keyword pressure_form of the coupling: the pair (a, b) in volume form, force on a from b -V_a V_b (P_a + P_b) grad W
 * and continuity rho_a sum_b V_b v_ab.grad W (V = m / rho), is the mass form's pair with P_a/rho_a^2 scaled by
 * *ka = rho_a/rho_b, P_b/rho_b^2 by *kb = rho_b/rho_a and a's continuity term by ka. Both 1 in the mass form (eq 9). */
SPHDEM_RINLINE void RN(pair_form_factors)(sphdem_pair_opts O, R rhoa, R rhob, R *ka, R *kb) {
  *ka = O.vol ? rhoa / rhob : (R)1;
  *kb = O.vol ? rhob / rhoa : (R)1;
}

/* delta-SPH density diffusion between fluid particles a and b (Molteni & Colagrossi 2009):
 * delta h c0 sum_b psi_ab . grad_a W V_b, psi_ab = 2 (rho_b - rho_a - rho^H_ab) r_ba / (r^2 + 0.01 h^2);
 * returned per unit mass of b (V_b = m_b / rho_b: the caller multiplies by m_b).
 * rho^H_ab is the hydrostatic part of rho_b - rho_a (Fourtakas et al. 2019), linearised in the
 * Tait law: rho^H_ab = -rho0 g.r_ab / c0^2 (relative error O(rho0 g dz / B)). */
SPHDEM_RINLINE R RN(density_diffusion)(const RN(pair_consts) *K, sphdem_pair_opts O, R rhoa, R rhob, R F, const R *r, R r2, R ie) {
  R drh = rhob - rhoa;
  if (O.hydro) {
    R gr = (R)0;
    SPHDEM_FOR3(d, gr += K->g[d] * r[d];) /* r[d] = 0 beyond dim */
    drh += K->rho0 * gr / (K->c0 * K->c0);
  }
  return (R)-2 * K->delta * K->h * K->c0 * drh * F * r2 * ie / rhob;
}

/* XSPH (He 2018 eq 12): a moves with v_a + sum_b m_b xsph_weight (v_a - v_b); 0 with xsph off. */
SPHDEM_RINLINE R RN(xsph_weight)(const RN(pair_consts) *K, sphdem_pair_opts O, R rhoa, R rhob, R W) {
  return O.xsph ? -K->xsph_eps / ((R)0.5 * (rhoa + rhob)) * W : (R)0;
}

/* The record of one fluid pair (a, b), for every fluid model. Plain fluid (fluid_pair_terms): per unit mass
 * of the partner; every term is symmetric or antisymmetric in a and b, so one evaluation serves both: a
 * gains m_b (cont + dda) density rate, m_b A acceleration and m_b U XSPH velocity; b gains m_a (cont + ddb),
 * -m_a A and -m_a U (the CPU's half-list pass). Delta-plus fluid (dplus_pair_terms): a's own rates, weight
 * 1 (its shifting terms are not antisymmetric). */
typedef struct {
  R cont, dda, ddb, A[3], U[3];
} RN(fluid_pair_rec);

/* Continuity (eq 6), delta-SPH, momentum (eqs 9-11) and XSPH (eq 12) of a fluid pair within reach (0 < r2 <
 * (2h)^2): separation r = r_a - r_b, velocity difference vab = v_a - v_b (at the force time), rho and P/rho^2 of
 * both, the porosity of both (1 without coupling; epsb only read with the coupled EOS and delta-SPH). */
SPHDEM_RINLINE void RN(fluid_pair_core)(const RN(pair_consts) *K, sphdem_pair_opts O, const R *r, R r2, const R *vab, R rhoa, R pra, R epsa,
                                   R rhob, R prb, R epsb, RN(fluid_pair_rec) *P) {
  R q = SPHDEM_RSQRT(r2) * K->inv_h, alphaD = K->alphaD;
  R W = RN(wendland_w)(alphaD, q), F = RN(wendland_grad_factor)(alphaD, K->inv_h, q);
  R vdotr = (R)0, ie = (R)1 / (r2 + K->eta2);
  SPHDEM_FOR3(d, vdotr += vab[d] * r[d]; P->A[d] = (R)0;)
  P->cont = vdotr * F;                                                 /* eq 6 */
  P->dda = P->ddb = (R)0;
  if (O.delta == 2) {
    /* coupled, superficial density rho = eps rho_f: diffuse the intrinsic density rho_f (the EOS variable),
     * not the porosity structure of rho; each side's rate scaled back by its eps (He 2018 eq 7 context) */
    R dd = RN(density_diffusion)(K, O, rhoa / epsa, rhob / epsb, F, r, r2, ie);
    P->dda = epsa * dd * (rhob / epsb) / rhob;  /* density_diffusion divides by rho_f,b; V_b = m_b / rho_b */
    P->ddb = -epsb * dd * (rhob / epsb) / rhoa;
  } else if (O.delta == 1) {
    P->dda = RN(density_diffusion)(K, O, rhoa, rhob, F, r, r2, ie);
    P->ddb = -P->dda * rhob / rhoa;
  }
  /* pressure_form volume: the extra continuity part rides on dda/ddb, so one record still serves both sides */
  R ka, kb;
  RN(pair_form_factors)(O, rhoa, rhob, &ka, &kb);
  if (O.vol) { P->dda += P->cont * (ka - (R)1); P->ddb += P->cont * (kb - (R)1); }
  RN(pair_momentum)(K, O, (R)1, pra * ka, rhoa, prb * kb, rhob, W, F, r, r2, ie, vab, P->A);
  R k2 = RN(xsph_weight)(K, O, rhoa, rhob, W); /* eq 12 */
  SPHDEM_FOR3(d, P->U[d] = k2 * vab[d];)
}

/* Monaghan 1994 wall repulsion: D [(r0/r)^12 - (r0/r)^4] r_ab / r^2 within r0. */
SPHDEM_RINLINE void RN(wall_repulsion)(const RN(pair_consts) *K, sphdem_pair_opts O, R rr, R r2, const R *r, R *acc) {
  if (!O.rep || rr >= K->rep_r0) return;
  R s = K->rep_r0 / rr, s2 = s * s, s4 = s2 * s2, s12 = s4 * s4 * s4;
  R k3 = K->rep_D * (s12 - s4) / r2;
  SPHDEM_FOR3(d, acc[d] += k3 * r[d];)
}

/* Wall neighbour w of fluid particle a within reach (0 < r2 < (2h)^2), plain fluid: Adami wall state (eqs
 * 13-15) in continuity and momentum, Monaghan repulsion. vw = v_a - (prescribed wall velocity), vv = v_a -
 * (extrapolated wall velocity, eq 13); mw the wall mass, rw its density (eq 15), pw its pressure, ew its porosity
 * (1 uncoupled). Adds to *drho and acc. */
SPHDEM_RINLINE void RN(wall_pair_core)(const RN(pair_consts) *K, sphdem_pair_opts O, const R *r, R r2, const R *vw, const R *vv, R rhoa, R pra,
                                  R mw, R rw, R pw, R ew, R *drho, R *acc) {
  R rr = SPHDEM_RSQRT(r2), q = rr * K->inv_h, alphaD = K->alphaD;
  R W = RN(wendland_w)(alphaD, q), F = RN(wendland_grad_factor)(alphaD, K->inv_h, q);
  /* wall particles keep their volume V_w = m_w / rho0 (Adami 2012); their density follows eq 15 */
  R mb = mw * rw / K->rho0, vdotr = (R)0;
  if (O.porous_walls) { mb *= ew; rw *= ew; } /* coupled: superficial wall density eps_w rho_w */
  SPHDEM_FOR3(d, vdotr += vw[d] * r[d];) /* prescribed wall velocity: no penetration */
  R ka, kb; /* pressure_form (V_w = mb / rw) */
  RN(pair_form_factors)(O, rhoa, rw, &ka, &kb);
  *drho += mb * ka * vdotr * F;
  RN(pair_momentum)(K, O, mb, pra * ka, rhoa, pw / (rw * rw) * kb, rw, W, F, r, r2, (R)1 / (r2 + K->eta2), vv, acc);
  RN(wall_repulsion)(K, O, rr, r2, r, acc);
}

/* ---- the delta-plus fluid (Shi & Huang 2022; mp_bodies.h calls these) ---------------------------------- */

/* Fluid particle a's side of the delta-plus pair terms (mp_bodies.h, dplus_init): density, mass, V_a^2, P_a V_a^2 /
 * m_a, viscosity, 1/c_a^2, delta_d h c_a, velocity (force time), shift velocity, <grad P>^L. */
typedef struct {
  R rhoa, ma, Va2, paV, ic2, kdiff, va[3], dua[3], ga[3];
} RN(dplus_side);

/* Fluid pair (a, b) within reach, delta-plus: continuity with shifting (eq 15) and diffusion (eqs 16-18),
 * pressure (eq 20), viscosity (eq 24), the shifting terms of momentum (eq 3), XSPH (He 2018 eq 12); a's rates,
 * weight 1 (fluid_pair_rec). shift, diff: the model's switches (diff: SPHDEM_DIFF_*); same: b is in a's phase;
 * vab = v_a - v_b, vb b's velocity (force time), dub its shift velocity (0 without shifting), gb its <grad P>^L
 * (read with diff SPHDEM_DIFF_RENORM only); dp = P_b - P_a; mubar the harmonic mean of the viscosities (eq 24). */
SPHDEM_RINLINE void RN(dplus_pair_core)(const RN(pair_consts) *K, sphdem_pair_opts O, int shift, int diff, int same,
                                        const RN(dplus_side) *A, const R *r, R r2, const R *vab, const R *vb,
                                        const R *dub, const R *gb, R rhob, R mb, R pb, R dp, R mubar,
                                        RN(fluid_pair_rec) *P) {
  R q = SPHDEM_RSQRT(r2) * K->inv_h, ie = (R)1 / (r2 + K->mp_eta2);
  R W = RN(wendland_w)(K->alphaD, q), F = RN(wendland_grad_factor)(K->alphaD, K->inv_h, q);
  R rhoa = A->rhoa, Vb = mb / rhob, s1 = (R)0;
  for (int d = 0; d < 3; d++) s1 += (vab[d] + A->dua[d] - dub[d]) * r[d];
  R cont = rhoa * Vb * F * s1;                                              /* eq 15, first term */
  if (shift && same) {
    R t = (R)0;
    for (int d = 0; d < 3; d++) t += (rhob * dub[d] + rhoa * A->dua[d]) * r[d];
    cont += Vb * F * t;                                                       /* eq 15, div(rho du) */
  }
  if (diff) {
    R psi = (R)2 * dp;                                                        /* eq 17, times c_a^2 */
    if (diff == SPHDEM_DIFF_RENORM)
      for (int d = 0; d < 3; d++) psi += (A->ga[d] + gb[d]) * r[d];           /* -(<>_i + <>_j).(x_j - x_i) */
    psi *= A->ic2;
    cont += A->kdiff * psi * (-F) * r2 * ie * Vb;                             /* eq 16: (x_j - x_i).grad W / r^2 */
  }
  P->cont = cont;
  P->dda = P->ddb = (R)0;
  R ma = A->ma;
  R kp = -(A->paV + pb * Vb * Vb / ma) * F;                                   /* eq 20 */
  R kv = mubar * (A->Va2 + Vb * Vb) * F * r2 * ie / ma;                       /* eq 24 */
  for (int d = 0; d < 3; d++) P->A[d] = kp * r[d] + kv * vab[d];
  if (shift && same) {
    /* eq 3: div(u (x) du) - u div(du), Sun et al. 2019 discretisation */
    R dub_r = (R)0, dua_r = (R)0;
    for (int d = 0; d < 3; d++) { dub_r += dub[d] * r[d]; dua_r += A->dua[d] * r[d]; }
    for (int d = 0; d < 3; d++)
      P->A[d] += Vb * F * (vb[d] * dub_r + A->va[d] * dua_r) - A->va[d] * Vb * F * (dub_r - dua_r);
  }
  R k2 = mb * RN(xsph_weight)(K, O, rhoa, rhob, W);                          /* XSPH (He 2018 eq 12) */
  for (int d = 0; d < 3; d++) P->U[d] = k2 * vab[d];
}

/* Wall neighbour w of fluid particle a within reach, delta-plus: the wall's volume Vw in continuity, pressure
 * (its pressure pw) and viscosity (mubar, eq 24), Monaghan repulsion. vs = v_a + du_a - (prescribed wall
 * velocity), vv = v_a - (extrapolated wall velocity, eq 13). Adds to *drho and acc. */
SPHDEM_RINLINE void RN(dplus_wall_core)(const RN(pair_consts) *K, sphdem_pair_opts O, const RN(dplus_side) *A,
                                        const R *r, R r2, const R *vs, const R *vv, R Vw, R pw, R mubar, R *drho,
                                        R *acc) {
  R rr = SPHDEM_RSQRT(r2), q = rr * K->inv_h, ie = (R)1 / (r2 + K->mp_eta2);
  R F = RN(wendland_grad_factor)(K->alphaD, K->inv_h, q), s1 = (R)0;
  for (int d = 0; d < 3; d++) s1 += vs[d] * r[d];
  *drho += A->rhoa * Vw * F * s1;
  R ma = A->ma;
  R kp = -(A->paV + pw * Vw * Vw / ma) * F;
  R kv = mubar * (A->Va2 + Vw * Vw) * F * r2 * ie / ma;
  for (int d = 0; d < 3; d++) acc[d] += kp * r[d] + kv * vv[d];
  RN(wall_repulsion)(K, O, rr, r2, r, acc);
}

#undef R
#undef RN
/* the includer's configuration, for the next real type */
#undef SPHDEM_REAL
#undef SPHDEM_RNAME
#undef SPHDEM_RSQRT
#undef SPHDEM_RFABS
#undef SPHDEM_RPOW
#undef SPHDEM_RFLOAT
