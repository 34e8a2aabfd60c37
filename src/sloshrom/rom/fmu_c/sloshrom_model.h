/* sloshrom sloshing ROM: the model's data layout and its step kernels (C99, no allocation).
 *
 * A model is the mean of one or more member networks of one class. Each member reads one tank
 * signal u (the tank's vertical velocity in m/s, or its acceleration in m/s^2) and gives the
 * dynamic sloshing force in N, positive up, at the model's sample rate. Every member works in
 * min-max scaled units: s(u) = 2 (u - u_min) / (u_max - u_min) - 1.
 *
 *   NFIR  y_k = rbf(s(u_{k-d_1}), ..., s(u_{k-d_n}))
 *   NOE   y_k = rbf(s(u_{k-d_1}), ..., s(u_{k-d_n}), y_{k-1}, ..., y_{k-m})   (scaled outputs)
 *   NSS   y_k = H(x_k, s(u_k)) - H(0, r_u) + r_y,
 *         x_{k+1} = x_k + F(x_k, s(u_k)) - F(0, r_u),  r_u = s(0), r_y = s_y(0)
 *
 * with the normalised radial-basis layer rbf(x) = sum_j c_j softmax(-n^2)_j + c_0,
 * n_j = W_j . x + b_j ("matlab") or n_j^2 = b_j^2 |x - W_j|^2 ("distance"), and
 * F(z) = z A + tanh(z W1 + b1) W2, H(z) = z C + tanh(z V1 + d1) V2 (row-major matrices).
 * The state of a member is its delay lines (NFIR, NOE) or x (NSS), in scaled units; the rest
 * state gives zero force with the tank at rest.
 *
 * This file is part of the sources that sloshrom writes into every FMU it exports.
 */
#ifndef SLOSHROM_MODEL_H
#define SLOSHROM_MODEL_H

#include <stddef.h>

/* The internal names (the model's data, the kernels) are private to the FMU: hidden from the
 * shared library's dynamic symbol table (two sloshrom FMUs loaded into one process with
 * RTLD_GLOBAL each keep their own model), and prefixed like the fmi2 functions when the sources
 * are compiled with FMI2_FUNCTION_PREFIX (several source FMUs linked into one program). Only
 * the fmi2 functions are exported (FMI2_Export, fmi2Functions.h). */
#if defined(FMI2_FUNCTION_PREFIX)
#define SL_PASTE_(a, b) a##b
#define SL_PASTE(a, b) SL_PASTE_(a, b)
#define SL_NAME(name) SL_PASTE(FMI2_FUNCTION_PREFIX, name)
#else
#define SL_NAME(name) name
#endif
#if defined(__GNUC__) && !defined(_WIN32) && !defined(__CYGWIN__)
#define SL_INTERNAL __attribute__((visibility("hidden")))
#else
#define SL_INTERNAL
#endif

#define SL_MODEL SL_NAME(SL_MODEL)
#define sl_state_size SL_NAME(sl_state_size)
#define sl_rest_size SL_NAME(sl_rest_size)
#define sl_scratch_size SL_NAME(sl_scratch_size)
#define sl_rest SL_NAME(sl_rest)
#define sl_output SL_NAME(sl_output)
#define sl_advance SL_NAME(sl_advance)
#define sl_unscale SL_NAME(sl_unscale)

#define SL_NFIR 0
#define SL_NOE 1
#define SL_NSS 2

#define SL_HIDDEN_MATLAB 0
#define SL_HIDDEN_DISTANCE 1

typedef struct {
    int arch;             /* SL_NFIR, SL_NOE or SL_NSS */
    int hidden;           /* SL_HIDDEN_MATLAB or SL_HIDDEN_DISTANCE (NFIR, NOE) */
    int n_delays;         /* input delays (NFIR, NOE) */
    const int *delays;    /* samples, each >= 1 */
    int max_delay;
    int out_delays;       /* fed-back outputs m (NOE) */
    int neurons;          /* hidden units */
    const double *W;      /* (neurons, n_delays + out_delays) */
    const double *b;      /* (neurons) */
    const double *c;      /* (neurons) */
    double c0;
    int n_states;         /* NSS: dimension of x */
    const double *A, *W1, *b1, *W2;   /* (nz, nx), (nz, H), (H), (H, nx); nz = nx + 1 */
    const double *C, *V1, *d1, *V2;   /* (nz), (nz, H), (H), (H) */
    double in_min, in_max, out_min, out_max;  /* scaler bounds, physical units */
    double unstable_bound;  /* |scaled output| beyond this (or not finite): unstable */
} SlMember;

typedef struct {
    const char *guid;
    const char *description;
    int n_members;
    const SlMember *members;
    double dt;                /* s: the model's step, the only communication step */
    int reads_acceleration;   /* 0: the members read the velocity; 1: the acceleration */
    int has_envelope;
    double input_min, input_max;        /* training range of the signal read */
    /* read-only parameters: NaN where the model does not know them */
    double acceleration_max, frequency_min, frequency_max, fill_min, fill_max;
} SlModel;

extern SL_INTERNAL const SlModel SL_MODEL;

/* doubles of state, of rest terms (constants of the NSS) and of scratch one member needs */
SL_INTERNAL size_t sl_state_size(const SlMember *m);
SL_INTERNAL size_t sl_rest_size(const SlMember *m);
SL_INTERNAL size_t sl_scratch_size(const SlMember *m);
/* the state at rest, and the member's rest terms */
SL_INTERNAL void sl_rest(const SlMember *m, double *state, double *rest, double *scratch);
/* scaled output at the current sample from the state and the current input u (physical) */
SL_INTERNAL double sl_output(const SlMember *m, const double *state, const double *rest,
                             double u, double *scratch);
/* advance the state by one sample, given the current input u (physical) and the scaled output
 * y_s that sl_output gave for it; call it right after that sl_output, with the same scratch
 * (the NSS reuses its map F from there) */
SL_INTERNAL void sl_advance(const SlMember *m, double *state, const double *rest, double u,
                            double y_s, double *scratch);
/* physical output from the scaled one */
SL_INTERNAL double sl_unscale(const SlMember *m, double y_s);

#endif
