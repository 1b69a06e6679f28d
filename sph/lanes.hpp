// Doubles computed side by side: what the pair loops use to evaluate several neighbours at
// once. Lanes2 is one SSE2 register on x86-64 (two scalars elsewhere); Lanes4 one AVX
// register, used where the CPU has AVX (the functions that use it are compiled for AVX and
// chosen at run time: hasWideLanes()). Every operation is the correctly rounded IEEE
// operation of each lane, so a lane gives the same bits as the scalar code it mirrors; only
// branches become masks (select), and a sum over pairs is still added lane by lane in the
// scalar order (subtractInOrder). Lanes2 and Lanes4 give the same bits.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define WAKE_HAS_LANES4 1
#endif

namespace wake {

#if defined(__SSE2__)

struct Lanes2 {
  __m128d v;
  static constexpr int kWidth = 2;

  static Lanes2 all(double a) { return {_mm_set1_pd(a)}; }
  static Lanes2 load(const double* p) { return {_mm_loadu_pd(p)}; }
  /// (p[0], p[1]) of floats, widened (exact).
  static Lanes2 loadFloats(const float* p) {
    return {_mm_cvtps_pd(_mm_castpd_ps(_mm_load_sd(reinterpret_cast<const double*>(p))))};
  }
  void store(double* p) const { _mm_storeu_pd(p, v); }
  /// (a[j0], a[j1]).
  static Lanes2 gather(const double* a, std::uint32_t j0, std::uint32_t j1) {
    return {_mm_loadh_pd(_mm_load_sd(a + j0), a + j1)};
  }
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
  /// Per lane: `mask` set ? a : b.
  friend Lanes2 select(Lanes2 mask, Lanes2 a, Lanes2 b) {
    return {_mm_or_pd(_mm_and_pd(mask.v, a.v), _mm_andnot_pd(mask.v, b.v))};
  }
};

/// acc - (a lane 0, b lane 0) - (a lane 1, b lane 1): per lane of acc the scalar order
/// acc -= a_0; acc -= a_1 (lane 0 with a, lane 1 with b); only the first `used` lanes.
inline Lanes2 subtractInOrder(Lanes2 acc, Lanes2 a, Lanes2 b, int used) {
  __m128d s = _mm_sub_pd(acc.v, _mm_unpacklo_pd(a.v, b.v));
  if (used > 1) s = _mm_sub_pd(s, _mm_unpackhi_pd(a.v, b.v));
  return {s};
}

/// For each lane t < used with a destination (p[t] not null): *p[t] += a_t. The other
/// side of a pair: its particle gets the term negated, and x - (-y) is x + y, bit for bit.
inline void addToOne(double* const* p, Lanes2 a, int used) {
  if (p[0]) *p[0] += a.lane0();
  if (used > 1 && p[1]) *p[1] += a.lane1();
}
/// The lanes as rows: lo = (a_0, b_0), hi = (a_1, b_1) (a 2x2 transpose).
inline void transpose2(Lanes2 a, Lanes2 b, Lanes2& lo, Lanes2& hi) {
  lo.v = _mm_unpacklo_pd(a.v, b.v);
  hi.v = _mm_unpackhi_pd(a.v, b.v);
}

#else

struct Lanes2 {
  double v[2];
  static constexpr int kWidth = 2;

  static Lanes2 all(double a) { return {{a, a}}; }
  static Lanes2 load(const double* p) { return {{p[0], p[1]}}; }
  static Lanes2 loadFloats(const float* p) { return {{double(p[0]), double(p[1])}}; }
  void store(double* p) const {
    p[0] = v[0];
    p[1] = v[1];
  }
  static Lanes2 gather(const double* a, std::uint32_t j0, std::uint32_t j1) {
    return {{a[j0], a[j1]}};
  }
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
  friend Lanes2 select(Lanes2 m, Lanes2 a, Lanes2 b) {
    return {{isSet(m.v[0]) ? a.v[0] : b.v[0], isSet(m.v[1]) ? a.v[1] : b.v[1]}};
  }

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

inline Lanes2 subtractInOrder(Lanes2 acc, Lanes2 a, Lanes2 b, int used) {
  acc.v[0] -= a.v[0];
  acc.v[1] -= b.v[0];
  if (used > 1) {
    acc.v[0] -= a.v[1];
    acc.v[1] -= b.v[1];
  }
  return acc;
}

inline void addToOne(double* const* p, Lanes2 a, int used) {
  for (int t = 0; t < used; ++t)
    if (p[t]) *p[t] += a.v[t];
}
inline void transpose2(Lanes2 a, Lanes2 b, Lanes2& lo, Lanes2& hi) {
  lo = {{a.v[0], b.v[0]}};
  hi = {{a.v[1], b.v[1]}};
}

#endif

/// The index-array forms of the gathers, for loops written once for Lanes2 and Lanes4:
/// (a[j[0]], a[j[1]]) and the 3-vectors at p[0], p[1].
inline Lanes2 gatherLanes(Lanes2, const double* a, const std::uint32_t* j) {
  return Lanes2::gather(a, j[0], j[1]);
}
inline void gather3Lanes(const double* const* p, Lanes2& x, Lanes2& y, Lanes2& z) {
  Lanes2::gather3(p[0], p[1], x, y, z);
}

/// Four doubles as two Lanes2: the operations of Lanes4 with the same bits, so that a loop
/// over groups of four terms is written once for both (a sum in four partial sums, one per
/// position in the group, then total(): the same result with and without AVX).
struct Quad2 {
  Lanes2 lo, hi;

  static Quad2 all(double a) { return {Lanes2::all(a), Lanes2::all(a)}; }
  /// p[0 .. 3] of floats, widened (exact).
  static Quad2 loadFloats(const float* p) {
    return {Lanes2::loadFloats(p), Lanes2::loadFloats(p + 2)};
  }
  /// (a[j[0]], .., a[j[3]]).
  static Quad2 gather(const double* a, const std::uint32_t* j) {
    return {Lanes2::gather(a, j[0], j[1]), Lanes2::gather(a, j[2], j[3])};
  }
  /// Components of the 3-vectors at p[0 .. 3].
  static void gather3(const double* const* p, Quad2& x, Quad2& y, Quad2& z) {
    Lanes2::gather3(p[0], p[1], x.lo, y.lo, z.lo);
    Lanes2::gather3(p[2], p[3], x.hi, y.hi, z.hi);
  }
  /// Components of the float 3-vectors at p[0 .. 3], widened (exact).
  static void gather3Floats(const float* const* p, Quad2& x, Quad2& y, Quad2& z) {
    const double a[3][4] = {{p[0][0], p[1][0], p[2][0], p[3][0]},
                            {p[0][1], p[1][1], p[2][1], p[3][1]},
                            {p[0][2], p[1][2], p[2][2], p[3][2]}};
    x = {Lanes2::load(a[0]), Lanes2::load(a[0] + 2)};
    y = {Lanes2::load(a[1]), Lanes2::load(a[1] + 2)};
    z = {Lanes2::load(a[2]), Lanes2::load(a[2] + 2)};
  }
  /// (q0 + q1) + (q2 + q3).
  double total() const { return (lo.lane0() + lo.lane1()) + (hi.lane0() + hi.lane1()); }

  friend Quad2 operator+(Quad2 a, Quad2 b) { return {a.lo + b.lo, a.hi + b.hi}; }
  friend Quad2 operator-(Quad2 a, Quad2 b) { return {a.lo - b.lo, a.hi - b.hi}; }
  friend Quad2 operator*(Quad2 a, Quad2 b) { return {a.lo * b.lo, a.hi * b.hi}; }
};

#if defined(WAKE_HAS_LANES4)

/// Lanes4's operations: AVX code, inlined into the functions marked WAKE_TARGET_AVX.
#define WAKE_LANES4_FN __attribute__((target("avx"))) inline
/// A function that uses Lanes4: compiled for AVX with everything it calls inlined
/// (flatten); called only where hasWideLanes().
#define WAKE_TARGET_AVX __attribute__((target("avx"), flatten))

struct Lanes4 {
  __m256d v;
  static constexpr int kWidth = 4;

  WAKE_LANES4_FN static Lanes4 all(double a) { return {_mm256_set1_pd(a)}; }
  WAKE_LANES4_FN static Lanes4 load(const double* p) { return {_mm256_loadu_pd(p)}; }
  WAKE_LANES4_FN void store(double* p) const { _mm256_storeu_pd(p, v); }
  // As Quad2's.
  WAKE_LANES4_FN static Lanes4 loadFloats(const float* p) {
    return {_mm256_cvtps_pd(_mm_loadu_ps(p))};
  }
  WAKE_LANES4_FN static Lanes4 gather(const double* a, const std::uint32_t* j) {
    return {_mm256_set_m128d(_mm_loadh_pd(_mm_load_sd(a + j[2]), a + j[3]),
                             _mm_loadh_pd(_mm_load_sd(a + j[0]), a + j[1]))};
  }
  WAKE_LANES4_FN static void gather3(const double* const* p, Lanes4& x, Lanes4& y, Lanes4& z);
  /// As Quad2's: p[t] has 4 floats (the fourth is read, not used).
  WAKE_LANES4_FN static void gather3Floats(const float* const* p, Lanes4& x, Lanes4& y, Lanes4& z) {
    __m128 a = _mm_loadu_ps(p[0]), b = _mm_loadu_ps(p[1]), c = _mm_loadu_ps(p[2]),
           d = _mm_loadu_ps(p[3]);
    _MM_TRANSPOSE4_PS(a, b, c, d);
    x.v = _mm256_cvtps_pd(a);
    y.v = _mm256_cvtps_pd(b);
    z.v = _mm256_cvtps_pd(c);
  }
  WAKE_LANES4_FN double total() const {
    alignas(32) double s[4];
    _mm256_store_pd(s, v);
    return (s[0] + s[1]) + (s[2] + s[3]);
  }

  WAKE_LANES4_FN friend Lanes4 operator+(Lanes4 a, Lanes4 b) { return {_mm256_add_pd(a.v, b.v)}; }
  WAKE_LANES4_FN friend Lanes4 operator-(Lanes4 a, Lanes4 b) { return {_mm256_sub_pd(a.v, b.v)}; }
  WAKE_LANES4_FN friend Lanes4 operator*(Lanes4 a, Lanes4 b) { return {_mm256_mul_pd(a.v, b.v)}; }
  WAKE_LANES4_FN friend Lanes4 operator/(Lanes4 a, Lanes4 b) { return {_mm256_div_pd(a.v, b.v)}; }
  WAKE_LANES4_FN friend Lanes4 operator-(Lanes4 a) {
    return {_mm256_xor_pd(a.v, _mm256_set1_pd(-0.0))};
  }
  WAKE_LANES4_FN friend Lanes4 sqrt(Lanes4 a) { return {_mm256_sqrt_pd(a.v)}; }
  WAKE_LANES4_FN friend Lanes4 operator<(Lanes4 a, Lanes4 b) {
    return {_mm256_cmp_pd(a.v, b.v, _CMP_LT_OQ)};
  }
  WAKE_LANES4_FN friend Lanes4 operator>=(Lanes4 a, Lanes4 b) {
    return {_mm256_cmp_pd(a.v, b.v, _CMP_GE_OQ)};
  }
  /// As Lanes2's: bitwise (GCC 12 turns _mm256_blendv_pd into a branch per lane).
  WAKE_LANES4_FN friend Lanes4 select(Lanes4 mask, Lanes4 a, Lanes4 b) {
    return {_mm256_or_pd(_mm256_and_pd(mask.v, a.v), _mm256_andnot_pd(mask.v, b.v))};
  }
};

WAKE_LANES4_FN Lanes4 gatherLanes(Lanes4, const double* a, const std::uint32_t* j) {
  return Lanes4::gather(a, j);
}
WAKE_LANES4_FN void Lanes4::gather3(const double* const* p, Lanes4& x, Lanes4& y, Lanes4& z) {
  const __m128d a = _mm_loadu_pd(p[0]), b = _mm_loadu_pd(p[1]);
  const __m128d c = _mm_loadu_pd(p[2]), d = _mm_loadu_pd(p[3]);
  x.v = _mm256_set_m128d(_mm_unpacklo_pd(c, d), _mm_unpacklo_pd(a, b));
  y.v = _mm256_set_m128d(_mm_unpackhi_pd(c, d), _mm_unpackhi_pd(a, b));
  z.v = _mm256_set_m128d(_mm_loadh_pd(_mm_load_sd(p[2] + 2), p[3] + 2),
                         _mm_loadh_pd(_mm_load_sd(p[0] + 2), p[1] + 2));
}
WAKE_LANES4_FN void gather3Lanes(const double* const* p, Lanes4& x, Lanes4& y, Lanes4& z) {
  Lanes4::gather3(p, x, y, z);
}

/// acc - (a lane k, b lane k) for k = 0 .. 3, in that order (as for Lanes2; all four lanes).
WAKE_LANES4_FN Lanes2 subtractInOrder(Lanes2 acc, Lanes4 a, Lanes4 b, int) {
  const __m128d a_lo = _mm256_castpd256_pd128(a.v), a_hi = _mm256_extractf128_pd(a.v, 1);
  const __m128d b_lo = _mm256_castpd256_pd128(b.v), b_hi = _mm256_extractf128_pd(b.v, 1);
  __m128d s = _mm_sub_pd(acc.v, _mm_unpacklo_pd(a_lo, b_lo));
  s = _mm_sub_pd(s, _mm_unpackhi_pd(a_lo, b_lo));
  s = _mm_sub_pd(s, _mm_unpacklo_pd(a_hi, b_hi));
  s = _mm_sub_pd(s, _mm_unpackhi_pd(a_hi, b_hi));
  return {s};
}

/// The lanes as rows: row[t] = (a_t, b_t, c_t, d_t) (a 4x4 transpose).
WAKE_LANES4_FN void transpose4(Lanes4 a, Lanes4 b, Lanes4 c, Lanes4 d, Lanes4* row) {
  const __m256d ab_lo = _mm256_unpacklo_pd(a.v, b.v), ab_hi = _mm256_unpackhi_pd(a.v, b.v);
  const __m256d cd_lo = _mm256_unpacklo_pd(c.v, d.v), cd_hi = _mm256_unpackhi_pd(c.v, d.v);
  row[0].v = _mm256_permute2f128_pd(ab_lo, cd_lo, 0x20);
  row[1].v = _mm256_permute2f128_pd(ab_hi, cd_hi, 0x20);
  row[2].v = _mm256_permute2f128_pd(ab_lo, cd_lo, 0x31);
  row[3].v = _mm256_permute2f128_pd(ab_hi, cd_hi, 0x31);
}
/// (lo_0, lo_1, hi_0, hi_1).
WAKE_LANES4_FN Lanes4 join(Lanes2 lo, Lanes2 hi) {
  return {_mm256_set_m128d(hi.v, lo.v)};
}

/// addToOne of four lanes (all four used).
WAKE_LANES4_FN void addToOne(double* const* p, Lanes4 a, int) {
  alignas(32) double lane[4];
  _mm256_store_pd(lane, a.v);
  for (int t = 0; t < 4; ++t)
    if (p[t]) *p[t] += lane[t];
}

/// Whether this CPU (and its operating system) runs AVX code, and the environment does not
/// ask for two lanes (WAKE_NO_AVX set: to compare; the results are the same bits).
inline bool hasWideLanes() {
  static const bool avx = __builtin_cpu_supports("avx") && !std::getenv("WAKE_NO_AVX");
  return avx;
}

#else

inline bool hasWideLanes() {
  return false;
}

#endif

/// Calls group(lanes, j, used) for the entries [k, e) of an index list: L::kWidth at a time
/// (lanes: an L), then the rest (fewer than L::kWidth) two at a time (lanes: a Lanes2). j
/// holds the indices (an unused lane repeats the first), `used` how many are real.
template <class L, class G>
inline void forEachNeighborGroup(const std::uint32_t* nb, std::uint64_t k, std::uint64_t e,
                                 G&& group) {
  for (; k + L::kWidth <= e; k += L::kWidth)
    group(L::all(0.0), nb + k, L::kWidth);
  for (; k < e; k += 2) {
    const bool both = k + 1 < e;
    const std::uint32_t j[2] = {nb[k], nb[both ? k + 1 : k]};
    group(Lanes2::all(0.0), j, both ? 2 : 1);
  }
}

}  // namespace wake
