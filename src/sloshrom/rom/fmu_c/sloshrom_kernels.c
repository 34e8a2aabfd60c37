/* sloshrom sloshing ROM: the step kernels of sloshrom_model.h.
 *
 * The arithmetic follows the order of operations of sloshrom's own (JAX) model, so that the
 * FMU and the model agree to rounding: scaling 2 (u - min) / (max - min) - 1, the softmax as
 * exp(v - max v) / sum, the rest terms subtracted after the maps.
 *
 * This file is part of the sources that sloshrom writes into every FMU it exports.
 */
#include <math.h>
#include "sloshrom_model.h"

/* Linux: bind exp to its oldest glibc version, so that the binary loads on every glibc since
 * 2.17 (the manylinux2014 baseline: RHEL 7/8, Ubuntu 18.04, SLES 12). glibc 2.29 gave exp a new
 * default version (exp@GLIBC_2.29) that only drops the SVID error handling: the same result
 * for every finite argument. tanh, and the rest of what the FMU calls, is older than 2.17. */
#if defined(__GLIBC__) && defined(__GNUC__)
#if defined(__x86_64__) && !defined(__ILP32__)
__asm__(".symver exp,exp@GLIBC_2.2.5");
#elif defined(__aarch64__)
__asm__(".symver exp,exp@GLIBC_2.17");
#elif defined(__i386__)
__asm__(".symver exp,exp@GLIBC_2.0");
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

size_t sl_state_size(const SlMember *m) {
    if (m->arch == SL_NSS) return (size_t)m->n_states;
    return (size_t)m->max_delay + (size_t)m->out_delays;
}

size_t sl_rest_size(const SlMember *m) {
    return m->arch == SL_NSS ? (size_t)m->n_states + 1 : 0;
}

size_t sl_scratch_size(const SlMember *m) {
    if (m->arch == SL_NSS)
        return 2 * ((size_t)m->n_states + 1) + 2 * (size_t)m->neurons + (size_t)m->n_states;
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

void sl_rest(const SlMember *m, double *state, double *rest, double *scratch) {
    size_t i, n = sl_state_size(m);
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
