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
 *   GREY  y_k = r_y + phi_k[0] + H(o_k) - H(0),   o_k = [x_k, phi_k]
 *         x_{k+1} = x_k + F(z_k) - F(0),          z_k = [x_k, s(u_k) - r_u, phi_k]
 *         then the column's step with u_k gives phi_{k+1}
 *
 * with the normalised radial-basis layer rbf(x) = sum_j c_j softmax(-n^2)_j + c_0,
 * n_j = W_j . x + b_j ("matlab") or n_j^2 = b_j^2 |x - W_j|^2 ("distance"), and
 * F(z) = z A + tanh(z W1 + b1) W2, H(z) = z C + tanh(z V1 + d1) V2 (row-major matrices).
 * The state of a member is its delay lines (NFIR, NOE) or x (NSS), in scaled units; the rest
 * state gives zero force with the tank at rest.
 *
 * The grey box (GREY) is a network of that form beside a physical model, an impacting liquid
 * column (sloshrom.rom.grey.physics): n_balls point masses released one after the other by a
 * Rayleigh-Taylor gate while the tank pulls the liquid down faster than gravity, flying through
 * the ullage and landing on compressive-only spring-dashpot contacts. Each sample interval is
 * n_substeps semi-implicit Euler sub-steps with the tank acceleration held. At each step the
 * interval that ends at t_k is committed with a = (u_k - u_{k-1}) fs, the two after it are
 * predicted with 2 a - a_prev and 3 a - 2 a_prev, and phi_{k+1} (N, divided by the output's half
 * range) is the filtered force (taps on the predicted sub-step forces and the committed ones of
 * the last n_past - 1 intervals, newest first) and the three intervals' mean forces. The output
 * at t_k reads the state only (strictly proper). Its state: x, the balls' positions, velocities
 * and attachments, the gate, the low-passed acceleration level, a_prev, u_{k-1}, the committed
 * sub-step forces and phi, all doubles.
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
#define SL_GREY 3

#define SL_HIDDEN_MATLAB 0
#define SL_HIDDEN_DISTANCE 1

typedef struct {
    int arch;             /* SL_NFIR, SL_NOE, SL_NSS or SL_GREY */
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
    int n_states;         /* NSS, GREY: dimension of x */
    /* NSS: nz = no = nx + 1; GREY: nz = nx + 5 (state, input, features), no = nx + 4 */
    const double *A, *W1, *b1, *W2;   /* (nz, nx), (nz, H), (H), (H, nx) */
    const double *C, *V1, *d1, *V2;   /* (no), (no, H), (H), (H) */
    /* GREY: the column */
    int n_balls, n_substeps, n_past;
    const double *physics;  /* mass (kg), stiffness (1/s^2), damping (1/s), gap (m),
                               gate_rate (1/s), gate_relaxation (s), coherence_g (g) */
    const double *taps;     /* ((n_past + 1) n_substeps): the output filter */
    double fs;              /* Hz: the sample rate the column's step reads */
    double g;               /* m/s^2: standard gravity */
    double coherence_time;  /* s: time constant of the coherence factor's acceleration level */
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
    int strictly_proper;      /* 1: dynamic_force at t_k is the model's force of t_{k-1}, held
                                 from the last step (a feed-through model exported strictly
                                 proper: no output reads an input of its own point) */
    int has_envelope;
    double input_min, input_max;        /* training range of the signal read */
    /* read-only parameters: NaN where the model does not know them */
    double acceleration_max, frequency_min, frequency_max, fill_min, fill_max;
} SlModel;

extern SL_INTERNAL const SlModel SL_MODEL;

/* doubles of state, of rest terms (constants of the NSS and GREY) and of scratch one member
 * needs */
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
 * (the NSS reuses its map F from there; GREY recomputes what it needs) */
SL_INTERNAL void sl_advance(const SlMember *m, double *state, const double *rest, double u,
                            double y_s, double *scratch);
/* physical output from the scaled one */
SL_INTERNAL double sl_unscale(const SlMember *m, double y_s);

#endif
