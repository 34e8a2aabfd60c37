// The grey box's shooting window as two XLA FFI handlers: the network's free run over a batch
// of sub-sequences (state steps and output map) and its reverse pass (backpropagation through
// time), float64 and float32; and, called from Python, the free run of a few long rows (a
// validation run, a prediction) one row at a time. Python side: sloshrom/rom/grey/kernel.py.
//
//   z_t = [x_t, seq_t]                       seq_t = [du_t, phi_t] (1 + nf features)
//   o_t = [x_t, phi_t]
//   y_t = phi_t[0] + o_t C + tanh(o_t V1 + d1) V2 - tanh(d1) V2
//   x_{t+1} = x_t + z_t A + tanh(z_t W1 + b1) W2 - tanh(b1) W2
//
// Layout: the batch is the last (contiguous) axis of every per-sample array, so that the
// innermost loops run over LANES batch rows with no dependence between them and the compiler
// vectorises them for any SIMD width. The rows of a block of LANES run through the whole window
// at once (their state stays in the first-level cache), and the blocks are shared among XLA's
// intra-op threads (run_blocks). Weight gradients are summed per lane first, across lanes at
// the end of a block, then over the blocks in their order: no floating-point reduction has to
// be reordered for the vector units (the build needs no -ffast-math), and the results are the
// same whatever the threads. The sums of a layer's outputs run several at once (8 neurons,
// 4 states), each over its terms in the same order as alone: independent chains keep the FMA
// units busy, and the results are those of one sum at a time to the bit.
//
// x86-64: the work of a block, forward and reverse, is compiled for the baseline ISA,
// x86-64-v3 (AVX2, FMA) and x86-64-v4 (AVX-512), and the loader picks the best the CPU has
// (GCC's function multiversioning); other compilers and CPUs get the baseline build.

#include <Python.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <new>
#include <thread>
#include <vector>

#include "xla/ffi/api/ffi.h"

namespace ffi = xla::ffi;

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && __GNUC__ >= 12
#define SL_CLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define SL_CLONES
#endif
#define SL_INLINE inline __attribute__((always_inline))

namespace {

// A block of batch rows: 64 bytes (one AVX-512 register, two AVX2 or four SSE2 ones; GCC's
// vector extension lowers it to what the target has).
template <typename T> constexpr int kLanes = 64 / sizeof(T);
template <typename T> struct Vec;
template <> struct Vec<double> {
  typedef double type __attribute__((vector_size(64)));
  typedef std::int64_t itype __attribute__((vector_size(64)));
  typedef std::int64_t I;
  static constexpr int kMant = 52, kBias = 1023, kDegree = 13;
  static constexpr double kClamp = 40.0;  // tanh(20) rounds to 1
};
template <> struct Vec<float> {
  typedef float type __attribute__((vector_size(64)));
  typedef std::int32_t itype __attribute__((vector_size(64)));
  typedef std::int32_t I;
  static constexpr int kMant = 23, kBias = 127, kDegree = 8;
  static constexpr float kClamp = 20.0f;  // tanh(10) rounds to 1
};
template <typename T> using V = typename Vec<T>::type;
// Working memory on whole cache lines. malloc aligns to 16 bytes: a block of lanes (64 bytes)
// then straddles two lines, and every vector load and store of it is split in two (the
// reverse pass ran 1.3-1.4x slower in processes whose working memory fell so).
template <typename T> struct LineAllocator {
  typedef T value_type;
  LineAllocator() = default;
  template <typename U> LineAllocator(const LineAllocator<U>&) {}
  T* allocate(std::size_t n) {
    return static_cast<T*>(::operator new(n * sizeof(T), std::align_val_t(64)));
  }
  void deallocate(T* p, std::size_t) { ::operator delete(p, std::align_val_t(64)); }
  template <typename U> bool operator==(const LineAllocator<U>&) const { return true; }
  template <typename U> bool operator!=(const LineAllocator<U>&) const { return false; }
};
template <typename T> using Lines = std::vector<T, LineAllocator<T>>;
// Samples of a block whose weight gradients are summed at once (their rows stay in L1).
constexpr int64_t kChunk = 8;

template <typename T> SL_INLINE V<T> load(const T* p) {
  V<T> v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
template <typename T> SL_INLINE void store(T* p, V<T> v) { std::memcpy(p, &v, sizeof v); }
template <typename T> SL_INLINE V<T> splat(T x) { return V<T>{} + x; }
template <typename T> SL_INLINE T hsum(V<T> v) {
  T s = 0;
  for (int l = 0; l < kLanes<T>; ++l) s += v[l];
  return s;
}

// 1 / d!
constexpr double kInvFactorial[14] = {
    1.0, 1.0, 1.0 / 2, 1.0 / 6, 1.0 / 24, 1.0 / 120, 1.0 / 720, 1.0 / 5040, 1.0 / 40320,
    1.0 / 362880, 1.0 / 3628800, 1.0 / 39916800, 1.0 / 479001600, 1.0 / 6227020800};

// tanh(x) = e / (e + 2), e = expm1(2|x|), with the sign of x: no cancellation near 0, a few
// ulp everywhere, branch-free on a block (libm's tanh is one call a row).
template <typename T> SL_INLINE V<T> tanh_v(V<T> x) {
  using W = Vec<T>;
  using IV = typename W::itype;
  using I = typename W::I;
  const IV sign_bit = IV{} + (I(1) << (8 * sizeof(T) - 1));
  const IV xb = reinterpret_cast<IV&>(x);
  const IV sgn = xb & sign_bit;
  IV ab = xb & ~sign_bit;
  const V<T> ax = reinterpret_cast<V<T>&>(ab);
  const V<T> a2 = ax + ax;
  const V<T> clamp = splat<T>(T(W::kClamp));
  const V<T> a = a2 < clamp ? a2 : clamp;
  const T shifter = T(1.5) * T(I(1) << W::kMant);  // rounds to an integer in the low bits
  const V<T> kd = a * T(1.4426950408889634) + shifter;
  const V<T> k = kd - shifter;
  // a - k ln2, ln2 in two parts (Cody-Waite): r exact to the last bits
  V<T> r = a - k * T(0.693145751953125);
  r = r - k * T(1.4286068203094173e-06);
  // expm1(r) on |r| <= ln2 / 2 by its Taylor series (terms beyond the degree below ulp/4),
  // r + r^2 (1/2! + r (1/3! + ...)) by Horner's rule
  V<T> q = splat<T>(T(kInvFactorial[W::kDegree]));
  for (int d = W::kDegree - 1; d >= 2; --d) q = q * r + T(kInvFactorial[d]);
  const V<T> p = r + (r * r) * q;
  T sh = shifter;
  I shb;
  std::memcpy(&shb, &sh, sizeof(T));
  const IV kb = reinterpret_cast<const IV&>(kd);
  IV e2 = (kb - shb + I(W::kBias)) << W::kMant;
  const V<T> sc = reinterpret_cast<V<T>&>(e2);
  const V<T> em1 = sc * p + (sc - T(1));  // 2^k expm1(r) + 2^k - 1: exact at k = 0
  V<T> t = em1 / (em1 + T(2));
  IV tb = reinterpret_cast<IV&>(t) | sgn;
  return reinterpret_cast<V<T>&>(tb);
}
template <typename T> SL_INLINE T tanh_s(T x) { return tanh_v<T>(splat<T>(x))[0]; }

// The weights and sizes of a window.
template <typename T> struct Net {
  const T *A, *W1, *b1, *W2, *C, *V1, *d1, *V2;
  int64_t nx, nf, n, T_, B;  // states, 1 + features, neurons, samples, batch (multiple of L)
  int64_t nz() const { return nx + nf; }
  int64_t no() const { return nx + nf - 1; }
};

// One tile of TI x TJ accumulators of outer_acc, in registers over the samples [t0, t1): each
// sums its terms in the order of t, whatever the tile's shape.
template <typename T, int TI, int TJ>
SL_INLINE void outer_tile(T* acc, int64_t ld, const T* a, int64_t sa_t, int64_t sa_i,
                          const T* b, int64_t sb_t, int64_t sb_j, int64_t i, int64_t j,
                          int64_t t0, int64_t t1) {
  constexpr int L = kLanes<T>;
  V<T> c[TI][TJ];
  for (int p = 0; p < TI; ++p)
    for (int q = 0; q < TJ; ++q) c[p][q] = load(acc + ((i + p) * ld + j + q) * L);
  for (int64_t t = t0; t < t1; ++t) {
    const T* at = a + t * sa_t + i * sa_i;
    const T* bt = b + t * sb_t + j * sb_j;
    V<T> av[TI], bv[TJ];
    for (int p = 0; p < TI; ++p) av[p] = load(at + p * sa_i);
    for (int q = 0; q < TJ; ++q) bv[q] = load(bt + q * sb_j);
    for (int p = 0; p < TI; ++p)
      for (int q = 0; q < TJ; ++q) c[p][q] += av[p] * bv[q];
  }
  for (int p = 0; p < TI; ++p)
    for (int q = 0; q < TJ; ++q) store(acc + ((i + p) * ld + j + q) * L, c[p][q]);
}

// The tiles of TI rows of a from row i on (a single row one accumulator at a time: fewer
// kinds of tiles to inline at each of the reverse pass's ten products).
template <typename T, int TI>
SL_INLINE void outer_rows(T* acc, int64_t ld, const T* a, int64_t sa_t, int64_t sa_i,
                          const T* b, int64_t nj, int64_t sb_t, int64_t sb_j, int64_t i,
                          int64_t t0, int64_t t1) {
  int64_t j = 0;
  if constexpr (TI > 1)
    for (; j + 4 <= nj; j += 4)
      outer_tile<T, TI, 4>(acc, ld, a, sa_t, sa_i, b, sb_t, sb_j, i, j, t0, t1);
  for (; j < nj; ++j) outer_tile<T, TI, 1>(acc, ld, a, sa_t, sa_i, b, sb_t, sb_j, i, j, t0, t1);
}

// acc[i, j] += sum_t a[t, i] b[t, j], lane by lane (acc: a block of lanes per (i, j), ld
// blocks a row), for t in [t0, t1): a's rows advance by (sa_t, sa_i) and b's by (sb_t, sb_j)
// elements, each row a block of lanes. Called on a few samples at a time (their rows are in
// the first-level cache). Tiles of 4 x 4 accumulators: 16 independent chains for the FMA
// units, 8 loads for 16 FMAs (tiles of 2 x 4 took 6 for 8 and ran the reverse pass 8 %
// slower). More kinds of tiles (8 x 1 for a column, 2 x 4 for the rows left) ran no faster
// and took the build from 21 to 45 s.
template <typename T>
SL_INLINE void outer_acc(T* acc, int64_t ld, const T* a, int64_t ni, int64_t sa_t, int64_t sa_i,
                         const T* b, int64_t nj, int64_t sb_t, int64_t sb_j, int64_t t0,
                         int64_t t1) {
  int64_t i = 0;
  for (; i + 4 <= ni; i += 4)
    outer_rows<T, 4>(acc, ld, a, sa_t, sa_i, b, nj, sb_t, sb_j, i, t0, t1);
  for (; i < ni; ++i) outer_rows<T, 1>(acc, ld, a, sa_t, sa_i, b, nj, sb_t, sb_j, i, t0, t1);
}

// act[j] = tanh(bias[j] + sum_i in_i W[i, j]) for the K neurons from j on, in_i the rows of
// two sets (ni0 rows at p0, ni1 at p1, s0 and s1 elements apart); act's rows act_ld apart. K
// sums at once, each in the order of i: K independent chains for the FMA units, the same
// arithmetic whatever K.
template <typename T, int K>
SL_INLINE void dense_tanh_block(T* act, int64_t act_ld, const T* W, const T* bias, int64_t n,
                                int64_t j, const T* p0, int64_t ni0, int64_t s0, const T* p1,
                                int64_t ni1, int64_t s1) {
  V<T> c[K];
  for (int q = 0; q < K; ++q) c[q] = splat(bias[j + q]);
  for (int64_t i = 0; i < ni0 + ni1; ++i) {
    const V<T> v = load(i < ni0 ? p0 + i * s0 : p1 + (i - ni0) * s1);
    const T* w = W + i * n + j;
    for (int q = 0; q < K; ++q) c[q] += v * w[q];
  }
  for (int q = 0; q < K; ++q) store(act + (j + q) * act_ld, tanh_v<T>(c[q]));
}

template <typename T>
SL_INLINE void dense_tanh(T* act, int64_t act_ld, const T* W, const T* bias, int64_t n,
                          const T* p0, int64_t ni0, int64_t s0, const T* p1, int64_t ni1,
                          int64_t s1) {
  int64_t j = 0;
  for (; j + 8 <= n; j += 8)
    dense_tanh_block<T, 8>(act, act_ld, W, bias, n, j, p0, ni0, s0, p1, ni1, s1);
  for (; j + 4 <= n; j += 4)
    dense_tanh_block<T, 4>(act, act_ld, W, bias, n, j, p0, ni0, s0, p1, ni1, s1);
  for (; j < n; ++j)
    dense_tanh_block<T, 1>(act, act_ld, W, bias, n, j, p0, ni0, s0, p1, ni1, s1);
}

// The next state of the K states from k on: x_k - f0_k + sum_i z_i A[i, k] + sum_j h_j W2[j, k]
// (K sums at once, each in the order of its terms).
template <typename T, int K>
SL_INLINE void next_state(const Net<T>& m, int64_t k, const T* xt, const T* s, const T* h,
                          const T* f0, T* xv) {
  constexpr int L = kLanes<T>;
  const int64_t nx = m.nx, B = m.B;
  V<T> c[K];
  for (int q = 0; q < K; ++q) c[q] = load(xt + (k + q) * L) - f0[k + q];
  for (int64_t i = 0; i < nx; ++i) {
    const V<T> v = load(xt + i * L);
    for (int q = 0; q < K; ++q) c[q] += v * m.A[i * nx + k + q];
  }
  for (int64_t i = 0; i < m.nf; ++i) {
    const V<T> v = load(s + i * B);
    for (int q = 0; q < K; ++q) c[q] += v * m.A[(nx + i) * nx + k + q];
  }
  for (int64_t j = 0; j < m.n; ++j) {
    const V<T> v = load(h + j * L);
    for (int q = 0; q < K; ++q) c[q] += v * m.W2[j * nx + k + q];
  }
  for (int q = 0; q < K; ++q) store(xv + (k + q) * L, c[q]);
}

// The free run's constant terms: f0 = tanh(b1) W2 (nx) and h0 = tanh(d1) V2.
template <typename T> struct Forward {
  Net<T> m;
  const T *x0, *seq;
  T *y, *xs, *hs, *gs;
  std::vector<T> f0;
  T h0;
};

// The free run of block blk of LANES rows: y (T, B), and the states xs and activations hs, gs
// the reverse pass reads ((B / L, T, nx or n, L): a block's are contiguous, read back in one
// sweep); xv: the block's state (nx L).
template <typename T>
SL_INLINE void forward_block(const Forward<T>& f, T* xv, int64_t blk) {
  constexpr int L = kLanes<T>;
  const Net<T>& m = f.m;
  const int64_t nx = m.nx, nf = m.nf, n = m.n, B = m.B, b0 = blk * L;
  for (int64_t k = 0; k < nx; ++k) store(xv + k * L, load(f.x0 + k * B + b0));
  for (int64_t t = 0; t < m.T_; ++t) {
    const T* s = f.seq + t * nf * B + b0;
    T* xt = f.xs + (blk * m.T_ + t) * nx * L;
    T* h = f.hs + (blk * m.T_ + t) * n * L;
    T* g = f.gs + (blk * m.T_ + t) * n * L;
    for (int64_t k = 0; k < nx; ++k) store(xt + k * L, load(xv + k * L));
    // output map on o = [x, phi]
    dense_tanh<T>(g, L, m.V1, m.d1, n, xt, nx, L, s + B, nf - 1, B);
    V<T> yv = load(s + B) - f.h0;
    for (int64_t i = 0; i < nx; ++i) yv += load(xt + i * L) * m.C[i];
    for (int64_t i = 0; i < nf - 1; ++i) yv += load(s + (1 + i) * B) * m.C[nx + i];
    for (int64_t j = 0; j < n; ++j) yv += load(g + j * L) * m.V2[j];
    store(f.y + t * B + b0, yv);
    // state map on z = [x, du, phi]
    dense_tanh<T>(h, L, m.W1, m.b1, n, xt, nx, L, s, nf, B);
    int64_t k = 0;
    for (; k + 4 <= nx; k += 4) next_state<T, 4>(m, k, xt, s, h, f.f0.data(), xv);
    for (; k < nx; ++k) next_state<T, 1>(m, k, xt, s, h, f.f0.data(), xv);
  }
}

// The free run's constant terms: f0 = tanh(b1) W2 added into f0 (nx, zeros), h0 = tanh(d1) V2
// returned
template <typename T> T rest_terms(const Net<T>& m, T* f0) {
  T h0 = 0;
  for (int64_t j = 0; j < m.n; ++j) {
    const T tb = tanh_s(m.b1[j]);
    for (int64_t k = 0; k < m.nx; ++k) f0[k] += tb * m.W2[j * m.nx + k];
    h0 += tanh_s(m.d1[j]) * m.V2[j];
  }
  return h0;
}

template <typename T> Forward<T> forward_of(const Net<T>& m, const T* x0, const T* seq, T* y,
                                            T* xs, T* hs, T* gs) {
  Forward<T> f{m, x0, seq, y, xs, hs, gs, std::vector<T>(m.nx, T(0)), T(0)};
  f.h0 = rest_terms(m, f.f0.data());
  return f;
}

// The reverse pass's gradients of the K pre-activations from neuron j on: the state map's
// da = (dxn W2^T)(1 - h^2) and the output map's dg = dy V2 (1 - g^2), with their running sums
// (K sums at once, each in the order of its terms).
template <typename T, int K>
SL_INLINE void pre_gradients(const Net<T>& m, int64_t j, const T* dxt, const T* h, const T* g,
                             V<T> dyt, T* dat, T* dgt, T* s_da, T* s_dg) {
  constexpr int L = kLanes<T>;
  V<T> c[K] = {};
  for (int64_t k = 0; k < m.nx; ++k) {
    const V<T> v = load(dxt + k * L);
    for (int q = 0; q < K; ++q) c[q] += v * m.W2[(j + q) * m.nx + k];
  }
  for (int q = 0; q < K; ++q) {
    const int64_t jq = j + q;
    const V<T> hv = load(h + jq * L);
    const V<T> gv = load(g + jq * L);
    const V<T> daj = c[q] * (T(1) - hv * hv);
    const V<T> dgj = dyt * m.V2[jq] * (T(1) - gv * gv);
    store(dat + jq * L, daj);
    store(dgt + jq * L, dgj);
    store(s_da + jq * L, load(s_da + jq * L) + daj);
    store(s_dg + jq * L, load(s_dg + jq * L) + dgj);
  }
}

// The gradient of the K states from k on at the step before: dx_{t+1} + dy C + dxn A^T +
// da W1^T + dg V1^T (K sums at once, each in the order of its terms).
template <typename T, int K>
SL_INLINE void state_gradient(const Net<T>& m, int64_t k, const T* dxt, const T* dat,
                              const T* dgt, V<T> dyt, T* dx) {
  constexpr int L = kLanes<T>;
  const int64_t nx = m.nx, n = m.n;
  V<T> c[K];
  for (int q = 0; q < K; ++q) c[q] = load(dxt + (k + q) * L) + dyt * m.C[k + q];
  for (int64_t i = 0; i < nx; ++i) {
    const V<T> v = load(dxt + i * L);
    for (int q = 0; q < K; ++q) c[q] += v * m.A[(k + q) * nx + i];
  }
  for (int64_t j = 0; j < n; ++j) {
    const V<T> a = load(dat + j * L), d = load(dgt + j * L);
    for (int q = 0; q < K; ++q) c[q] += a * m.W1[(k + q) * n + j] + d * m.V1[(k + q) * n + j];
  }
  for (int q = 0; q < K; ++q) store(dx + (k + q) * L, c[q]);
}

// The reverse pass's inputs and its per-block results: the weights' gradients and the sums
// the biases' gradients and the rest terms need, one row of P per block (summed over the
// blocks in their order at the end: the same numbers whichever thread ran a block).
template <typename T> struct Backward {
  Net<T> m;
  const T *seq, *xs, *hs, *gs, *dy;
  T* dx0;
  T* totals;  // (B / L, P)
  int64_t P() const {
    const int64_t nx = m.nx, n = m.n, nz = m.nz(), no = m.no();
    return nz * nx + nz * n + n * nx + no * n + no + n + 2 * n + nx + 1;
  }
};

// A thread's working memory for the reverse pass of a block.
template <typename T> struct BackwardScratch {
  Lines<T> dxn, da, dg, dyb, sq, lanes, dxbuf, sums;
  explicit BackwardScratch(const Net<T>& m) {
    constexpr int L = kLanes<T>;
    const int64_t nx = m.nx, nf = m.nf, n = m.n, TT = m.T_, nz = m.nz(), no = m.no();
    dxn.resize(TT * nx * L);
    da.resize(TT * n * L);
    dg.resize(TT * n * L);
    dyb.resize(TT * L);
    sq.resize(TT * nf * L);
    lanes.resize((nz * nx + nz * n + n * nx + no * n + no + n) * L);
    dxbuf.resize(nx * L);
    sums.resize((2 * n + nx + 1) * L);
  }
};

// The reverse pass of block blk from dy (T, B): its rows of dx0 (nx, B), and its row of
// totals: the weights' gradients (A, W1, W2, V1, C, V2), then the sums of da, dg, dxn and dy.
template <typename T>
SL_INLINE void backward_block(const Backward<T>& r, BackwardScratch<T>& w, int64_t blk) {
  constexpr int L = kLanes<T>;
  const Net<T>& m = r.m;
  const int64_t nx = m.nx, nf = m.nf, n = m.n, B = m.B, TT = m.T_, b0 = blk * L;
  const int64_t nz = m.nz(), no = m.no();
  // the gradients at each sample of the next state (dxn), of the state map's and the output
  // map's pre-activations (da, dg), and dy, one block of lanes a row; the block's inputs and
  // features; the weights' gradients lane by lane (summed across lanes at the end)
  std::fill(w.lanes.begin(), w.lanes.end(), T(0));
  std::fill(w.sums.begin(), w.sums.end(), T(0));
  T* gA = w.lanes.data();
  T* gW1 = gA + nz * nx * L;
  T* gW2 = gW1 + nz * n * L;
  T* gV1 = gW2 + n * nx * L;
  T* gC = gV1 + no * n * L;
  T* gV2 = gC + no * L;
  // the running gradient of the state, and the sums of da, dg, dxn and dy (the biases' and
  // the rest terms' gradients), one block of lanes a row
  T* dx = w.dxbuf.data();
  T* s_da = w.sums.data();
  T* s_dg = s_da + n * L;
  T* s_dxn = s_dg + n * L;
  T* s_dy = s_dxn + nx * L;
  for (int64_t t = 0; t < TT; ++t)
    for (int64_t i = 0; i < nf; ++i)
      store(w.sq.data() + (t * nf + i) * L, load(r.seq + (t * nf + i) * B + b0));
  for (int64_t k = 0; k < nx * L; ++k) dx[k] = 0;
  for (int64_t t = TT - 1; t >= 0; --t) {
    const T* h = r.hs + (blk * TT + t) * n * L;
    const T* g = r.gs + (blk * TT + t) * n * L;
    T* dxt = w.dxn.data() + t * nx * L;
    T* dat = w.da.data() + t * n * L;
    T* dgt = w.dg.data() + t * n * L;
    const V<T> dyt = load(r.dy + t * B + b0);
    store(w.dyb.data() + t * L, dyt);
    store(s_dy, load(s_dy) + dyt);
    for (int64_t k = 0; k < nx; ++k) {
      const V<T> d = load(dx + k * L);
      store(dxt + k * L, d);
      store(s_dxn + k * L, load(s_dxn + k * L) + d);
    }
    // state map: da = (dxn W2^T) (1 - h^2); output map: dg = dy V2 (1 - g^2)
    int64_t j = 0;
    for (; j + 4 <= n; j += 4) pre_gradients<T, 4>(m, j, dxt, h, g, dyt, dat, dgt, s_da, s_dg);
    for (; j < n; ++j) pre_gradients<T, 1>(m, j, dxt, h, g, dyt, dat, dgt, s_da, s_dg);
    // dx_t = dx_{t+1} + dz[:nx] + do[:nx]
    int64_t k = 0;
    for (; k + 4 <= nx; k += 4) state_gradient<T, 4>(m, k, dxt, dat, dgt, dyt, dx);
    for (; k < nx; ++k) state_gradient<T, 1>(m, k, dxt, dat, dgt, dyt, dx);
    // the weights' gradients of the last few samples, while their rows are in the cache
    if (t % kChunk == 0) {
      const int64_t t1 = t + kChunk < TT ? t + kChunk : TT;
      const T* xb = r.xs + blk * TT * nx * L;
      const T* hb = r.hs + blk * TT * n * L;
      const T* gb = r.gs + blk * TT * n * L;
      const T* sb = w.sq.data();
      const T* dn = w.dxn.data();
      const T* dab = w.da.data();
      const T* dgb = w.dg.data();
      const T* dyb = w.dyb.data();
      outer_acc<T>(gA, nx, xb, nx, nx * L, L, dn, nx, nx * L, L, t, t1);
      outer_acc<T>(gA + nx * nx * L, nx, sb, nf, nf * L, L, dn, nx, nx * L, L, t, t1);
      outer_acc<T>(gW1, n, xb, nx, nx * L, L, dab, n, n * L, L, t, t1);
      outer_acc<T>(gW1 + nx * n * L, n, sb, nf, nf * L, L, dab, n, n * L, L, t, t1);
      outer_acc<T>(gW2, nx, hb, n, n * L, L, dn, nx, nx * L, L, t, t1);
      outer_acc<T>(gV1, n, xb, nx, nx * L, L, dgb, n, n * L, L, t, t1);
      outer_acc<T>(gV1 + nx * n * L, n, sb + L, nf - 1, nf * L, L, dgb, n, n * L, L, t, t1);
      outer_acc<T>(gC, 1, xb, nx, nx * L, L, dyb, 1, L, L, t, t1);
      outer_acc<T>(gC + nx * L, 1, sb + L, nf - 1, nf * L, L, dyb, 1, L, L, t, t1);
      outer_acc<T>(gV2, 1, gb, n, n * L, L, dyb, 1, L, L, t, t1);
    }
  }
  for (int64_t k = 0; k < nx; ++k) store(r.dx0 + k * B + b0, load(dx + k * L));
  // the lanes' sums: the weights' gradients, then da, dg, dxn and dy (the layout of P)
  T* tot = r.totals + blk * r.P();
  const int64_t nw = nz * nx + nz * n + n * nx + no * n + no + n;
  for (int64_t i = 0; i < nw; ++i) tot[i] = hsum<T>(load(w.lanes.data() + i * L));
  for (int64_t i = 0; i < 2 * n + nx + 1; ++i) tot[nw + i] = hsum<T>(load(s_da + i * L));
}

// The blocks' totals summed in their order into the eight weights' gradients, with the rest
// terms -tanh(b1) W2 and -tanh(d1) V2 of every sample.
template <typename T>
void backward_totals(const Backward<T>& r, T* dA, T* dW1, T* db1, T* dW2, T* dC, T* dV1,
                     T* dd1, T* dV2) {
  const Net<T>& m = r.m;
  const int64_t nx = m.nx, n = m.n, nz = m.nz(), no = m.no(), P = r.P();
  const int64_t blocks = m.B / kLanes<T>;
  std::vector<T> sum(P, T(0));
  for (int64_t blk = 0; blk < blocks; ++blk)
    for (int64_t i = 0; i < P; ++i) sum[i] += r.totals[blk * P + i];
  const T* s = sum.data();
  for (int64_t i = 0; i < nz * nx; ++i) dA[i] = *s++;
  for (int64_t i = 0; i < nz * n; ++i) dW1[i] = *s++;
  for (int64_t i = 0; i < n * nx; ++i) dW2[i] = *s++;
  for (int64_t i = 0; i < no * n; ++i) dV1[i] = *s++;
  for (int64_t i = 0; i < no; ++i) dC[i] = *s++;
  for (int64_t j = 0; j < n; ++j) dV2[j] = *s++;
  const T* s_da = s;
  const T* s_dg = s_da + n;
  const T* sum_dxn = s_dg + n;
  const T sum_dy = sum_dxn[nx];
  for (int64_t j = 0; j < n; ++j) {
    db1[j] = s_da[j];
    dd1[j] = s_dg[j];
    const T tb = tanh_s(m.b1[j]);
    T v = 0;
    for (int64_t k = 0; k < nx; ++k) {
      dW2[j * nx + k] -= tb * sum_dxn[k];
      v += m.W2[j * nx + k] * sum_dxn[k];
    }
    db1[j] -= (T(1) - tb * tb) * v;
    const T td = tanh_s(m.d1[j]);
    dV2[j] -= td * sum_dy;
    dd1[j] -= (T(1) - td * td) * m.V2[j] * sum_dy;
  }
}

// The free run of a few long rows (a validation run, a prediction): one row at a time, the
// neurons as the vector axis (a block of LANES rows would run one row in LANES lanes). Not
// differentiated, and called from Python (free_run below), not inside an XLA computation. The
// weights are copied, padded with zeros to whole vectors of neurons (np) and of states (npx):
// a padded neuron's tanh(0) = 0 reaches no state and no output, a padded state stays zero.
template <typename T> struct RowNet {
  int64_t nx, nf, n, np, npx;
  Lines<T> W1, b1, V1, d1, V2, A, W2, C, f0;
  T h0;
  explicit RowNet(const Net<T>& m)
      : nx(m.nx), nf(m.nf), n(m.n),
        np((m.n + kLanes<T> - 1) / kLanes<T> * kLanes<T>),
        npx((m.nx + kLanes<T> - 1) / kLanes<T> * kLanes<T>) {
    const int64_t nz = m.nz(), no = m.no();
    W1.assign(nz * np, T(0));
    V1.assign(no * np, T(0));
    b1.assign(np, T(0));
    d1.assign(np, T(0));
    V2.assign(np, T(0));
    A.assign(nz * npx, T(0));
    W2.assign(np * npx, T(0));
    f0.assign(npx, T(0));
    C.assign(m.C, m.C + no);
    for (int64_t i = 0; i < nz; ++i)
      for (int64_t j = 0; j < n; ++j) W1[i * np + j] = m.W1[i * n + j];
    for (int64_t i = 0; i < no; ++i)
      for (int64_t j = 0; j < n; ++j) V1[i * np + j] = m.V1[i * n + j];
    for (int64_t i = 0; i < nz; ++i)
      for (int64_t k = 0; k < nx; ++k) A[i * npx + k] = m.A[i * nx + k];
    for (int64_t j = 0; j < n; ++j) {
      b1[j] = m.b1[j];
      d1[j] = m.d1[j];
      V2[j] = m.V2[j];
      for (int64_t k = 0; k < nx; ++k) W2[j * npx + k] = m.W2[j * nx + k];
    }
    h0 = rest_terms(m, f0.data());
  }
};

// out = tanh(bias + sum_i in_i W[i, :]) for the K vectors of neurons from v on, in_ the n0
// values at p0 then the n1 at p1 (K independent sums)
template <typename T, int K>
SL_INLINE void row_dense_tanh_block(T* out, const T* W, const T* bias, int64_t np, int64_t v,
                                    const T* p0, int64_t n0, const T* p1, int64_t n1) {
  constexpr int L = kLanes<T>;
  V<T> c[K];
  for (int q = 0; q < K; ++q) c[q] = load(bias + v + q * L);
  for (int64_t i = 0; i < n0 + n1; ++i) {
    const T zi = i < n0 ? p0[i] : p1[i - n0];
    const T* w = W + i * np + v;
    for (int q = 0; q < K; ++q) c[q] += zi * load(w + q * L);
  }
  for (int q = 0; q < K; ++q) store(out + v + q * L, tanh_v<T>(c[q]));
}

template <typename T>
SL_INLINE void row_dense_tanh(T* out, const T* W, const T* bias, int64_t np, const T* p0,
                              int64_t n0, const T* p1, int64_t n1) {
  constexpr int L = kLanes<T>;
  int64_t v = 0;
  for (; v + 4 * L <= np; v += 4 * L)
    row_dense_tanh_block<T, 4>(out, W, bias, np, v, p0, n0, p1, n1);
  for (; v < np; v += L) row_dense_tanh_block<T, 1>(out, W, bias, np, v, p0, n0, p1, n1);
}

// The free run of one row from x0 (nx) over seq (T, nf: [du, phi] a sample) into y (T);
// scratch: 2 npx + 2 np values.
template <typename T>
SL_INLINE void row_run(const RowNet<T>& r, const T* x0, const T* seq, int64_t TT, T* y,
                       T* scratch) {
  constexpr int L = kLanes<T>;
  const int64_t nx = r.nx, nf = r.nf, np = r.np, npx = r.npx;
  T* x = scratch;
  T* xn = x + npx;
  T* h = xn + npx;
  T* g = h + np;
  std::fill(x, x + npx, T(0));
  std::copy(x0, x0 + nx, x);
  for (int64_t t = 0; t < TT; ++t) {
    const T* s = seq + t * nf;
    // output map on o = [x, phi]
    row_dense_tanh<T>(g, r.V1.data(), r.d1.data(), np, x, nx, s + 1, nf - 1);
    V<T> yv{};
    for (int64_t v = 0; v < np; v += L) yv += load(g + v) * load(r.V2.data() + v);
    T ys = hsum<T>(yv);
    for (int64_t i = 0; i < nx; ++i) ys += x[i] * r.C[i];
    for (int64_t i = 0; i < nf - 1; ++i) ys += s[1 + i] * r.C[nx + i];
    y[t] = (s[1] - r.h0) + ys;
    // state map on z = [x, du, phi]; the next state in four partial sums (short chains)
    row_dense_tanh<T>(h, r.W1.data(), r.b1.data(), np, x, nx, s, nf);
    for (int64_t u = 0; u < npx; u += L) {
      V<T> c0 = load(x + u) - load(r.f0.data() + u), c1{}, c2{}, c3{};
      for (int64_t i = 0; i < nx; ++i) c1 += x[i] * load(r.A.data() + i * npx + u);
      for (int64_t i = 0; i < nf; ++i) c1 += s[i] * load(r.A.data() + (nx + i) * npx + u);
      for (int64_t j = 0; j < np; j += 2) {
        c2 += h[j] * load(r.W2.data() + j * npx + u);
        c3 += h[j + 1] * load(r.W2.data() + (j + 1) * npx + u);
      }
      store(xn + u, (c0 + c1) + (c2 + c3));
    }
    std::swap(x, xn);
  }
}

SL_CLONES void row_run_f64(const RowNet<double>& r, const double* x0, const double* seq,
                           int64_t TT, double* y, double* scratch) {
  row_run<double>(r, x0, seq, TT, y, scratch);
}

// The blocks' work compiled for each ISA (the loader picks the best the CPU has); the
// threads that run it are not
SL_CLONES void forward_block_f64(const Forward<double>& f, double* xv, int64_t blk) {
  forward_block<double>(f, xv, blk);
}
SL_CLONES void forward_block_f32(const Forward<float>& f, float* xv, int64_t blk) {
  forward_block<float>(f, xv, blk);
}
SL_CLONES void backward_block_f64(const Backward<double>& r, BackwardScratch<double>& w,
                                  int64_t blk) {
  backward_block<double>(r, w, blk);
}
SL_CLONES void backward_block_f32(const Backward<float>& r, BackwardScratch<float>& w,
                                  int64_t blk) {
  backward_block<float>(r, w, blk);
}

template <typename T> void run_block(const Forward<T>& f, Lines<T>& xv, int64_t blk) {
  if constexpr (sizeof(T) == 8) forward_block_f64(f, xv.data(), blk);
  else forward_block_f32(f, xv.data(), blk);
}
template <typename T> void run_block(const Backward<T>& r, BackwardScratch<T>& w, int64_t blk) {
  if constexpr (sizeof(T) == 8) backward_block_f64(r, w, blk);
  else backward_block_f32(r, w, blk);
}
template <typename T> Lines<T> scratch_of(const Forward<T>& f) {
  return Lines<T>(f.m.nx * kLanes<T>);
}
template <typename T> BackwardScratch<T> scratch_of(const Backward<T>& r) {
  return BackwardScratch<T>(r.m);
}

// The blocks handed out one at a time: the next unclaimed one to whichever thread asks, and
// how many are done. Shared by the tasks (a task that starts after the call has returned
// finds none left and touches nothing else).
struct Claims {
  std::atomic<int64_t> next{0}, done{0}, threads{0};
  int64_t n = 0;
};
// The threads that ran blocks in the last call and the threads of the pool it was given
// (threads_used(), pool_threads(): what the tests check).
std::atomic<int64_t> g_threads_used{0}, g_pool_threads{0};

// Runs block b of job from b on, then every block it claims, with its own working memory. It
// claims the next block before it says the current one is done: while it holds a claim the
// caller waits, so the job is alive whenever a block runs.
template <typename Job> void drain(Claims& c, const Job& job, int64_t b) {
  c.threads.fetch_add(1, std::memory_order_relaxed);
  auto scratch = scratch_of(job);
  for (;;) {
    run_block(job, scratch, b);
    const int64_t next = c.next.fetch_add(1, std::memory_order_relaxed);
    c.done.fetch_add(1, std::memory_order_release);
    if (next >= c.n) return;
    b = next;
  }
}

// Every block of job, on this thread and on as many of XLA's intra-op threads as there are
// (its CPU client's pool: one thread in a worker limited to one core). Each block's results
// are its own, so they do not depend on the threads. The caller never waits for a task that
// has not started (it runs the unclaimed blocks itself), so a pool busy elsewhere or a single
// thread cannot deadlock it.
template <typename Job> void run_blocks(ffi::ThreadPool& pool, int64_t n, const Job& job) {
  auto c = std::make_shared<Claims>();
  c->n = n;
  g_pool_threads.store(pool.num_threads(), std::memory_order_relaxed);
  const int64_t helpers = std::min<int64_t>(pool.num_threads(), n) - 1;
  const Job* jp = &job;
  for (int64_t h = 0; h < helpers; ++h)
    pool.Schedule([c, jp] {
      const int64_t b = c->next.fetch_add(1, std::memory_order_relaxed);
      if (b < c->n) drain(*c, *jp, b);
    });
  const int64_t b = c->next.fetch_add(1, std::memory_order_relaxed);
  if (b < n) drain(*c, job, b);
  while (c->done.load(std::memory_order_acquire) < n) std::this_thread::yield();
  g_threads_used.store(c->threads.load(std::memory_order_relaxed), std::memory_order_relaxed);
}

template <ffi::DataType DT> using Buf = ffi::Buffer<DT>;
template <ffi::DataType DT> using Out = ffi::ResultBuffer<DT>;

// The sizes from the arrays' shapes, checked against each other.
template <ffi::DataType DT>
ffi::Error net_of(Net<ffi::NativeType<DT>>& m, Buf<DT> A, Buf<DT> W1, Buf<DT> b1, Buf<DT> W2,
                                               Buf<DT> C, Buf<DT> V1, Buf<DT> d1, Buf<DT> V2,
                                               Buf<DT> seq) {
  using T = ffi::NativeType<DT>;
  auto da = A.dimensions(), dw1 = W1.dimensions(), ds = seq.dimensions();
  if (da.size() != 2 || dw1.size() != 2 || ds.size() != 3)
    return ffi::Error::InvalidArgument("grey window: A, W1 of rank 2 and seq of rank 3");
  m = Net<T>{A.typed_data(), W1.typed_data(), b1.typed_data(), W2.typed_data(),
           C.typed_data(), V1.typed_data(), d1.typed_data(), V2.typed_data(),
           da[1], ds[1], dw1[1], ds[0], ds[2]};
  if (da[0] != m.nz() || dw1[0] != m.nz() || int64_t(b1.element_count()) != m.n ||
      int64_t(W2.element_count()) != m.n * m.nx || int64_t(C.element_count()) != m.no() ||
      int64_t(V1.element_count()) != m.no() * m.n || int64_t(d1.element_count()) != m.n ||
      int64_t(V2.element_count()) != m.n || m.nf < 2)
    return ffi::Error::InvalidArgument("grey window: inconsistent weight shapes");
  if (m.B % kLanes<T> != 0)
    return ffi::Error::InvalidArgument("grey window: batch not a multiple of 16");
  return ffi::Error::Success();
}

template <ffi::DataType DT>
ffi::Error forward_impl(ffi::ThreadPool pool, Buf<DT> A, Buf<DT> W1, Buf<DT> b1, Buf<DT> W2,
                        Buf<DT> C, Buf<DT> V1, Buf<DT> d1, Buf<DT> V2, Buf<DT> x0, Buf<DT> seq,
                        Out<DT> y, Out<DT> xs, Out<DT> hs, Out<DT> gs) {
  using T = ffi::NativeType<DT>;
  Net<T> m;
  ffi::Error err = net_of<DT>(m, A, W1, b1, W2, C, V1, d1, V2, seq);
  if (err.failure()) return err;
  const Forward<T> f = forward_of<T>(m, x0.typed_data(), seq.typed_data(), y->typed_data(),
                                     xs->typed_data(), hs->typed_data(), gs->typed_data());
  run_blocks(pool, m.B / kLanes<T>, f);
  return ffi::Error::Success();
}

template <ffi::DataType DT>
ffi::Error backward_impl(ffi::ThreadPool pool, Buf<DT> A, Buf<DT> W1, Buf<DT> b1, Buf<DT> W2,
                         Buf<DT> C, Buf<DT> V1, Buf<DT> d1, Buf<DT> V2, Buf<DT> seq,
                         Buf<DT> xs, Buf<DT> hs, Buf<DT> gs, Buf<DT> dy, Out<DT> dA,
                         Out<DT> dW1, Out<DT> db1, Out<DT> dW2, Out<DT> dC, Out<DT> dV1,
                         Out<DT> dd1, Out<DT> dV2, Out<DT> dx0) {
  using T = ffi::NativeType<DT>;
  Net<T> m;
  ffi::Error err = net_of<DT>(m, A, W1, b1, W2, C, V1, d1, V2, seq);
  if (err.failure()) return err;
  Backward<T> r{m, seq.typed_data(), xs.typed_data(), hs.typed_data(), gs.typed_data(),
                dy.typed_data(), dx0->typed_data(), nullptr};
  const int64_t blocks = m.B / kLanes<T>;
  std::vector<T> totals(blocks * r.P());
  r.totals = totals.data();
  run_blocks(pool, blocks, r);
  backward_totals(r, dA->typed_data(), dW1->typed_data(), db1->typed_data(), dW2->typed_data(),
                  dC->typed_data(), dV1->typed_data(), dd1->typed_data(), dV2->typed_data());
  return ffi::Error::Success();
}

#define SL_ARG(DT) .Arg<ffi::Buffer<DT>>()
#define SL_RET(DT) .Ret<ffi::Buffer<DT>>()
#define SL_FORWARD_BINDING(DT)                                                           \
  ffi::Ffi::Bind().Ctx<ffi::ThreadPool>() SL_ARG(DT) SL_ARG(DT) SL_ARG(DT) SL_ARG(DT) SL_ARG(DT) SL_ARG(DT)     \
      SL_ARG(DT) SL_ARG(DT) SL_ARG(DT) SL_ARG(DT) SL_RET(DT) SL_RET(DT) SL_RET(DT)       \
          SL_RET(DT)
#define SL_BACKWARD_BINDING(DT)                                                          \
  ffi::Ffi::Bind().Ctx<ffi::ThreadPool>() SL_ARG(DT) SL_ARG(DT) SL_ARG(DT) SL_ARG(DT) SL_ARG(DT) SL_ARG(DT)     \
      SL_ARG(DT) SL_ARG(DT) SL_ARG(DT) SL_ARG(DT) SL_ARG(DT) SL_ARG(DT) SL_ARG(DT)       \
          SL_RET(DT) SL_RET(DT) SL_RET(DT) SL_RET(DT) SL_RET(DT) SL_RET(DT) SL_RET(DT)   \
              SL_RET(DT) SL_RET(DT)

}  // namespace

XLA_FFI_DEFINE_HANDLER_SYMBOL(SlGreyForwardF64, forward_impl<ffi::F64>,
                              SL_FORWARD_BINDING(ffi::F64));
XLA_FFI_DEFINE_HANDLER_SYMBOL(SlGreyForwardF32, forward_impl<ffi::F32>,
                              SL_FORWARD_BINDING(ffi::F32));
XLA_FFI_DEFINE_HANDLER_SYMBOL(SlGreyBackwardF64, backward_impl<ffi::F64>,
                              SL_BACKWARD_BINDING(ffi::F64));
XLA_FFI_DEFINE_HANDLER_SYMBOL(SlGreyBackwardF32, backward_impl<ffi::F32>,
                              SL_BACKWARD_BINDING(ffi::F32));

// The module: handlers() -> {target name: capsule}, for jax.ffi.register_ffi_target.
namespace {
PyObject* capsule(XLA_FFI_Error* (*fn)(XLA_FFI_CallFrame*)) {
  return PyCapsule_New(reinterpret_cast<void*>(fn), nullptr, nullptr);
}

PyObject* handlers(PyObject*, PyObject*) {
  PyObject* d = PyDict_New();
  if (d == nullptr) return nullptr;
  const struct {
    const char* name;
    XLA_FFI_Error* (*fn)(XLA_FFI_CallFrame*);
  } table[] = {{"sloshrom_grey_forward_f64", SlGreyForwardF64},
               {"sloshrom_grey_forward_f32", SlGreyForwardF32},
               {"sloshrom_grey_backward_f64", SlGreyBackwardF64},
               {"sloshrom_grey_backward_f32", SlGreyBackwardF32}};
  for (const auto& e : table) {
    PyObject* c = capsule(e.fn);
    if (c == nullptr || PyDict_SetItemString(d, e.name, c) != 0) {
      Py_XDECREF(c);
      Py_DECREF(d);
      return nullptr;
    }
    Py_DECREF(c);
  }
  return d;
}

// free_run(A, W1, b1, W2, C, V1, d1, V2, x0, seq, y, nx, nf, n, T, B): the float64 free run
// of B rows (row_run), seq (B, T, nf) with du = the scaled input minus its rest, y (B, T)
// written; every array C-contiguous float64 of its size (checked here by byte count, by
// shape in kernel.py). The GIL is released while it runs.
PyObject* free_run(PyObject*, PyObject* args) {
  constexpr int kBufs = 11;
  Py_buffer b[kBufs] = {};
  long long nx, nf, n, TT, B;
  if (!PyArg_ParseTuple(args, "y*y*y*y*y*y*y*y*y*y*w*LLLLL", &b[0], &b[1], &b[2], &b[3],
                        &b[4], &b[5], &b[6], &b[7], &b[8], &b[9], &b[10], &nx, &nf, &n, &TT,
                        &B))
    return nullptr;
  auto release = [&b] {
    for (auto& v : b)
      if (v.obj != nullptr) PyBuffer_Release(&v);
  };
  const long long nz = nx + nf, no = nx + nf - 1;
  const long long want[kBufs] = {nz * nx, nz * n, n, n * nx, no, no * n, n, n, B * nx,
                                 B * TT * nf, B * TT};
  bool ok = nx > 0 && nf >= 2 && n > 0 && TT >= 0 && B >= 0;
  for (int i = 0; ok && i < kBufs; ++i)
    ok = b[i].len == Py_ssize_t(want[i] * sizeof(double));
  if (!ok) {
    release();
    PyErr_SetString(PyExc_ValueError, "free_run: array sizes do not match the shapes");
    return nullptr;
  }
  auto d = [&b](int i) { return static_cast<const double*>(b[i].buf); };
  Net<double> m{d(0), d(1), d(2), d(3), d(4), d(5), d(6), d(7), nx, nf, n, TT, B};
  double* y = static_cast<double*>(b[10].buf);
  bool no_memory = false;
  Py_BEGIN_ALLOW_THREADS
  try {
    const RowNet<double> r(m);
    Lines<double> scratch(2 * r.npx + 2 * r.np);
    for (long long row = 0; row < B; ++row)
      row_run_f64(r, d(8) + row * nx, d(9) + row * TT * nf, TT, y + row * TT, scratch.data());
  } catch (const std::bad_alloc&) {
    no_memory = true;
  }
  Py_END_ALLOW_THREADS
  release();
  if (no_memory) return PyErr_NoMemory();
  Py_RETURN_NONE;
}

PyObject* threads_used(PyObject*, PyObject*) {
  return PyLong_FromLongLong(g_threads_used.load(std::memory_order_relaxed));
}

PyObject* pool_threads(PyObject*, PyObject*) {
  return PyLong_FromLongLong(g_pool_threads.load(std::memory_order_relaxed));
}

PyMethodDef methods[] = {
    {"handlers", handlers, METH_NOARGS, "The XLA FFI handlers by target name (capsules)."},
    {"free_run", free_run, METH_VARARGS,
     "The float64 free run of a few rows, one at a time (neurons as the vector axis)."},
    {"threads_used", threads_used, METH_NOARGS,
     "The threads that ran the blocks of rows in the last call of a handler."},
    {"pool_threads", pool_threads, METH_NOARGS,
     "The threads of the pool XLA gave the last call of a handler."},
    {nullptr, nullptr, 0, nullptr}};

PyModuleDef module = {PyModuleDef_HEAD_INIT, "_window",
                      "The grey box's shooting window as XLA FFI handlers.", -1, methods};
}  // namespace

PyMODINIT_FUNC PyInit__window(void) { return PyModule_Create(&module); }
