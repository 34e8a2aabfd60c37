/* sloshrom sloshing ROM: the step kernels of sloshrom_model.h.
 *
 * The arithmetic follows the order of operations of sloshrom's own (JAX) model, so that the
 * FMU and the model agree to rounding: scaling 2 (u - min) / (max - min) - 1, the softmax as
 * exp(v - max v) / sum, the rest terms subtracted after the maps. The grey box's column
 * follows sloshrom's (numba and JAX) column operation for operation: its contacts, landings
 * and releases are thresholds on its state, which the same double operations reach alike.
 *
 * This file is part of the sources that sloshrom writes into every FMU it exports.
 */
#include <math.h>
#include "sloshrom_model.h"

/* No fused multiply-add: a * b + c rounded twice, as sloshrom computes it (GCC contracts by
 * default outside ISO C mode where the target has FMA, e.g. aarch64; a fused sub-step of the
 * grey box's column could move a contact or a release by a sub-step). */
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

/* Linux: bind exp to its oldest glibc version, so that the binary loads on every glibc since
 * 2.17 (the manylinux2014 baseline: RHEL 7/8, Ubuntu 18.04, SLES 12). glibc 2.29 gave exp a new
 * default version (exp@GLIBC_2.29) that only drops the SVID error handling: the same result
 * for every finite argument; pow (the grey box's gate) likewise. tanh, and the rest of what the
 * FMU calls, is older than 2.17. */
#if defined(__GLIBC__) && defined(__GNUC__)
#if defined(__x86_64__) && !defined(__ILP32__)
__asm__(".symver exp,exp@GLIBC_2.2.5");
__asm__(".symver pow,pow@GLIBC_2.2.5");
#elif defined(__aarch64__)
__asm__(".symver exp,exp@GLIBC_2.17");
__asm__(".symver pow,pow@GLIBC_2.17");
#elif defined(__i386__)
__asm__(".symver exp,exp@GLIBC_2.0");
__asm__(".symver pow,pow@GLIBC_2.0");
#endif
#endif

static double scale_u(const SlMember *m, double u) {
    return 2.0 * (u - m->in_min) / (m->in_max - m->in_min) - 1.0;
}

static double scale_y(const SlMember *m, double y) {
    return 2.0 * (y - m->out_min) / (m->out_max - m->out_min) - 1.0;
}

double sl_unscale(const SlMember *m, double y_s) {
    return (y_s + 1.0) * 0.5 * (m->out_max - m->out_min) + m->out_min;
}

/* GREY: the features of the column the network reads */
#define GREY_FEATURES 4

/* GREY: doubles of the committed sub-step forces the column keeps ((n_past - 1) intervals) */
static size_t grey_history(const SlMember *m) {
    return ((size_t)m->n_past - 1) * (size_t)m->n_substeps;
}

size_t sl_state_size(const SlMember *m) {
    if (m->arch == SL_NSS) return (size_t)m->n_states;
    if (m->arch == SL_GREY)  /* x, z, v, att, gate, level, a_prev, u_prev, history, phi */
        return (size_t)m->n_states + 3 * (size_t)m->n_balls + 4 + grey_history(m)
               + GREY_FEATURES;
    return (size_t)m->max_delay + (size_t)m->out_delays;
}

size_t sl_rest_size(const SlMember *m) {
    return m->arch == SL_NSS || m->arch == SL_GREY ? (size_t)m->n_states + 1 : 0;
}

size_t sl_scratch_size(const SlMember *m) {
    if (m->arch == SL_NSS)
        return 2 * ((size_t)m->n_states + 1) + 2 * (size_t)m->neurons + (size_t)m->n_states;
    if (m->arch == SL_GREY)  /* z, F, tanh units, sums; the predicted balls; 3 intervals */
        return ((size_t)m->n_states + 1 + GREY_FEATURES) + 2 * (size_t)m->n_states
               + (size_t)m->neurons + 3 * (size_t)m->n_balls + 3 * (size_t)m->n_substeps;
    return (size_t)m->n_delays + (size_t)m->out_delays + (size_t)m->neurons;
}

/* normalised RBF layer of a regressor x (scaled units); h: scratch of `neurons` doubles */
static double rbf(const SlMember *m, const double *x, double *h) {
    const int H = m->neurons, D = m->n_delays + m->out_delays;
    double top = -HUGE_VAL, sum = 0.0, y = 0.0;
    int i, j;
    if (m->hidden == SL_HIDDEN_MATLAB) {
        for (j = 0; j < H; j++) {
            const double *w = m->W + (size_t)j * D;
            double n = 0.0;
            for (i = 0; i < D; i++) n += w[i] * x[i];
            n += m->b[j];
            h[j] = -(n * n);
        }
    } else {
        double xx = 0.0;
        for (i = 0; i < D; i++) xx += x[i] * x[i];
        for (j = 0; j < H; j++) {
            const double *w = m->W + (size_t)j * D;
            double wx = 0.0, ww = 0.0, d2;
            for (i = 0; i < D; i++) wx += w[i] * (2.0 * x[i]);
            for (i = 0; i < D; i++) ww += w[i] * w[i];
            d2 = xx - wx + ww;
            h[j] = -(m->b[j] * m->b[j] * (d2 > 0.0 ? d2 : 0.0));
        }
    }
    for (j = 0; j < H; j++) if (h[j] > top) top = h[j];
    for (j = 0; j < H; j++) { h[j] = exp(h[j] - top); sum += h[j]; }
    for (j = 0; j < H; j++) y += h[j] / sum * m->c[j];
    return y + m->c0;
}

/* NSS maps at z (nz = nx + 1): F(z) into f (nx), returns H(z); t: scratch of 2 H + nx doubles.
 * The products run row by row of the (row-major) matrices, contiguous in memory; each sum
 * still adds its terms in the order of the inner index. */
static double nss_maps(const SlMember *m, const double *z, double *f, double *t) {
    const int nx = m->n_states, nz = nx + 1, H = m->neurons;
    double *g = t + H, h = 0.0, out = 0.0;
    int i, j;
    for (j = 0; j < nx; j++) f[j] = 0.0;
    for (j = 0; j < H; j++) { t[j] = 0.0; g[j] = 0.0; }
    for (i = 0; i < nz; i++) {
        const double zi = z[i], *a = m->A + (size_t)i * nx, *w = m->W1 + (size_t)i * H,
                     *v = m->V1 + (size_t)i * H;
        for (j = 0; j < nx; j++) f[j] += zi * a[j];
        for (j = 0; j < H; j++) t[j] += zi * w[j];
        for (j = 0; j < H; j++) g[j] += zi * v[j];
        h += zi * m->C[i];
    }
    for (j = 0; j < H; j++) t[j] = tanh(t[j] + m->b1[j]);
    for (j = 0; j < H; j++) out += tanh(g[j] + m->d1[j]) * m->V2[j];
    {
        double *acc = g + H;  /* tanh(z W1 + b1) W2, summed apart as z A is */
        for (j = 0; j < nx; j++) acc[j] = 0.0;
        for (i = 0; i < H; i++) {
            const double ti = t[i], *w = m->W2 + (size_t)i * nx;
            for (j = 0; j < nx; j++) acc[j] += ti * w[j];
        }
        for (j = 0; j < nx; j++) f[j] += acc[j];
    }
    return h + out;
}

/* ---------------------------------------------------------------------------------------------
 * GREY: the grey box (sloshrom.rom.grey.network.GreyBoxNetwork.step)
 * ------------------------------------------------------------------------------------------- */

/* F(z) = z A + tanh(z W1 + b1) W2 into f (nx), z of nz entries; t: H doubles, acc: nx doubles.
 * z A and the tanh layer's product are summed apart and added last, as XLA's two dots. */
static void grey_f(const SlMember *m, const double *z, int nz, double *f, double *t,
                   double *acc) {
    const int nx = m->n_states, H = m->neurons;
    int i, j;
    for (j = 0; j < nx; j++) f[j] = 0.0;
    for (j = 0; j < H; j++) t[j] = 0.0;
    for (i = 0; i < nz; i++) {
        const double zi = z[i], *a = m->A + (size_t)i * nx, *w = m->W1 + (size_t)i * H;
        for (j = 0; j < nx; j++) f[j] += zi * a[j];
        for (j = 0; j < H; j++) t[j] += zi * w[j];
    }
    for (j = 0; j < H; j++) t[j] = tanh(t[j] + m->b1[j]);
    for (j = 0; j < nx; j++) acc[j] = 0.0;
    for (i = 0; i < H; i++) {
        const double ti = t[i], *w = m->W2 + (size_t)i * nx;
        for (j = 0; j < nx; j++) acc[j] += ti * w[j];
    }
    for (j = 0; j < nx; j++) f[j] += acc[j];
}

/* H(o) = o C + tanh(o V1 + d1) V2, o of no entries; t: H doubles */
static double grey_h(const SlMember *m, const double *o, int no, double *t) {
    const int H = m->neurons;
    double h = 0.0, out = 0.0;
    int i, j;
    for (j = 0; j < H; j++) t[j] = 0.0;
    for (i = 0; i < no; i++) {
        const double oi = o[i], *v = m->V1 + (size_t)i * H;
        for (j = 0; j < H; j++) t[j] += oi * v[j];
        h += oi * m->C[i];
    }
    for (j = 0; j < H; j++) out += tanh(t[j] + m->d1[j]) * m->V2[j];
    return h + out;
}

/* One sample interval of the column with the tank acceleration a held (physics.py, _interval
 * and _interval_jax): n_substeps semi-implicit Euler sub-steps of length h; updates the balls
 * (z, v, att) and *gate in place and writes each sub-step's force per unit ball mass (m/s^2,
 * before the coherence factor and the mass) into out. */
static void grey_interval(const SlMember *m, double *z, double *v, double *att, double *gate,
                          double a, double h, double *out) {
    const int n = m->n_balls, n_sub = m->n_substeps;
    const double *ph = m->physics;
    const double stiff = ph[1], damp = ph[2], gap = ph[3];
    const double geff = m->g + a;
    const int neg = geff < 0.0;
    const double sdot = ph[4] * pow(fabs(geff) / m->g, 0.25);
    const double decay = exp(-h / ph[5]);
    const double alpha = -geff;
    double s = *gate;
    int i, j;
    for (j = 0; j < n_sub; j++) {
        double dv_sum = 0.0;
        if (neg) {
            s = s + sdot * h;
            if (1.0 < s) s = 1.0;
        } else {
            s *= decay;
        }
        for (i = 0; i < n; i++) {
            double zi, vi, f = 0.0, vn, zn;
            if (att[i] > 0.0) {
                if (neg && s >= ((double)i + 0.5) / (double)n) att[i] = 0.0;
                else continue;
            }
            zi = z[i];
            vi = v[i];
            if (zi < 0.0) {
                f = -stiff * zi - damp * vi;
                if (0.0 > f) f = 0.0;   /* compressive only */
            } else if (zi > gap) {
                f = -stiff * (zi - gap) - damp * vi;
                if (0.0 < f) f = 0.0;
            }
            vn = vi + h * (alpha + f);
            zn = zi + h * vn;
            if (zn <= 0.0 && vn >= 0.0 && alpha < 0.0) {  /* landed under gravity: attached */
                vn = 0.0;
                zn = 0.0;
                att[i] = 1.0;
            }
            dv_sum += vn - vi;
            z[i] = zn;
            v[i] = vn;
        }
        out[j] = -dv_sum / ((double)n * h);
    }
    *gate = s;
}

/* the parts of a GREY member's state (sl_state_size) */
typedef struct {
    double *x, *z, *v, *att, *gate, *level, *a_prev, *u_prev, *hist, *phi;
} GreyState;

static GreyState grey_state(const SlMember *m, double *state) {
    GreyState p;
    p.x = state;
    p.z = p.x + m->n_states;
    p.v = p.z + m->n_balls;
    p.att = p.v + m->n_balls;
    p.gate = p.att + m->n_balls;
    p.level = p.gate + 1;
    p.a_prev = p.level + 1;
    p.u_prev = p.a_prev + 1;
    p.hist = p.u_prev + 1;
    p.phi = p.hist + grey_history(m);
    return p;
}

/* the column's step with the velocity u (physics.py, physics_step): commit the interval ending
 * now, predict the two after it, and compute the next output's features (N) into p.phi */
static void grey_physics_step(const SlMember *m, GreyState p, double u, double *scratch) {
    const int nb = m->n_balls, ns = m->n_substeps;
    const size_t n_hist = grey_history(m);
    const double *ph = m->physics, *taps = m->taps;
    const double dt = 1.0 / m->fs, h = dt / ns;
    double *zp = scratch, *vp = zp + nb, *attp = vp + nb, *fc = attp + nb, *f1 = fc + ns,
           *f2 = f1 + ns;
    double a = (u - *p.u_prev) * m->fs, q, scale, gp, acc, sum;
    size_t k, r;
    int i, j;
    grey_interval(m, p.z, p.v, p.att, p.gate, a, h, fc);
    *p.level = *p.level
               + (0.5 * 3.141592653589793 * fabs(a) / m->g - *p.level)
                     * (1.0 - exp(-dt / m->coherence_time));
    q = *p.level / ph[6];
    scale = ph[0] / (1.0 + q * q);
    for (j = 0; j < ns; j++) fc[j] = scale * fc[j];
    for (i = 0; i < nb; i++) {
        zp[i] = p.z[i];
        vp[i] = p.v[i];
        attp[i] = p.att[i];
    }
    gp = *p.gate;
    grey_interval(m, zp, vp, attp, &gp, 2.0 * a - *p.a_prev, h, f1);
    grey_interval(m, zp, vp, attp, &gp, 3.0 * a - 2.0 * *p.a_prev, h, f2);
    for (j = 0; j < ns; j++) {
        f1[j] = scale * f1[j];
        f2[j] = scale * f2[j];
    }
    /* the committed forces, newest first: this interval's (reversed) before the older ones */
    for (k = n_hist; k > (size_t)ns; k--) p.hist[k - 1] = p.hist[k - 1 - ns];
    for (j = 0; j < ns; j++) p.hist[j] = fc[ns - 1 - j];
    /* the filter's rows: the second predicted interval, the first, then the history */
    acc = 0.0;
    r = 0;
    for (j = ns - 1; j >= 0; j--) acc += f2[j] * taps[r++];
    for (j = ns - 1; j >= 0; j--) acc += f1[j] * taps[r++];
    for (k = 0; k < n_hist; k++) acc += p.hist[k] * taps[r++];
    p.phi[0] = acc;
    sum = 0.0;
    for (j = 0; j < ns; j++) sum += fc[j];
    p.phi[1] = sum / ns;
    sum = 0.0;
    for (j = 0; j < ns; j++) sum += f1[j];
    p.phi[2] = sum / ns;
    sum = 0.0;
    for (j = 0; j < ns; j++) sum += f2[j];
    p.phi[3] = sum / ns;
    *p.a_prev = a;
    *p.u_prev = u;
}

/* the output's half range, the features' scale */
static double grey_half(const SlMember *m) {
    return 0.5 * (m->out_max - m->out_min);
}

static void grey_rest(const SlMember *m, double *state, double *rest, double *scratch) {
    const int nx = m->n_states, nz = nx + 1 + GREY_FEATURES;
    size_t i, n = sl_state_size(m);
    double *z = scratch, *t = z + nz, *acc = t + m->neurons;
    GreyState p = grey_state(m, state);
    for (i = 0; i < n; i++) state[i] = 0.0;
    for (i = 0; i < (size_t)m->n_balls; i++) p.att[i] = 1.0;  /* every ball attached */
    for (i = 0; i < (size_t)nz; i++) z[i] = 0.0;
    grey_f(m, z, nz, rest, t, acc);           /* F(0) in rest[0..nx) */
    rest[nx] = grey_h(m, z, nz - 1, t);       /* H(0) last */
}

static double grey_output(const SlMember *m, const double *state, const double *rest,
                          double *scratch) {
    const int nx = m->n_states, no = nx + GREY_FEATURES;
    const double *phi = state + (sl_state_size(m) - GREY_FEATURES), half = grey_half(m);
    double *o = scratch, *t = o + no + 1;
    int i;
    for (i = 0; i < nx; i++) o[i] = state[i];
    for (i = 0; i < GREY_FEATURES; i++) o[nx + i] = phi[i] / half;
    return scale_y(m, 0.0) + o[nx] + grey_h(m, o, no, t) - rest[nx];
}

static void grey_advance(const SlMember *m, double *state, const double *rest, double u,
                         double *scratch) {
    const int nx = m->n_states, nz = nx + 1 + GREY_FEATURES;
    const double half = grey_half(m);
    double *z = scratch, *f = z + nz, *t = f + nx, *acc = t + m->neurons,
           *phys = acc + nx;
    GreyState p = grey_state(m, state);
    int i;
    /* the network: x_{k+1} = x_k + F([x_k, s(u_k) - r_u, phi_k]) - F(0) */
    for (i = 0; i < nx; i++) z[i] = p.x[i];
    z[nx] = scale_u(m, u) - scale_u(m, 0.0);
    for (i = 0; i < GREY_FEATURES; i++) z[nx + 1 + i] = p.phi[i] / half;
    grey_f(m, z, nz, f, t, acc);
    for (i = 0; i < nx; i++) p.x[i] = p.x[i] + f[i] - rest[i];
    /* then the column, which gives phi_{k+1} */
    grey_physics_step(m, p, u, phys);
}

void sl_rest(const SlMember *m, double *state, double *rest, double *scratch) {
    size_t i, n = sl_state_size(m);
    if (m->arch == SL_GREY) {
        grey_rest(m, state, rest, scratch);
        return;
    }
    if (m->arch == SL_NSS) {
        const int nx = m->n_states;
        double *z = scratch, *t = scratch + 2 * (nx + 1);
        for (i = 0; i < n; i++) state[i] = 0.0;
        for (i = 0; i < (size_t)nx; i++) z[i] = 0.0;
        z[nx] = scale_u(m, 0.0);
        rest[nx] = nss_maps(m, z, rest, t);   /* F(z_rest) in rest[0..nx), H(z_rest) last */
        return;
    }
    for (i = 0; i < (size_t)m->max_delay; i++) state[i] = scale_u(m, 0.0);
    for (i = 0; i < (size_t)m->out_delays; i++) state[m->max_delay + i] = scale_y(m, 0.0);
}

double sl_output(const SlMember *m, const double *state, const double *rest, double u,
                 double *scratch) {
    int i;
    if (m->arch == SL_GREY) return grey_output(m, state, rest, scratch);  /* not u: proper */
    if (m->arch == SL_NSS) {
        const int nx = m->n_states;
        double *z = scratch, *f = scratch + (nx + 1), *t = scratch + 2 * (nx + 1);
        for (i = 0; i < nx; i++) z[i] = state[i];
        z[nx] = scale_u(m, u);
        return nss_maps(m, z, f, t) - rest[nx] + scale_y(m, 0.0);
    }
    {
        double *x = scratch, *h = scratch + m->n_delays + m->out_delays;
        for (i = 0; i < m->n_delays; i++) x[i] = state[m->delays[i] - 1];
        for (i = 0; i < m->out_delays; i++) x[m->n_delays + i] = state[m->max_delay + i];
        return rbf(m, x, h);
    }
}

void sl_advance(const SlMember *m, double *state, const double *rest, double u, double y_s,
                double *scratch) {
    int i;
    if (m->arch == SL_GREY) {
        grey_advance(m, state, rest, u, scratch);
        return;
    }
    if (m->arch == SL_NSS) {  /* F(z_k) is in the scratch since sl_output */
        const double *f = scratch + (m->n_states + 1);
        for (i = 0; i < m->n_states; i++) state[i] = state[i] + f[i] - rest[i];
        return;
    }
    for (i = m->max_delay - 1; i > 0; i--) state[i] = state[i - 1];
    state[0] = scale_u(m, u);
    if (m->arch == SL_NOE && m->out_delays > 0) {
        double *y = state + m->max_delay;
        for (i = m->out_delays - 1; i > 0; i--) y[i] = y[i - 1];
        y[0] = y_s;
    }
}
