#include "ibvs/features/moments.hpp"

#include "moments_goal.hpp"

#include "ibvs/angle_wrap.hpp"
#include "ibvs/finite.hpp"
#include "ibvs/limits.hpp"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <utility>
#include <stdexcept>

namespace ibvs {

namespace {

// A value and its derivative along the camera twist (a row of an interaction matrix): the
// features are computed once, in this arithmetic, for their values and their rows alike.
using Row6 = Eigen::Matrix<double, 1, 6>;
struct Dual {
  double v = 0.0;
  Row6 d = Row6::Zero();
};
Dual operator+(const Dual& a, const Dual& b) { return {a.v + b.v, a.d + b.d}; }
Dual operator-(const Dual& a, const Dual& b) { return {a.v - b.v, a.d - b.d}; }
Dual operator*(const Dual& a, const Dual& b) { return {a.v * b.v, a.v * b.d + b.v * a.d}; }
Dual operator*(double k, const Dual& a) { return {k * a.v, k * a.d}; }
Dual operator/(const Dual& a, const Dual& b) {
  const double q = a.v / b.v;
  return {q, (a.d - q * b.d) / b.v};
}
Dual sqrt(const Dual& a) {
  const double r = std::sqrt(a.v);
  return {r, a.d / (2.0 * r)};
}
Dual atan2(const Dual& y, const Dual& x) {
  return {std::atan2(y.v, x.v), (x.v * y.d - y.v * x.d) / (x.v * x.v + y.v * y.v)};
}

constexpr double binomial[9][9] = {{1},
                                   {1, 1},
                                   {1, 2, 1},
                                   {1, 3, 3, 1},
                                   {1, 4, 6, 4, 1},
                                   {1, 5, 10, 10, 5, 1},
                                   {1, 6, 15, 20, 15, 6, 1},
                                   {1, 7, 21, 35, 35, 21, 7, 1},
                                   {1, 8, 28, 56, 70, 56, 28, 8, 1}};

constexpr double max_entry = 1e20;  // values and interaction entries beyond it are refused (J^T J stays finite)

// Everything a measurement gives: the six features (all of them, selected or not) with their
// interaction rows, and the quantities that decide what is refused.
struct Evaluation {
  Dual s[6];           // xn, yn, an, r1, r2, alpha
  double a = 0.0;      // the area (m00, or mu20 + mu02 for points)
  double depth = 0.0;  // 1/Z at the centre of gravity
  double flat = 0.0;   // 4 (mu20 mu02 - mu11^2) / I3^2, in [0, 1]: 0 for a flat object
  double anisotropy = 0.0;  // I1 / I3^2, in [0, 1]: 0 when alpha is undefined
  double third = 0.0;  // Re(z3 e^{-3 i alpha}) sqrt(m00) / I3^(3/2): 0 when its orientation is undefined
};

Evaluation evaluation(const double* mm, MomentsFeature::Source source, MomentsFeature::Invariants invariants,
                    MomentsFeature::Alpha alpha_kind) noexcept {
  const bool region = source == MomentsFeature::Source::region;
  const double r = region ? 1.0 : 0.0;  // the area element's change (regions only)
  const double A = mm[17], B = mm[18], C = mm[19];
  const auto raw = [mm](int i, int j) { return i < 0 || j < 0 ? 0.0 : mm[moment_index(i, j)]; };
  // m_ij (i + j <= 3) with their rows L_mij (Chaumette 2004 eq. (13) for a region; the sum of the
  // points' rows for points).
  Dual m[4][4];
  for (int n = 0; n <= 3; ++n)
    for (int j = 0; j <= n; ++j) {
      const int i = n - j;
      const double mij = raw(i, j), k = n + 3.0 * r;
      Dual& d = m[i][j];
      d.v = mij;
      d.d << -i * (A * mij + B * raw(i - 1, j + 1) + C * raw(i - 1, j)) - r * A * mij,
          -j * (A * raw(i + 1, j - 1) + B * mij + C * raw(i, j - 1)) - r * B * mij,
          k * (A * raw(i + 1, j) + B * raw(i, j + 1) + C * mij) - r * C * mij,  //
          k * raw(i, j + 1) + j * raw(i, j - 1),                               //
          -k * raw(i + 1, j) - i * raw(i - 1, j),                              //
          i * raw(i - 1, j + 1) - j * raw(i + 1, j - 1);
    }
  Evaluation out;
  const Dual xg = m[1][0] / m[0][0], yg = m[0][1] / m[0][0];
  // Centred moments from the raw ones (the binomial expansion of (x - xg)^p (y - yg)^q, with
  // m10 = xg m00, m01 = yg m00).
  const Dual xm10 = xg * m[1][0], ym01 = yg * m[0][1], xg2 = xg * xg, yg2 = yg * yg;
  const Dual mu20 = m[2][0] - xm10, mu11 = m[1][1] - xg * m[0][1], mu02 = m[0][2] - ym01;
  const Dual mu30 = m[3][0] - 3.0 * (xg * m[2][0]) + 2.0 * (xg2 * m[1][0]);
  const Dual mu21 = m[2][1] - 2.0 * (xg * m[1][1]) - yg * m[2][0] + 2.0 * (xg2 * m[0][1]);
  const Dual mu12 = m[1][2] - 2.0 * (yg * m[1][1]) - xg * m[0][2] + 2.0 * (yg2 * m[1][0]);
  const Dual mu03 = m[0][3] - 3.0 * (yg * m[0][2]) + 2.0 * (yg2 * m[0][1]);
  const Dual I3 = mu20 + mu02;
  const Dual a = region ? m[0][0] : I3;
  out.a = a.v;
  out.depth = A * xg.v + B * yg.v + C;
  // xn, yn, an (Tahri & Chaumette 2005, Sec. V): an = Z* sqrt(a* / a).
  Dual an;
  an.v = mm[16] * std::sqrt(mm[15] / a.v);
  an.d = -0.5 * an.v / a.v * a.d;
  out.s[0] = an * xg;
  out.s[1] = an * yg;
  out.s[2] = an;
  const Dual c1 = mu20 - mu02, s1 = 2.0 * mu11, c2 = mu03 - 3.0 * mu21, s2 = mu30 - 3.0 * mu12;
  const Dual I1 = c1 * c1 + s1 * s1, I2 = c2 * c2 + s2 * s2;
  const double I3sq = I3.v * I3.v;
  out.flat = 4.0 * (mu20.v * mu02.v - mu11.v * mu11.v) / I3sq;
  out.anisotropy = I1.v / I3sq;
  if (invariants == MomentsFeature::Invariants::p) {
    out.s[3] = I1 / (I3 * I3);
    out.s[4] = a * I2 / (I3 * I3 * I3);
  } else {
    const Dual c3 = c1 * c1 - s1 * s1, s3 = 2.0 * s1 * c1;
    const Dual K = I1 * I3 * sqrt(I3) / sqrt(a);
    out.s[3] = (c2 * c3 + s2 * s3) / K;
    out.s[4] = (s2 * c3 - c2 * s3) / K;
  }
  // alpha = atan2(2 mu11, mu20 - mu02) / 2; over the full turn, the axis oriented by z3.
  Dual alpha = 0.5 * atan2(s1, c1);
  const double ca = std::cos(3.0 * alpha.v), sa = std::sin(3.0 * alpha.v);
  // Re(z3 e^{-3 i alpha}) with z3 = s2 - i c2 = (mu30 - 3 mu12) + i (3 mu21 - mu03).
  out.third = (s2.v * ca - c2.v * sa) * std::sqrt(m[0][0].v) / (I3.v * std::sqrt(I3.v));
  if (alpha_kind == MomentsFeature::Alpha::third_order && out.third < 0.0) alpha.v = wrap_angle(alpha.v + pi);
  out.s[5] = alpha;
  return out;
}

// Moments of n points / of the polygon through n vertices, vertex k = xy(k) (a pair): no allocation.
template <class XY>
Moments points_moments(Eigen::Index n, const XY& xy) noexcept {
  Moments m{};
  for (Eigen::Index k = 0; k < n; ++k) {
    const auto [x, y] = xy(k);
    double xi = 1.0;
    for (int i = 0; i <= 4; ++i, xi *= x) {
      double yj = 1.0;
      for (int j = 0; i + j <= 4; ++j, yj *= y) m[static_cast<std::size_t>(moment_index(i, j))] += xi * yj;
    }
  }
  return m;
}

template <class XY>
Moments polygon_moments(Eigen::Index n, const XY& xy) noexcept {
  Moments m{};
  for (Eigen::Index e = 0; e < n; ++e) {
    const auto [x0, y0] = xy(e);
    const auto [x1, y1] = xy((e + 1) % n);
    const double cross = x0 * y1 - x1 * y0;
    double p0[5], p1[5], q0[5], q1[5];  // powers of x0, x1, y0, y1
    p0[0] = p1[0] = q0[0] = q1[0] = 1.0;
    for (int k = 1; k <= 4; ++k) {
      p0[k] = p0[k - 1] * x0;
      p1[k] = p1[k - 1] * x1;
      q0[k] = q0[k - 1] * y0;
      q1[k] = q1[k - 1] * y1;
    }
    for (int p = 0; p <= 4; ++p)
      for (int q = 0; p + q <= 4; ++q) {
        double sum = 0.0;
        for (int k = 0; k <= p; ++k)
          for (int l = 0; l <= q; ++l)
            sum += binomial[k + l][k] * binomial[p + q - k - l][q - l] * p1[k] * p0[p - k] * q1[l] * q0[q - l];
        m[static_cast<std::size_t>(moment_index(p, q))] += cross * sum;
      }
  }
  for (int p = 0; p <= 4; ++p)
    for (int q = 0; p + q <= 4; ++q)
      m[static_cast<std::size_t>(moment_index(p, q))] /= (p + q + 2.0) * (p + q + 1.0) * binomial[p + q][p];
  if (m[0] < 0.0)
    for (double& v : m) v = -v;  // a clockwise polygon
  return m;
}

double wrap_half(double d) noexcept { return 0.5 * wrap_angle(2.0 * d); }  // into (-pi/2, pi/2]

// e = s (-) s* of the selected rows: alpha's difference wrapped (over the full turn, or modulo pi).
// sd: the goal's six values.
void differences(const Evaluation& ev, const double* sd, unsigned rows, MomentsFeature::Alpha alpha,
                 double* e) noexcept {
  for (unsigned b = 0, r = 0; b < 6; ++b)
    if ((rows >> b) & 1u) {
      const double d = ev.s[b].v - sd[b];
      e[r++] = b < 5 ? d : (alpha == MomentsFeature::Alpha::third_order ? wrap_angle(d) : wrap_half(d));
    }
}
void differences(const Evaluation& ev, const Evaluation& evd, unsigned rows, MomentsFeature::Alpha alpha,
                 double* e) noexcept {
  const double sd[6] = {evd.s[0].v, evd.s[1].v, evd.s[2].v, evd.s[3].v, evd.s[4].v, evd.s[5].v};
  differences(ev, sd, rows, alpha, e);
}

}  // namespace


MomentsFeature::MomentsFeature(Source source, Invariants invariants, Alpha alpha, unsigned rows)
    : source_(source), invariants_(invariants), alpha_(alpha), rows_(rows), n_rows_(0) {
  if (rows == 0 || (rows & ~static_cast<unsigned>(Row::all)) != 0)
    throw std::invalid_argument("ibvs: moments: rows must select some of xn, yn, an, r1, r2, alpha (bits 0..5)");
  if (static_cast<unsigned>(source) > 1 || static_cast<unsigned>(invariants) > 1 || static_cast<unsigned>(alpha) > 1)
    throw std::invalid_argument("ibvs: moments: unknown source, invariants or alpha");
  for (unsigned b = 0; b < 6; ++b) n_rows_ += (rows >> b) & 1u;
}

std::string MomentsFeature::describe() const {
  std::string d = std::string("moments(") + (source_ == Source::region ? "region" : "points") +
                  (invariants_ == Invariants::p ? ", p" : ", s") +
                  (alpha_ == Alpha::third_order ? ", third_order" : ", second_order");
  if (rows_ != Row::all) {
    static const char* names[6] = {"xn", "yn", "an", "r1", "r2", "alpha"};
    d += ", rows=";
    bool first = true;
    for (unsigned b = 0; b < 6; ++b)
      if ((rows_ >> b) & 1u) {
        d += (first ? "" : "+") + std::string(names[b]);
        first = false;
      }
  }
  return d + ")";
}

Moments MomentsFeature::of_points(const Eigen::Ref<const Points>& xy) {
  return points_moments(xy.cols(), [&](Eigen::Index k) { return std::pair<double, double>(xy(0, k), xy(1, k)); });
}

Moments MomentsFeature::of_polygon(const Eigen::Ref<const Points>& xy) {
  return polygon_moments(xy.cols(), [&](Eigen::Index k) { return std::pair<double, double>(xy(0, k), xy(1, k)); });
}

double MomentsFeature::area(const double* m, Source source) noexcept {
  if (source == Source::region) return m[0];
  return m[3] - m[1] * m[1] / m[0] + m[5] - m[2] * m[2] / m[0];
}

std::array<double, 20> MomentsFeature::measure(const Moments& m, Source source, double a_desired, double depth_desired,
                                               double A, double B, double C) {
  std::array<double, 20> out{};
  std::copy(m.begin(), m.end(), out.begin());
  out[15] = a_desired == 0.0 ? area(m.data(), source) : a_desired;
  out[16] = depth_desired;
  out[17] = A;
  out[18] = B;
  out[19] = C;
  return out;
}

std::array<double, 20> MomentsFeature::project(const Eigen::Ref<const Eigen::Matrix3Xd>& P, Source source,
                                               double a_desired, double depth_desired) {
  const Eigen::Index n = P.cols();
  if (n < 3) throw std::invalid_argument("ibvs: moments: project needs at least 3 points");
  if (!P.allFinite()) throw std::invalid_argument("ibvs: moments: the points must be finite");
  if (!(P.row(2).array() >= min_depth).all())
    throw std::invalid_argument("ibvs: moments: every point must be in front of the camera (Z >= min_depth)");
  // The plane n . X = d through the points: the scatter's eigenvector of least eigenvalue.
  const Eigen::Vector3d c = P.rowwise().mean();
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  double extent = 0.0;
  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Vector3d q = P.col(k) - c;
    S.noalias() += q * q.transpose();
    extent = std::max(extent, q.norm());
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(S);
  const Eigen::Vector3d normal = eig.eigenvectors().col(0);
  for (Eigen::Index k = 0; k < n; ++k)
    if (std::abs(normal.dot(P.col(k) - c)) > 1e-9 * extent)
      throw std::invalid_argument("ibvs: moments: the points are not on one plane");
  const double d = normal.dot(c);
  if (!(std::abs(d) > 1e-12 * c.norm()))
    throw std::invalid_argument("ibvs: moments: the plane passes through the camera centre");
  const auto image = [&](Eigen::Index k) { return std::pair<double, double>(P(0, k) / P(2, k), P(1, k) / P(2, k)); };
  const Moments m = source == Source::region ? polygon_moments(n, image) : points_moments(n, image);
  return measure(m, source, a_desired, depth_desired, normal.x() / d, normal.y() / d, normal.z() / d);
}

namespace {

// The refusals decided from the measurement's entries alone (before it is evaluated).
const char* check_entries(const double* m, int& entry) noexcept {
  for (entry = 0; entry < MomentsFeature::measurement_size; ++entry)
    if (!std::isfinite(m[entry])) return "is not finite";
  entry = 0;
  if (!(m[0] > 0.0)) return "m00 must be > 0 (an object of zero area, or no points)";
  if (m[0] > max_points) return "m00 must be at most max_points";
  double bound = 2.0 * m[0];  // 2 m00 10^n for the moments of order n
  for (int n = 1; n <= 4; ++n) {
    bound *= max_normalized_coordinate;
    for (int j = 0; j <= n; ++j) {
      entry = moment_index(n - j, j);
      if (std::abs(m[entry]) > bound) return "is beyond the normalised-coordinate limit (|m_ij| <= 2 m00 10^(i+j))";
    }
  }
  entry = 15;
  if (!(m[15] > 0.0 && m[15] <= 1e12)) return "the goal's area a* must be in (0, 1e12]";
  entry = 16;
  if (!(m[16] >= min_depth && m[16] <= max_depth)) return "the goal's depth Z* must be within [min_depth, max_depth]";
  for (entry = 17; entry < 20; ++entry)
    if (std::abs(m[entry]) > 1.0 / min_depth) return "the plane's A, B, C must be within 1 / min_depth";
  entry = -1;
  return nullptr;
}

// The refusals decided from its evaluation (the selected rows, their invariants and orientation).
const char* check_evaluation(const Evaluation& ev, unsigned rows, MomentsFeature::Invariants invariants,
                             MomentsFeature::Alpha alpha) noexcept {
  using Row = MomentsFeature::Row;
  if (!(ev.a > 0.0) || !(ev.flat >= 1e-9))
    return "the object is flat or has zero area (collinear points, a zero-width region)";
  if (!(ev.depth >= 1.0 / max_depth))
    return "the plane is seen edge-on or from behind at the object (1/Z = A x + B y + C <= 0 at its centre)";
  const bool needs_axis =
      (rows & Row::alpha) || (invariants == MomentsFeature::Invariants::s && (rows & (Row::r1 | Row::r2)));
  if (needs_axis && !(ev.anisotropy >= 1e-12))
    return "alpha (and the S invariants) are undefined: mu20 = mu02 and mu11 = 0 (a square, a disc)";
  if ((rows & Row::alpha) && alpha == MomentsFeature::Alpha::third_order && !(std::abs(ev.third) >= 1e-9))
    return "the third-order orientation is undefined (a centrally symmetric object: use Alpha::second_order)";
  for (unsigned b = 0; b < 6; ++b)
    if (((rows >> b) & 1u) && (!finite_within(ev.s[b].v, max_entry) || !finite_within(ev.s[b].d, max_entry)))
      return "gives values or interaction entries beyond 1e20 (not the moments of an object)";
  return nullptr;
}

}  // namespace

const char* MomentsFeature::check(const double* m, int& entry) const noexcept {
  if (const char* why = check_entries(m, entry)) return why;
  return check_evaluation(evaluation(m, source_, invariants_, alpha_), rows_, invariants_, alpha_);
}

// check(), error() and interaction() on the two measurements with each evaluated once (their
// five evaluations give the same numbers twice or three times): the same results, bit for bit.
const char* MomentsFeature::evaluate(double* m, const double* md, double* e, Eigen::Ref<MatrixX6> L) const noexcept {
  int entry = -1;
  if (const char* why = check_entries(m, entry)) return why;
  const Evaluation ev = evaluation(m, source_, invariants_, alpha_);
  if (const char* why = check_evaluation(ev, rows_, invariants_, alpha_)) return why;
  if (const char* why = check_entries(md, entry)) return why;
  const Evaluation evd = evaluation(md, source_, invariants_, alpha_);
  if (const char* why = check_evaluation(evd, rows_, invariants_, alpha_)) return why;
  differences(ev, evd, rows_, alpha_, e);
  for (unsigned b = 0, r = 0; b < 6; ++b)
    if ((rows_ >> b) & 1u) L.row(r++) = ev.s[b].d;
  return nullptr;
}

void detail::moments_goal(const MomentsFeature& f, const double* md, MomentsGoal& goal) noexcept {
  int entry = -1;
  goal.refused = check_entries(md, entry);
  if (goal.refused) return;
  const Evaluation evd = evaluation(md, f.source(), f.invariants(), f.alpha_kind());
  goal.refused = check_evaluation(evd, f.selected(), f.invariants(), f.alpha_kind());
  for (int b = 0; b < 6; ++b) goal.s[b] = evd.s[b].v;
}

// MomentsFeature::evaluate with the goal's evaluation given: differences() reads the goal's
// values only.
const char* detail::moments_evaluate(const MomentsFeature& f, double* m, const MomentsGoal& goal, double* e,
                                     Eigen::Ref<MatrixX6> L) noexcept {
  int entry = -1;
  if (const char* why = check_entries(m, entry)) return why;
  const Evaluation ev = evaluation(m, f.source(), f.invariants(), f.alpha_kind());
  if (const char* why = check_evaluation(ev, f.selected(), f.invariants(), f.alpha_kind())) return why;
  if (goal.refused) return goal.refused;
  differences(ev, goal.s, f.selected(), f.alpha_kind(), e);
  for (unsigned b = 0, r = 0; b < 6; ++b)
    if ((f.selected() >> b) & 1u) L.row(r++) = ev.s[b].d;
  return nullptr;
}

void MomentsFeature::value(const double* m, double* s) const noexcept {
  const Evaluation ev = evaluation(m, source_, invariants_, alpha_);
  for (unsigned b = 0, r = 0; b < 6; ++b)
    if ((rows_ >> b) & 1u) s[r++] = ev.s[b].v;
}

void MomentsFeature::error(const double* m, const double* md, double* e) const noexcept {
  const Evaluation ev = evaluation(m, source_, invariants_, alpha_), evd = evaluation(md, source_, invariants_, alpha_);
  differences(ev, evd, rows_, alpha_, e);
}

void MomentsFeature::interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept {
  const Evaluation ev = evaluation(m, source_, invariants_, alpha_);
  for (unsigned b = 0, r = 0; b < 6; ++b)
    if ((rows_ >> b) & 1u) L.row(r++) = ev.s[b].d;
}

}  // namespace ibvs
