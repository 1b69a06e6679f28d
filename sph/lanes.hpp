// Two doubles computed side by side (one SSE2 register on x86-64, two scalars elsewhere):
// what the pair loops use to evaluate two neighbours at once. Every operation is the
// correctly rounded IEEE operation of each lane, so a lane gives the same bits as the
// scalar code it mirrors; only branches become masks (select), and a sum over pairs is
// still added lane by lane in the scalar order by its caller.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace wake {

#if defined(__SSE2__)

struct Lanes2 {
  __m128d v;

  static Lanes2 all(double a) { return {_mm_set1_pd(a)}; }
  /// (a, b).
  static Lanes2 of(double a, double b) { return {_mm_set_pd(b, a)}; }
  /// (a[j0], a[j1]).
  static Lanes2 gather(const double* a, std::uint32_t j0, std::uint32_t j1) {
    return {_mm_loadh_pd(_mm_load_sd(a + j0), a + j1)};
  }
  /// Two consecutive doubles a[0], a[1].
  static Lanes2 load(const double* a) { return {_mm_loadu_pd(a)}; }
  /// Components of two 3-vectors stored as 3 consecutive doubles at p0 and p1:
  /// x = (p0[0], p1[0]), y = (p0[1], p1[1]), z = (p0[2], p1[2]).
  static void gather3(const double* p0, const double* p1, Lanes2& x, Lanes2& y, Lanes2& z) {
    const __m128d a = _mm_loadu_pd(p0), b = _mm_loadu_pd(p1);
    x.v = _mm_unpacklo_pd(a, b);
    y.v = _mm_unpackhi_pd(a, b);
    z.v = _mm_loadh_pd(_mm_load_sd(p0 + 2), p1 + 2);
  }
  double lane0() const { return _mm_cvtsd_f64(v); }
  double lane1() const { return _mm_cvtsd_f64(_mm_unpackhi_pd(v, v)); }

  friend Lanes2 operator+(Lanes2 a, Lanes2 b) { return {_mm_add_pd(a.v, b.v)}; }
  friend Lanes2 operator-(Lanes2 a, Lanes2 b) { return {_mm_sub_pd(a.v, b.v)}; }
  friend Lanes2 operator*(Lanes2 a, Lanes2 b) { return {_mm_mul_pd(a.v, b.v)}; }
  friend Lanes2 operator/(Lanes2 a, Lanes2 b) { return {_mm_div_pd(a.v, b.v)}; }
  /// -a (the sign bit flipped, exact).
  friend Lanes2 operator-(Lanes2 a) { return {_mm_xor_pd(a.v, _mm_set1_pd(-0.0))}; }
  friend Lanes2 sqrt(Lanes2 a) { return {_mm_sqrt_pd(a.v)}; }
  /// Masks: all bits set in a lane where the comparison holds.
  friend Lanes2 operator<(Lanes2 a, Lanes2 b) { return {_mm_cmplt_pd(a.v, b.v)}; }
  friend Lanes2 operator>=(Lanes2 a, Lanes2 b) { return {_mm_cmpge_pd(a.v, b.v)}; }
  friend Lanes2 operator>(Lanes2 a, Lanes2 b) { return {_mm_cmpgt_pd(a.v, b.v)}; }
  friend Lanes2 operator&(Lanes2 a, Lanes2 b) { return {_mm_and_pd(a.v, b.v)}; }
  /// The mask of the lanes in use: both, or lane 0 only.
  static Lanes2 valid(bool both) { return {_mm_castsi128_pd(_mm_set_epi64x(both ? -1 : 0, -1))}; }
  /// Per lane: `mask` set ? a : b.
  friend Lanes2 select(Lanes2 mask, Lanes2 a, Lanes2 b) {
    return {_mm_or_pd(_mm_and_pd(mask.v, a.v), _mm_andnot_pd(mask.v, b.v))};
  }
  /// Bit k set where lane k of the mask is set.
  friend int bits(Lanes2 mask) { return _mm_movemask_pd(mask.v); }
};

/// acc - (a lane 0, b lane 0) - (a lane 1, b lane 1): per lane of acc the scalar order
/// acc -= a_0; acc -= a_1 (lane 0 with a, lane 1 with b). With `only_first`, lane 1 of a
/// and b is left out.
inline Lanes2 subtractInOrder(Lanes2 acc, Lanes2 a, Lanes2 b, bool only_first = false) {
  __m128d s = _mm_sub_pd(acc.v, _mm_unpacklo_pd(a.v, b.v));
  if (!only_first) s = _mm_sub_pd(s, _mm_unpackhi_pd(a.v, b.v));
  return {s};
}

#else

struct Lanes2 {
  double v[2];

  static Lanes2 all(double a) { return {{a, a}}; }
  static Lanes2 of(double a, double b) { return {{a, b}}; }
  static Lanes2 gather(const double* a, std::uint32_t j0, std::uint32_t j1) {
    return {{a[j0], a[j1]}};
  }
  static Lanes2 load(const double* a) { return {{a[0], a[1]}}; }
  static void gather3(const double* p0, const double* p1, Lanes2& x, Lanes2& y, Lanes2& z) {
    x = {{p0[0], p1[0]}};
    y = {{p0[1], p1[1]}};
    z = {{p0[2], p1[2]}};
  }
  double lane0() const { return v[0]; }
  double lane1() const { return v[1]; }

  friend Lanes2 operator+(Lanes2 a, Lanes2 b) { return {{a.v[0] + b.v[0], a.v[1] + b.v[1]}}; }
  friend Lanes2 operator-(Lanes2 a, Lanes2 b) { return {{a.v[0] - b.v[0], a.v[1] - b.v[1]}}; }
  friend Lanes2 operator*(Lanes2 a, Lanes2 b) { return {{a.v[0] * b.v[0], a.v[1] * b.v[1]}}; }
  friend Lanes2 operator/(Lanes2 a, Lanes2 b) { return {{a.v[0] / b.v[0], a.v[1] / b.v[1]}}; }
  friend Lanes2 operator-(Lanes2 a) { return {{-a.v[0], -a.v[1]}}; }
  friend Lanes2 sqrt(Lanes2 a) { return {{std::sqrt(a.v[0]), std::sqrt(a.v[1])}}; }
  friend Lanes2 operator<(Lanes2 a, Lanes2 b) {
    return {{mask(a.v[0] < b.v[0]), mask(a.v[1] < b.v[1])}};
  }
  friend Lanes2 operator>=(Lanes2 a, Lanes2 b) {
    return {{mask(a.v[0] >= b.v[0]), mask(a.v[1] >= b.v[1])}};
  }
  friend Lanes2 operator>(Lanes2 a, Lanes2 b) {
    return {{mask(a.v[0] > b.v[0]), mask(a.v[1] > b.v[1])}};
  }
  friend Lanes2 operator&(Lanes2 a, Lanes2 b) {
    return {{mask(isSet(a.v[0]) && isSet(b.v[0])), mask(isSet(a.v[1]) && isSet(b.v[1]))}};
  }
  static Lanes2 valid(bool both) { return {{mask(true), mask(both)}}; }
  friend Lanes2 select(Lanes2 m, Lanes2 a, Lanes2 b) {
    return {{isSet(m.v[0]) ? a.v[0] : b.v[0], isSet(m.v[1]) ? a.v[1] : b.v[1]}};
  }
  friend int bits(Lanes2 m) { return (isSet(m.v[0]) ? 1 : 0) | (isSet(m.v[1]) ? 2 : 0); }

 private:
  static double mask(bool on) {
    const std::uint64_t u = on ? ~std::uint64_t(0) : 0;
    double d;
    std::memcpy(&d, &u, sizeof d);
    return d;
  }
  static bool isSet(double m) {
    std::uint64_t u;
    std::memcpy(&u, &m, sizeof u);
    return u != 0;
  }
};

inline Lanes2 subtractInOrder(Lanes2 acc, Lanes2 a, Lanes2 b, bool only_first = false) {
  acc.v[0] -= a.v[0];
  acc.v[1] -= b.v[0];
  if (!only_first) {
    acc.v[0] -= a.v[1];
    acc.v[1] -= b.v[1];
  }
  return acc;
}

#endif

/// acc + (a lane k, b lane k) for the lanes k set in `mask`, in lane order: the same bits
/// as the scalar `if (mask_k) { acc[0] += a_k; acc[1] += b_k; }` (x - (-t) is x + t, and
/// x - (+0) is x, signed zeros included).
inline Lanes2 addInOrder(Lanes2 acc, Lanes2 a, Lanes2 b, Lanes2 mask) {
  const Lanes2 zero = Lanes2::all(0.0);
  return subtractInOrder(acc, select(mask, -a, zero), select(mask, -b, zero));
}

/// acc + (a lane k, b lane k) for k = 0, 1 (lane 0 only with `only_first`), in lane
/// order: the same bits as acc[0] += a_k; acc[1] += b_k.
inline Lanes2 addInOrder(Lanes2 acc, Lanes2 a, Lanes2 b, bool only_first = false) {
  return subtractInOrder(acc, -a, -b, only_first);
}

/// Calls f(j0, j1, valid) for the indices [lo, hi) two at a time: (j, j + 1) with both
/// lanes valid, and for an odd count a last (j, j) with lane 0 only.
template <class F>
inline void forEachTwo(std::uint32_t lo, std::uint32_t hi, F&& f) {
  for (std::uint32_t j = lo; j < hi; j += 2) {
    const bool both = j + 1 < hi;
    f(j, both ? j + 1 : j, Lanes2::valid(both));
  }
}

}  // namespace wake
