#include "scan/register.h"

#include <Eigen/CholmodSupport>
#include <Eigen/Geometry>
#include <Eigen/Sparse>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <unordered_map>

#include "core/error.h"
#include "core/stats.h"
#include "core/parallel.h"
#include "core/similarity.h"
#include "render/rasterize.h"
#include "template/surface.h"

namespace bareskin {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

Eigen::MatrixX3d landmark_points(const TemplateFace& face) {
  Eigen::MatrixX3d P(68, 3);
  for (int k = 0; k < 68; ++k) P.row(k) = face.mesh.V.row(face.landmark_vertices[size_t(k)]);
  return P;
}

// Runs f, adds its wall time to `seconds`, returns its result.
template <class F>
auto timed(double& seconds, F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  auto result = f();
  seconds += seconds_since(t0);
  return result;
}

double rms(const Eigen::MatrixX3d& a, const Eigen::MatrixX3d& b) { return std::sqrt((a - b).rowwise().squaredNorm().mean()); }

// Which scan points are on its boundary: a closest point on a boundary edge or vertex means the query is off the scan
// (beyond its rim or over a hole), so its correspondence is rejected.
class BoundaryTest {
 public:
  explicit BoundaryTest(const Mesh& scan) : vertex_(size_t(scan.V.rows()), false) {
    const Eigen::MatrixX2i edges = boundary_edges(scan.F);
    for (Eigen::Index e = 0; e < edges.rows(); ++e) {
      vertex_[size_t(edges(e, 0))] = vertex_[size_t(edges(e, 1))] = true;
      edges_.insert(key(edges(e, 0), edges(e, 1)));
    }
    F_ = scan.F;
  }
  bool on_boundary(const SurfacePoint& p) const {
    constexpr double eps = 1e-7;
    for (int k = 0; k < 3; ++k) {
      if (p.barycentric[k] > 1 - eps && vertex_[size_t(F_(p.face, k))]) return true;
      if (p.barycentric[k] < eps && edges_.count(key(F_(p.face, (k + 1) % 3), F_(p.face, (k + 2) % 3)))) return true;
    }
    return false;
  }

 private:
  static uint64_t key(int a, int b) { return (uint64_t(std::min(a, b)) << 32) | uint64_t(std::max(a, b)); }
  std::vector<bool> vertex_;
  std::set<uint64_t> edges_;
  Eigen::MatrixX3i F_;
};

struct Correspondences {
  Eigen::MatrixX3d target;
  Eigen::VectorXi face;    // the scan triangle each target lies on
  Eigen::VectorXd weight;  // 0: rejected
};

// For every vertex of V, or only for `rows` (then row j of the result is vertex rows[j]).
Correspondences correspond(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, const SurfaceLocator& locator,
                           const Eigen::MatrixX3d& scan_normals, const BoundaryTest& boundary, double trim,
                           double huber, double min_cos, const std::vector<int>* rows = nullptr) {
  const Eigen::MatrixX3d N = vertex_normals(V, F);
  const Eigen::Index count = rows ? Eigen::Index(rows->size()) : V.rows();
  Correspondences c;
  c.target.resize(count, 3);
  c.face.resize(count);
  c.weight.setZero(count);
  parallel_for(0, count, [&](int64_t b, int64_t e) {
    for (int64_t j = b; j < e; ++j) {
      const Eigen::Index i = rows ? (*rows)[size_t(j)] : j;
      const SurfacePoint p = locator.locate(V.row(i).transpose());
      c.target.row(j) = p.point.transpose();
      c.face(j) = p.face;
      const double d = (p.point - V.row(i).transpose()).norm();
      if (d > trim || boundary.on_boundary(p)) continue;
      if (N.row(i).dot(scan_normals.row(p.face)) < min_cos) continue;
      c.weight(j) = d > huber ? huber / d : 1.0;
    }
  }, 1024);
  return c;
}

// The boundary edges of the longest border loop of a mesh: a face's outline (holes and openings are shorter).
Eigen::MatrixX2i outer_border(const Eigen::MatrixX3i& F) {
  const Eigen::MatrixX2i edges = boundary_edges(F);
  std::unordered_map<int, std::vector<int>> next;
  for (Eigen::Index e = 0; e < edges.rows(); ++e) {
    next[edges(e, 0)].push_back(edges(e, 1));
    next[edges(e, 1)].push_back(edges(e, 0));
  }
  std::unordered_map<int, int> loop;  // vertex -> loop id, by flood fill along the border
  std::vector<int> length;
  for (Eigen::Index e = 0; e < edges.rows(); ++e) {
    if (loop.count(edges(e, 0))) continue;
    const int id = int(length.size());
    std::vector<int> stack{edges(e, 0)};
    loop[edges(e, 0)] = id;
    while (!stack.empty()) {
      const int v = stack.back();
      stack.pop_back();
      for (const int w : next[v])
        if (loop.emplace(w, id).second) stack.push_back(w);
    }
    length.push_back(0);
  }
  for (Eigen::Index e = 0; e < edges.rows(); ++e) ++length[size_t(loop[edges(e, 0)])];
  const int outer = int(std::max_element(length.begin(), length.end()) - length.begin());
  Eigen::MatrixX2i out(length.empty() ? 0 : length[size_t(outer)], 2);
  Eigen::Index k = 0;
  for (Eigen::Index e = 0; e < edges.rows(); ++e)
    if (loop[edges(e, 0)] == outer) out.row(k++) = edges.row(e);
  return out;
}

// The closest point to p on the polyline of `edges` (rows of vertex ids into V).
Eigen::Vector3d closest_on_edges(const Eigen::Vector3d& p, const Eigen::MatrixX3d& V, const Eigen::MatrixX2i& edges) {
  double best = std::numeric_limits<double>::infinity();
  Eigen::Vector3d q = p;
  for (Eigen::Index e = 0; e < edges.rows(); ++e) {
    const Eigen::Vector3d a = V.row(edges(e, 0)).transpose(), ab = V.row(edges(e, 1)).transpose() - a;
    const Eigen::Vector3d x = a + std::clamp((p - a).dot(ab) / std::max(1e-12, ab.squaredNorm()), 0.0, 1.0) * ab;
    if ((x - p).squaredNorm() < best) best = (x - p).squaredNorm(), q = x;
  }
  return q;
}

// The scan as correspondences see it: closest points (AABB tree), face normals, boundary, the normal-angle limit, and
// (only when the outline term is on) its outer border; a scan without one is refused then.
struct ScanSurface {
  ScanSurface(const Mesh& scan, double max_normal_angle_deg, bool with_outline)
      : locator(scan.V, scan.F), normals(face_normals(scan.V, scan.F)), boundary(scan),
        min_cos(std::cos(max_normal_angle_deg * M_PI / 180)), V(scan.V),
        outline(with_outline ? outer_border(scan.F) : Eigen::MatrixX2i()) {
    if (with_outline && outline.rows() == 0) {
      throw InvalidInput("", "the scan has no open border, so --outline-weight has no outline to draw the template's to",
                         "leave --outline-weight at 0 for closed scans");
    }
  }
  SurfaceLocator locator;
  Eigen::MatrixX3d normals;
  BoundaryTest boundary;
  double min_cos;
  const Eigen::MatrixX3d& V;  // the scan's vertices (the scan outlives its surface)
  Eigen::MatrixX2i outline;
};

Correspondences correspond(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, const ScanSurface& s, double trim,
                           double huber, const std::vector<int>* rows = nullptr) {
  return correspond(V, F, s.locator, s.normals, s.boundary, trim, huber, s.min_cos, rows);
}

std::vector<int> landmark_ids(const RegisterOptions& options) {
  std::vector<int> ids = options.landmark_ids;
  if (ids.empty())
    for (int k = 0; k < 68; ++k) ids.push_back(k);
  for (const int k : ids)
    if (k < 0 || k >= 68) throw InvalidInput("", "landmark id " + std::to_string(k) + " is not in 0..67", "");
  return ids;
}

// Phase 1: the template placed on the scan by a similarity. With landmarks: Umeyama on them. Without: the documented
// fallback, centroid + RMS radius, then similarity ICP.
Eigen::MatrixX3d similarity_alignment(const TemplateFace& face, const Mesh& scan, const Landmarks* landmarks,
                                      const RegisterOptions& options, const ScanSurface& surface, RegistrationStats& stats) {
  const std::vector<int> ids = landmark_ids(options);
  if (landmarks) {
    const Eigen::MatrixX3d all = landmark_points(face);
    Eigen::MatrixX3d src(ids.size(), 3), dst(ids.size(), 3);
    for (size_t i = 0; i < ids.size(); ++i) src.row(Eigen::Index(i)) = all.row(ids[i]), dst.row(Eigen::Index(i)) = landmarks->points.row(ids[i]);
    const Eigen::Matrix4d T = Eigen::umeyama(src.transpose(), dst.transpose(), true);
    stats.used_landmarks = true;
    stats.similarity_scale = std::cbrt(T.topLeftCorner<3, 3>().determinant());
    stats.landmark_rms_after_similarity_mm = rms(transformed(T, src), dst);
    return transformed(T, face.mesh.V);
  }
  const Eigen::Index n = face.mesh.V.rows();
  const Eigen::RowVector3d ct = face.mesh.V.colwise().mean(), cs = scan.V.colwise().mean();
  const double rt = std::sqrt((face.mesh.V.rowwise() - ct).rowwise().squaredNorm().mean());
  const double rs = std::sqrt((scan.V.rowwise() - cs).rowwise().squaredNorm().mean());
  Eigen::MatrixX3d V0 = (((face.mesh.V.rowwise() - ct) * (rs / rt)).rowwise() + cs).eval();
  for (int it = 0; it < 20; ++it) {
    const Correspondences c = correspond(V0, face.mesh.F, surface, 1e9, 1e9);
    std::vector<Eigen::Index> keep;
    for (Eigen::Index i = 0; i < n; ++i)
      if (c.weight(i) > 0) keep.push_back(i);
    if (keep.size() < 100) throw InvalidInput("scan", "ICP found no overlap with the template", "give landmarks");
    Eigen::Matrix3Xd a(3, keep.size()), b(3, keep.size());
    for (size_t k = 0; k < keep.size(); ++k) {
      a.col(Eigen::Index(k)) = V0.row(keep[k]).transpose();
      b.col(Eigen::Index(k)) = c.target.row(keep[k]).transpose();
    }
    const Eigen::Matrix4d T = Eigen::umeyama(a, b, true);
    V0 = transformed(T, V0);
    if ((T - Eigen::Matrix4d::Identity()).norm() < 1e-6) break;
  }
  return V0;
}

// The transforms live on nodes: the aligned template remeshed to about `nodes` vertices (or every vertex). Each
// template vertex is embedded in a node triangle and moves by the barycentric blend of its corners' affines.
struct NodeEmbedding {
  Eigen::MatrixX3d V;
  Eigen::MatrixX3i F;
  std::vector<std::array<int, 3>> node;  // per template vertex: its node triangle's corners
  std::vector<Eigen::Vector3d> weight;   // ... and barycentric weights
};

// The node mesh of a template (template/node_layout.h): the template folder's when it was made for this surface and
// node count, else made here once per template and node count and kept for the process (a folder of scans pays once).
std::shared_ptr<const NodeLayout> node_layout(const TemplateFace& face, int nodes) {
  const uint64_t key = node_layout_fingerprint(face.mesh.V, face.mesh.F, nodes);
  if (face.nodes && face.nodes->template_fingerprint == key) return face.nodes;  // checked against the mesh when read
  static std::mutex mutex;
  static std::map<uint64_t, std::shared_ptr<const NodeLayout>> cache;
  std::lock_guard<std::mutex> lock(mutex);  // another scan's thread waits rather than remeshing the same template
  if (const auto it = cache.find(key); it != cache.end()) return it->second;
  auto layout = std::make_shared<const NodeLayout>(make_node_layout(face.mesh.V, face.mesh.F, nodes));
  cache.emplace(key, layout);
  return layout;
}

// V0: the template's vertices where NICP starts (the rest template after a similarity, or the model's fitted shape);
// the nodes follow V0 by their barycentric weights on the template's triangles.
NodeEmbedding embed_in_nodes(const TemplateFace& face, const Eigen::MatrixX3d& V0, int nodes) {
  const Eigen::MatrixX3i& F = face.mesh.F;
  const Eigen::Index n = V0.rows();
  NodeEmbedding e;
  if (uses_node_mesh(n, nodes)) {
    const std::shared_ptr<const NodeLayout> layout = node_layout(face, nodes);
    e.F = layout->F;
    e.V.resize(Eigen::Index(layout->face.size()), 3);
    for (Eigen::Index j = 0; j < e.V.rows(); ++j) {
      const int f = layout->face[size_t(j)];
      const Eigen::Vector3d& b = layout->on_face[size_t(j)];
      e.V.row(j) = b[0] * V0.row(F(f, 0)) + b[1] * V0.row(F(f, 1)) + b[2] * V0.row(F(f, 2));
    }
    e.node = layout->node;
    e.weight = layout->weight;
    return e;
  }
  e.node.resize(size_t(n));
  e.weight.resize(size_t(n));
  e.V = V0;
  e.F = F;
  for (Eigen::Index i = 0; i < n; ++i) {
    e.node[size_t(i)] = {int(i), int(i), int(i)};
    e.weight[size_t(i)] = Eigen::Vector3d(1, 0, 0);
  }
  return e;
}

// Stiffness, per node edge (i, j), in the variables X_i, X_j (4x3 affines acting on homogeneous points v):
//   c (|(X_i - X_j)^T v_i|^2 + |(X_i - X_j)^T v_j|^2) / |v_i - v_j|^2  +  a |G (X_i - X_j)|^2.
// The first part asks neighbouring affines to agree where the nodes are (embedded-deformation consistency, Sumner et
// al. 2007): unlike Amberg's term it does not depend on where the origin is. The second is Amberg's term; a little
// of it (a = 0.03) fixes the affines' normal direction. c = 0, a = 1 is Amberg's NICP as published (the benchmark's
// anchor). On the same nodes the consistency term cuts the correspondence error, most of it tangential slide on the nose
// (bench/register.sh; the figures in bench/BENCHMARKS.md, registration). Its pattern, plus full 4x4
// blocks on the diagonal (data) and between the corners of each landmark's node triangle (landmark term), is the
// pattern of every system, so CHOLMOD analyses it once.
Eigen::SparseMatrix<double> stiffness_matrix(const Eigen::MatrixX4d& v, const NodeEmbedding& e,
                                             const std::vector<int>& landmark_vertices, const RegisterOptions& options) {
  const Eigen::Index m = v.rows();
  std::set<uint64_t> edge_set;
  for (Eigen::Index f = 0; f < e.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = e.F(f, k), b = e.F(f, (k + 1) % 3);
      edge_set.insert((uint64_t(std::min(a, b)) << 32) | uint64_t(std::max(a, b)));
    }
  std::vector<Eigen::Triplet<double>> stiff;
  stiff.reserve(edge_set.size() * 16 + size_t(m) * 16);
  const auto full_block = [&](int i, int j) {
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) stiff.emplace_back(4 * i + a, 4 * j + b, 0.0);
  };
  for (Eigen::Index i = 0; i < m; ++i) full_block(int(i), int(i));
  for (int k = 0; k < 68; ++k) {
    for (int x : e.node[size_t(landmark_vertices[size_t(k)])])
      for (int y : e.node[size_t(landmark_vertices[size_t(k)])]) full_block(x, y);
  }
  for (uint64_t edge : edge_set) {
    const int i = int(edge >> 32), j = int(edge & 0xffffffffu);
    Eigen::Matrix4d Q = options.consistency * (v.row(i).transpose() * v.row(i) + v.row(j).transpose() * v.row(j)) /
                        (v.row(i) - v.row(j)).squaredNorm();
    for (int a = 0; a < 4; ++a) Q(a, a) += options.affine_stiffness * (a < 3 ? 1.0 : options.gamma * options.gamma);
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) {
        stiff.emplace_back(4 * i + a, 4 * i + b, Q(a, b));
        stiff.emplace_back(4 * j + a, 4 * j + b, Q(a, b));
        stiff.emplace_back(4 * i + a, 4 * j + b, -Q(a, b));
        stiff.emplace_back(4 * j + a, 4 * i + b, -Q(a, b));
      }
  }
  Eigen::SparseMatrix<double> K(4 * m, 4 * m);
  K.setFromTriplets(stiff.begin(), stiff.end());
  return K;
}

// Correspondences of dense template vertices (landmarks, texture targets): blended rows of the node affines.
struct DenseTerm {
  std::vector<int> vertex;
  std::vector<Eigen::Vector3d> point;  // mm
  std::vector<double> weight;          // squared-residual weights
};

// The similarity under which `rest` best explains `current` as displacements along its `normals`: the (s, R, t)
// minimising sum_i |P_i (x_i - (s R r_i + t))|^2, P_i = I - (R n_i)(R n_i)^T, by Gauss-Newton from `frame` (the
// normals held within an iteration; updates R <- exp([w]x) R, s <- s e^sigma, t <- t + tau).
Similarity normal_displacement_frame(const Eigen::MatrixX3d& rest, const Eigen::MatrixX3d& normals,
                                     const Eigen::MatrixX3d& current, Similarity frame) {
  for (int it = 0; it < 8; ++it) {
    Eigen::Matrix<double, 7, 7> H = Eigen::Matrix<double, 7, 7>::Zero();
    Eigen::Matrix<double, 7, 1> g = Eigen::Matrix<double, 7, 1>::Zero();
    for (Eigen::Index i = 0; i < rest.rows(); ++i) {
      const Eigen::Vector3d a = frame.s * frame.R * rest.row(i).transpose(), n = frame.R * normals.row(i).transpose();
      const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - n * n.transpose();
      Eigen::Matrix<double, 3, 7> J;  // d(s R r + t) / d(w, sigma, tau)
      J.leftCols<3>() << 0, a.z(), -a.y(), -a.z(), 0, a.x(), a.y(), -a.x(), 0;  // -[a]x
      J.col(3) = a;
      J.rightCols<3>().setIdentity();
      const Eigen::Matrix<double, 3, 7> PJ = P * J;
      H += PJ.transpose() * PJ;
      g += PJ.transpose() * (P * (current.row(i).transpose() - a - frame.t));
    }
    H.diagonal().array() += 1e-9 * (1 + H.diagonal().array());  // a flat patch leaves directions unobserved
    const Eigen::Matrix<double, 7, 1> d = H.ldlt().solve(g);
    if (!d.allFinite()) break;
    const Eigen::Vector3d w = d.head<3>();
    if (w.norm() > 0) frame.R = Eigen::AngleAxisd(w.norm(), w / w.norm()).toRotationMatrix() * frame.R;
    frame.s *= std::exp(d(3));
    frame.t += d.tail<3>();
    if (d.norm() < 1e-10) break;
  }
  return frame;
}

// Phase 2: optimal-step NICP in normalised coordinates (centred, unit RMS radius), so the schedules do not depend on
// size. Per iteration: A = alpha^2 K + sum_i w_i v_i v_i^T + beta^2 r^T r per landmark (r: the landmark's blended row)
// [+ w_t r^T r per texture target]; B likewise; X = A^-1 B. dense(): each template vertex by the blend of its node
// triangle's affines.
class Nicp {
 public:
  Nicp(const TemplateFace& face, const Eigen::MatrixX3d& V0, const Landmarks* landmarks, const RegisterOptions& options,
       const ScanSurface& surface, RegistrationStats& stats)
      : face_(face), options_(options), surface_(surface), stats_(stats), ids_(landmark_ids(options)),
        centre_(V0.colwise().mean()),
        radius_(std::sqrt((V0.rowwise() - centre_).rowwise().squaredNorm().mean())),
        e_(timed(stats.seconds_nodes, [&] { return embed_in_nodes(face, V0, options.nodes); })),
        m_(e_.V.rows()) {
    stats.nodes = int(m_);
    v_ = homogeneous(e_.V);
    v_dense_ = homogeneous(V0);
    const std::vector<double> sigma_weight =
        options.sigma_weighted_nicp ? landmark_sigma_weights(options.landmark_sigma_mm) : std::vector<double>{};
    if (landmarks) {
      for (const int k : ids_) {
        landmarks_.vertex.push_back(face.landmark_vertices[size_t(k)]);
        landmarks_.point.push_back(landmarks->points.row(k).transpose());
        landmarks_.weight.push_back(sigma_weight.empty() ? 1.0 : sigma_weight[size_t(k)]);
      }
    }
    if (options.outline_weight > 0) {
      const Eigen::MatrixX2i border = outer_border(face.mesh.F);
      outline_.assign(border.data(), border.data() + border.size());
      std::sort(outline_.begin(), outline_.end());
      outline_.erase(std::unique(outline_.begin(), outline_.end()), outline_.end());
    }
    rest_normal_ = vertex_normals(v_.leftCols<3>(), e_.F);
    K_ = stiffness_matrix(v_, e_, face.landmark_vertices, options);
    solver_.analyzePattern(K_);
    X_ = Eigen::MatrixXd::Zero(4 * m_, 3);
    for (Eigen::Index i = 0; i < m_; ++i) X_.block<3, 3>(4 * i, 0).setIdentity();
  }

  // The stiffness schedule (alpha relaxed step by step, beta decaying).
  void run(const ProgressCallback& progress) {
    const int steps = int(options_.stiffness.size());
    for (int s = 0; s < steps; ++s) {
      for (int it = 0; it < options_.iterations_per_step; ++it)
        if (iterate(s, 1.0, nullptr) < 1e-4) break;
      report(progress, s + 1, steps, "NICP steps");
    }
  }

  // One iteration at step s's stiffness, landmark weight and trim; the closest-point term scaled by data_scale, plus
  // `extra` dense correspondences. Returns the change of the affines (RMS per node).
  double iterate(int s, double data_scale, const DenseTerm* extra, double stiffness = 0) {
    const double alpha = stiffness > 0 ? stiffness : options_.stiffness[size_t(s)];
    const double beta = landmarks_.vertex.empty() ? 0.0 : landmark_scale_ * options_.landmark_weight[size_t(s)];
    const auto t_c = std::chrono::steady_clock::now();
    const Correspondences c = correspond(nodes_mm(), e_.F, surface_, options_.trim_mm[size_t(s)], options_.huber_mm);
    stats_.seconds_correspond += seconds_since(t_c);
    Eigen::SparseMatrix<double> A = alpha * alpha * K_;
    Eigen::MatrixXd B = Eigen::MatrixXd::Zero(4 * m_, 3);
    for (Eigen::Index i = 0; i < m_; ++i) {
      if (c.weight(i) <= 0) continue;
      const double w = data_scale * c.weight(i);
      const Eigen::RowVector4d vi = v_.row(i);
      for (int b = 0; b < 4; ++b)
        for (int a = 0; a < 4; ++a) A.coeffRef(4 * i + a, 4 * i + b) += w * vi[a] * vi[b];
      B.block<4, 3>(4 * i, 0) += w * vi.transpose() * ((c.target.row(i) - centre_) / radius_);
    }
    for (size_t j = 0; j < landmark_line_.size(); ++j) {
      const Eigen::Vector3d& d = landmark_line_[j];
      if (d.squaredNorm() == 0) continue;
      const Eigen::Vector3d x = (dense(landmarks_.vertex[j]) * radius_ + centre_).transpose();
      landmarks_.point[j] = landmark_point_[j] + (x - landmark_point_[j]).dot(d) * d;
    }
    if (beta > 0) add_dense(landmarks_, beta * beta, A, B);
    if (!outline_.empty()) add_dense(outline_term(), 1.0, A, B);
    if (extra) add_dense(*extra, 1.0, A, B);
    const double w_t = options_.tangential_weight.empty() || stiffness > 0 ? 0.0 : options_.tangential_weight[size_t(s)];
    if (w_t > 0) update_tangential_reference();
    if (w_t > 0)
      for (Eigen::Index i = 0; i < m_; ++i)
        for (int b = 0; b < 4; ++b)
          for (int a = 0; a < 4; ++a) A.coeffRef(4 * i + a, 4 * i + b) += w_t * v_(i, a) * v_(i, b);
    const auto t_f = std::chrono::steady_clock::now();
    solver_.factorize(A);
    if (solver_.info() != Eigen::Success) throw InternalError("NICP: the sparse system is not positive definite");
    Eigen::MatrixXd X_new = solver_.solve(B + tangential_rhs(w_t, X_));
    // The tangential term w_t |P_i (x_i - s_i)|^2 couples x, y, z; majorised by w_t |x_i - t_i|^2 with t_i the point
    // of the reference normal line nearest the last solution, a few solves with the same factor reach its minimum.
    for (int inner = 0; w_t > 0 && inner < kTangentialSolves; ++inner) X_new = solver_.solve(B + tangential_rhs(w_t, X_new));
    stats_.seconds_factorize += seconds_since(t_f);
    const double change = (X_new - X_).norm() / std::sqrt(double(m_));
    X_ = X_new;
    ++stats_.iterations;
    return change;
  }

  Eigen::MatrixX3d dense() const {
    const Eigen::Index n = v_dense_.rows();
    Eigen::MatrixX3d out(n, 3);
    for (Eigen::Index i = 0; i < n; ++i) out.row(i) = dense(i);
    return to_mm(out);
  }
  Eigen::Index node_count() const { return m_; }
  const std::vector<int>& outline() const { return outline_; }  // the template's outline vertices (outline_weight > 0)
  void scale_landmark_weights(double scale) { landmark_scale_ = scale; }
  // More points held like landmarks (with the landmarks' schedule), each `weight` times a landmark's.
  void add_landmark_points(const std::vector<int>& vertex, const std::vector<Eigen::Vector3d>& point, double weight) {
    landmarks_.vertex.insert(landmarks_.vertex.end(), vertex.begin(), vertex.end());
    landmarks_.point.insert(landmarks_.point.end(), point.begin(), point.end());
    landmarks_.weight.insert(landmarks_.weight.end(), vertex.size(), weight);
  }
  // Landmarks known only across a line (`lines`: iBUG index, unit direction): their targets slide along the line to
  // the point nearest the registration's landmark at each iteration, so only the offset across the line is held.
  void set_landmark_lines(const std::vector<std::pair<int, Eigen::Vector3d>>& lines) {
    landmark_line_.assign(landmarks_.vertex.size(), Eigen::Vector3d::Zero());
    landmark_point_ = landmarks_.point;
    for (const auto& [k, d] : lines)
      for (size_t j = 0; j < ids_.size(); ++j)
        if (ids_[j] == k) landmark_line_[j] = d;
  }

 private:
  Eigen::MatrixX4d homogeneous(const Eigen::MatrixX3d& P) const {
    Eigen::MatrixX4d h(P.rows(), 4);
    h.leftCols<3>() = (P.rowwise() - centre_) / radius_;
    h.col(3).setOnes();
    return h;
  }
  Eigen::MatrixX3d to_mm(const Eigen::MatrixX3d& P) const { return Eigen::MatrixX3d((P * radius_).rowwise() + centre_); }
  Eigen::MatrixX3d nodes_mm() const {
    Eigen::MatrixX3d P(m_, 3);
    for (Eigen::Index i = 0; i < m_; ++i) P.row(i) = v_.row(i) * X_.block<4, 3>(4 * i, 0);
    return to_mm(P);
  }
  // The tangential prior's reference: the start nodes under the similarity that best explains the current nodes as
  // displacements along the start's normals (refitted at every iteration from the last frame): a reference that has
  // the scan's placement and scale but none of its shape, so a bump pushes the points over it outward, not aside.
  void update_tangential_reference() {
    Eigen::MatrixX3d x(m_, 3);
    for (Eigen::Index i = 0; i < m_; ++i) x.row(i) = v_.row(i) * X_.block<4, 3>(4 * i, 0);
    const Eigen::MatrixX3d rest = v_.leftCols<3>();
    frame_ = normal_displacement_frame(rest, rest_normal_, x, frame_);
    start_ = (frame_.s * rest * frame_.R.transpose()).rowwise() + frame_.t.transpose();
    start_normal_ = rest_normal_ * frame_.R.transpose();
  }
  static constexpr int kTangentialSolves = 4;
  // The tangential term's right-hand side: w_t v_i^T t_i per node, t_i = s_i + ((x_i - s_i) . n_i) n_i, where x_i is
  // node i under X, s_i its reference position and n_i the reference normal (normalised coordinates).
  Eigen::MatrixXd tangential_rhs(double w_t, const Eigen::MatrixXd& X) const {
    Eigen::MatrixXd R = Eigen::MatrixXd::Zero(4 * m_, 3);
    if (w_t <= 0) return R;
    for (Eigen::Index i = 0; i < m_; ++i) {
      const Eigen::RowVector3d start = start_.row(i), n = start_normal_.row(i);
      const Eigen::RowVector3d x = v_.row(i) * X.block<4, 3>(4 * i, 0);
      const Eigen::RowVector3d t = start + (x - start).dot(n) * n;
      R.block<4, 3>(4 * i, 0) = w_t * v_.row(i).transpose() * t;
    }
    return R;
  }
  // scale * sum_j w_j |blend_j(X) - p_j|^2, accumulated per node block first (many targets share a few blocks).
  void add_dense(const DenseTerm& t, double scale, Eigen::SparseMatrix<double>& A, Eigen::MatrixXd& B) const {
    std::unordered_map<uint64_t, Eigen::Matrix4d> blocks;
    for (size_t j = 0; j < t.vertex.size(); ++j) {
      const int vertex = t.vertex[j];
      const double w = scale * t.weight[j];
      const Eigen::RowVector4d x = v_dense_.row(vertex);
      const Eigen::Matrix4d xx = x.transpose() * x;
      const Eigen::RowVector3d target = (t.point[j].transpose() - centre_) / radius_;
      const auto& nodes = e_.node[size_t(vertex)];
      const Eigen::Vector3d& b = e_.weight[size_t(vertex)];
      for (int p = 0; p < 3; ++p) {
        for (int q = 0; q < 3; ++q) {
          const uint64_t key = (uint64_t(nodes[size_t(p)]) << 32) | uint64_t(nodes[size_t(q)]);
          auto [it, fresh] = blocks.try_emplace(key, Eigen::Matrix4d::Zero());
          it->second += w * b[p] * b[q] * xx;
        }
        B.block<4, 3>(4 * nodes[size_t(p)], 0) += w * b[p] * x.transpose() * target;
      }
    }
    for (const auto& [key, block] : blocks) {
      const int p = int(key >> 32), q = int(key & 0xffffffffu);
      for (int b = 0; b < 4; ++b)
        for (int a = 0; a < 4; ++a) A.coeffRef(4 * p + a, 4 * q + b) += block(a, b);
    }
  }

  // Template vertex i where the nodes' affines now put it (normalised coordinates).
  Eigen::RowVector3d dense(Eigen::Index i) const {
    Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
    for (int k = 0; k < 3; ++k)
      p += e_.weight[size_t(i)][k] * (v_dense_.row(i) * X_.block<4, 3>(4 * e_.node[size_t(i)][size_t(k)], 0));
    return p;
  }

  // The outline term: each template outline vertex drawn to the closest point of the scan's outer border.
  DenseTerm outline_term() const {
    DenseTerm t;
    for (const int v : outline_) {
      const Eigen::Vector3d p = (dense(v) * radius_ + centre_).transpose();
      t.vertex.push_back(v);
      t.point.push_back(closest_on_edges(p, surface_.V, surface_.outline));
      t.weight.push_back(options_.outline_weight);
    }
    return t;
  }

  const TemplateFace& face_;
  const RegisterOptions& options_;
  const ScanSurface& surface_;
  RegistrationStats& stats_;
  std::vector<int> ids_;
  Eigen::RowVector3d centre_;
  double radius_;
  NodeEmbedding e_;
  Eigen::Index m_;
  Eigen::MatrixX4d v_, v_dense_;
  Eigen::MatrixX3d rest_normal_;           // the start nodes' normals
  Similarity frame_;                       // the tangential prior's frame: start nodes -> reference
  Eigen::MatrixX3d start_, start_normal_;  // the tangential prior's reference nodes and normals (normalised coordinates)
  DenseTerm landmarks_;
  std::vector<Eigen::Vector3d> landmark_line_, landmark_point_;  // per landmark: its line's direction (0: a point)
  std::vector<int> outline_;  // the template's outline vertices (outline_weight > 0)
  double landmark_scale_ = 1;
  Eigen::SparseMatrix<double> K_;
  Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>, Eigen::Lower> solver_;
  Eigen::MatrixXd X_;
};

// `from` under the similarity that best maps its `use` rows onto the same rows of `to` (Umeyama; all rows when
// fewer than 100 are in use).
Eigen::MatrixX3d similarity_onto(const Eigen::MatrixX3d& from, const Eigen::MatrixX3d& to, const std::vector<bool>& use) {
  Eigen::Matrix3Xd a(3, from.rows()), b(3, from.rows());
  Eigen::Index n = 0;
  for (Eigen::Index i = 0; i < from.rows(); ++i)
    if (use[size_t(i)]) a.col(n) = from.row(i).transpose(), b.col(n++) = to.row(i).transpose();
  if (n < 100) a = from.transpose(), b = to.transpose(), n = from.rows();
  return transformed(Eigen::umeyama(a.leftCols(n), b.leftCols(n), true), from);
}

// The outer lip line's side points (49, 53, 55, 59) and the direction of the lip line there (from their found
// neighbours). A flow sees an edge's offset across it, not where along it a point lies (the aperture problem): these
// points came out 2-4 mm off along the lip line on half the held-out scans, so the rounds hold them across it only.
std::vector<std::pair<int, Eigen::Vector3d>> lip_side_lines(const TextureLandmarks& found) {
  const auto has = [&](int k) { return std::binary_search(found.ids.begin(), found.ids.end(), k); };
  std::vector<std::pair<int, Eigen::Vector3d>> lines;
  for (const auto& [k, a, b] : {std::array<int, 3>{49, 48, 50}, {53, 52, 54}, {55, 54, 56}, {59, 58, 48}}) {
    if (!has(k) || !has(a) || !has(b)) continue;
    const Eigen::Vector3d d = (found.landmarks.points.row(b) - found.landmarks.points.row(a)).transpose();
    if (d.norm() > 1e-6) lines.emplace_back(k, d.normalized());
  }
  return lines;
}

// Phase 1b (with a model, model_prior.h): the model's shape fitted to the scan from the similarity's placement.
Eigen::MatrixX3d fit_model_prior(const MorphableModel& model, const Eigen::MatrixX3d& V0, const Landmarks* landmarks,
                                 const RegisterOptions& options, const ScanSurface& surface, RegistrationStats& stats) {
  const auto t0 = std::chrono::steady_clock::now();
  const Eigen::MatrixX3i& F = model.topology.F;
  const ScanTargetQuery query = [&](const Eigen::MatrixX3d& V, const std::vector<int>& rows, double trim) {
    const Correspondences c = correspond(V, F, surface, trim, options.huber_mm, &rows);
    ScanTargets t;
    t.point = c.target;
    t.weight = c.weight;
    t.normal.resize(c.target.rows(), 3);
    for (Eigen::Index j = 0; j < c.target.rows(); ++j) t.normal.row(j) = surface.normals.row(c.face(j)).normalized();
    return t;
  };
  const Eigen::MatrixX3d points = landmarks ? Eigen::MatrixX3d(landmarks->points) : Eigen::MatrixX3d();
  const ModelPriorFit fit = fit_model_to_scan(model, V0, query, landmarks ? &points : nullptr, landmark_ids(options),
                                              options.landmark_sigma_mm, options.prior);
  stats.used_model = true;
  stats.model_rms_mm = fit.rms_mm;
  stats.model_alpha_norm = fit.alpha.norm();
  stats.model_landmark_rms_mm = fit.landmark_rms_mm;
  stats.model_vertices_used = fit.vertices_used;
  stats.seconds_model = seconds_since(t0);
  return fit.V;
}

// Phase 3: accepted vertices go onto the scan (the last step's rejection rules).
void project_onto_scan(Registration& out, const Eigen::MatrixX3i& F, const ScanSurface& surface,
                       const RegisterOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const Correspondences c = correspond(out.V, F, surface, options.trim_mm.back(), 1e9);
  const Eigen::Index n = out.V.rows();
  out.accepted.assign(size_t(n), false);
  int accepted = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (c.weight(i) <= 0) continue;
    out.accepted[size_t(i)] = true;
    ++accepted;
    if (options.project) out.V.row(i) = c.target.row(i);
  }
  out.stats.accepted_fraction = double(accepted) / double(n);
  out.stats.seconds_project += seconds_since(t0);
}

// Phase 4 (texture refinement, texture_refine.h): rounds of transfer, flow to the reference and NICP iterations at
// the last stiffness with the texture targets as soft correspondences.
void texture_rounds(const TemplateFace& face, const Mesh& scan, const RegistrationTexture& texture,
                    const RegisterOptions& options, const ScanSurface& surface, Nicp& nicp, Registration& out) {
  const TextureRefineOptions& o = options.texture;
  const RasterOutput raster = rasterize_uv(face.mesh, o.resolution);
  const Image reference = resample_square(*texture.reference, o.resolution);
  const Plane fixed = texture_structure(reference, layout_mask(raster), o.structure_sigma * o.resolution / 256, o.structure_floor);
  const int last = int(options.stiffness.size()) - 1;
  const double per_vertex = o.weight * double(nicp.node_count()) / double(face.mesh.V.rows());
  for (int round = 0; round < o.iterations; ++round) {
    std::vector<uint8_t> valid;
    const Image moved = transfer_diffuse(raster, face.mesh, out.V, scan, surface.locator, *texture.scan_diffuse, valid);
    const UvFlow flow = uv_flow(texture_structure(moved, valid, o.structure_sigma * o.resolution / 256, o.structure_floor), fixed, valid, o);
    const TextureTargets t = texture_targets(face.mesh, out.V, raster, flow, surface.locator, o);
    DenseTerm term;
    term.vertex = t.vertex;
    term.point = t.point;
    for (const double c : t.confidence) term.weight.push_back(per_vertex * c);
    for (int it = 0; it < o.nicp_iterations; ++it) nicp.iterate(last, o.data_weight, &term, o.stiffness);
    out.V = nicp.dense();
    project_onto_scan(out, face.mesh.F, surface, options);
    out.stats.texture_targets.push_back(int(t.vertex.size()));
    out.stats.texture_median_flow_mm.push_back(t.median_move_mm);
  }
}

// The hand-placed landmarks' weights (RegisterOptions' default) for a schedule of `steps` steps: the default when the
// lengths agree, else from its first value to its last, geometrically.
std::vector<double> hand_placed_landmark_weights(size_t steps) {
  const std::vector<double> w = RegisterOptions{}.landmark_weight;
  if (steps == w.size()) return w;
  std::vector<double> out(steps, w.front());
  for (size_t k = 1; k < steps; ++k) out[k] = w.front() * std::pow(w.back() / w.front(), double(k) / double(steps - 1));
  return out;
}

}  // namespace

void RegisterOptions::check() const {
  if (stiffness.empty()) throw InvalidInput("", "the stiffness schedule is empty", "give at least one step");
  if (landmark_weight.size() != stiffness.size() || trim_mm.size() != stiffness.size() ||
      (!tangential_weight.empty() && tangential_weight.size() != stiffness.size())) {
    throw InvalidInput("", "stiffness, landmark weight, trim and tangential weight schedules differ in length", "give one value per step");
  }
  if (!(outline_weight >= 0 && outline_weight < 1e6)) {
    throw InvalidInput("", "--outline-weight must be >= 0", "0 is off; 0.3 is the measured best for scans cut at the outline");
  }
  for (size_t k = 0; k < stiffness.size(); ++k) {
    if (!(stiffness[k] > 0) || !(landmark_weight[k] >= 0) || !(trim_mm[k] > 0) ||
        (!tangential_weight.empty() && !(tangential_weight[k] >= 0))) {
      throw InvalidInput("", "schedules need stiffness > 0, landmark and tangential weights >= 0 and trim > 0",
                         "fix the values of --stiffness, --landmark-weight, --tangential-weight and --trim");
    }
  }
  texture.check();
  prior.check();
  if (!landmark_sigma_mm.empty() && landmark_sigma_mm.size() != 68) {
    throw InvalidInput("", "landmark uncertainties must be 68 values (one per iBUG point) or none", "");
  }
  if (nodes < 0 || (nodes > 0 && nodes < 500)) throw InvalidInput("", "--nodes must be 0 (every vertex) or >= 500", "");
  if (iterations_per_step < 1 || iterations_per_step > 100) throw InvalidInput("", "--iterations must lie in [1, 100]", "");
  if (!(affine_stiffness > 0) || !(consistency >= 0)) {
    throw InvalidInput("", "--affine-stiffness must be > 0 and --consistency >= 0", "");
  }
  if (!(gamma > 0) || !(huber_mm > 0)) throw InvalidInput("", "gamma and the Huber threshold must be > 0", "");
  if (!(max_normal_angle_deg > 0 && max_normal_angle_deg <= 180)) {
    throw InvalidInput("", "--max-normal-angle must lie in (0, 180] degrees", "");
  }
}

void check_scan_landmarks(const TemplateFace& face, const Landmarks& landmarks, const std::string& source) {
  if (landmarks.points.rows() != 68 || landmarks.points.cols() != 3) {
    throw InvalidInput(source, "needs 68 3D iBUG landmarks", "give the scan's landmarks.json");
  }
  const Eigen::MatrixX3d src = landmark_points(face), dst = landmarks.points;
  const double eyes = (dst.row(36) - dst.row(45)).norm(), template_eyes = (src.row(36) - src.row(45)).norm();
  char what[200];
  if (eyes < 0.02 * template_eyes) {
    std::snprintf(what, sizeof what, "outer eye corners are %.4g apart, faces about %.0f mm: the scan looks like metres",
                  eyes, template_eyes);
    throw InvalidInput(source, what, "rerun with --scale 1000 (scan register reads both in millimetres)");
  }
  if (eyes > 20 * template_eyes) {
    std::snprintf(what, sizeof what, "outer eye corners are %.4g apart, faces about %.0f mm: not millimetres", eyes,
                  template_eyes);
    throw InvalidInput(source, what, "convert the scan and its landmarks to millimetres");
  }
  const Eigen::Matrix4d T = Eigen::umeyama(src.transpose(), dst.transpose(), true);
  const double scale = std::cbrt(T.topLeftCorner<3, 3>().determinant());
  const double fit = rms(transformed(T, src), dst) / scale;  // in template millimetres
  if (fit < 8) return;
  Eigen::MatrixX3d mirrored = dst;
  mirrored.col(0) *= -1;
  const Eigen::Matrix4d M = Eigen::umeyama(src.transpose(), mirrored.transpose(), true);
  const double mirrored_fit = rms(transformed(M, src), mirrored) / std::cbrt(M.topLeftCorner<3, 3>().determinant());
  if (mirrored_fit < 0.5 * fit) {
    std::snprintf(what, sizeof what, "landmarks fit the template only when mirrored (RMS %.1f mm, mirrored %.1f mm)", fit,
                  mirrored_fit);
    throw InvalidInput(source, what, "the scan is mirrored: flip one axis of the scan and its landmarks");
  }
  std::snprintf(what, sizeof what, "landmarks do not fit the template's iBUG-68 layout (RMS %.1f mm after a similarity)",
                fit);
  throw InvalidInput(source, what, "check that they are the 68 iBUG points in order, on this scan");
}

Registration register_scan(const TemplateFace& face, const Mesh& scan, const Landmarks* landmarks,
                           const RegisterOptions& options, const ProgressCallback& progress,
                           const RegistrationTexture& texture, const MorphableModel* model) {
  options.check();
  const auto t_start = std::chrono::steady_clock::now();
  Registration out;
  RegistrationStats& stats = out.stats;
  const ScanSurface surface(scan, options.max_normal_angle_deg, options.outline_weight > 0);

  // 1. Similarity: Umeyama on the landmarks, or the documented fallback (centroid + RMS radius, then similarity ICP).
  Eigen::MatrixX3d V0 = similarity_alignment(face, scan, landmarks, options, surface, stats);
  stats.seconds_similarity = seconds_since(t_start);

  // 1b. With a model: its shape fitted to the scan; NICP starts there and leans less on the landmarks.
  if (model) {
    check_model_template(*model, face.mesh, face.landmark_vertices, "--model");
    V0 = fit_model_prior(*model, V0, landmarks, options, surface, stats);
    out.V_model = V0;
  }

  // 2. Optimal-step NICP on the nodes, the dense template following them.
  const auto t_nicp = std::chrono::steady_clock::now();
  auto nicp = std::make_unique<Nicp>(face, V0, landmarks, options, surface, stats);
  if (model) nicp->scale_landmark_weights(options.prior.nicp_landmark_scale);
  nicp->run(progress);
  out.V = nicp->dense();

  // 3. Projection: accepted vertices go onto the scan (the last step's rejection rules).
  project_onto_scan(out, face.mesh.F, surface, options);
  stats.seconds_nicp = seconds_since(t_nicp);

  // 3b. Texture landmarks: the brows, eyes and lips where the scan's texture puts them, the nose where its shape does,
  // then NICP again from them. out.texture_landmarks: the last round used.
  const bool textured = texture.scan_diffuse && texture.reference;
  TextureLandmarks& found = out.texture_landmarks;
  RegisterOptions again = options;  // outlives the Nicp that refers to it
  again.landmark_weight = hand_placed_landmark_weights(options.stiffness.size());
  again.sigma_weighted_nicp = false;
  std::unique_ptr<TextureLandmarkFinder> finder;
  for (int round = 0; textured && round < options.texture.landmark_rounds; ++round) {
    const auto t_round = std::chrono::steady_clock::now();
    if (!finder) finder = std::make_unique<TextureLandmarkFinder>(face, *texture.reference, options.texture);
    TextureLandmarks next = finder->find(out.V, scan, surface.locator, *texture.scan_diffuse);
    stats.texture_landmarks_found.push_back(int(next.ids.size()));
    stats.shape_points_found.push_back(int(next.shape_vertex.size()));
    stats.texture_landmarks_move_mm.push_back(next.median_move_mm);
    if (next.ids.size() < 10) {  // too few features in this texture: keep the registration
      stats.seconds_texture_landmarks += seconds_since(t_round);
      break;
    }
    found = std::move(next);
    again.landmark_ids = found.ids;
    // The start: the template placed on the last registration's whole surface. The found points (brows to lips) hold
    // the middle of the face only; their similarity put the outline mm off, which NICP's tangential prior then kept.
    V0 = similarity_onto(face.mesh.V, out.V, out.accepted);
    nicp = std::make_unique<Nicp>(face, V0, &found.landmarks, again, surface, stats);
    nicp->set_landmark_lines(lip_side_lines(found));
    nicp->add_landmark_points(found.shape_vertex, found.shape_point, options.texture.shape_point_weight);
    nicp->run({});
    out.V = nicp->dense();
    project_onto_scan(out, face.mesh.F, surface, again);
    stats.seconds_texture_landmarks += seconds_since(t_round);
  }

  // 4. Texture refinement: the scan's texture says where along the surface each point belongs.
  if (options.texture.iterations > 0 && textured) {
    const auto t_texture = std::chrono::steady_clock::now();
    out.V_before_texture = out.V;
    texture_rounds(face, scan, texture, options, surface, *nicp, out);
    stats.seconds_texture = seconds_since(t_texture);
  }
  if (options.outline_weight > 0) {
    std::vector<double> d;
    for (const int v : nicp->outline())
      d.push_back((closest_on_edges(out.V.row(v).transpose(), scan.V, surface.outline) - out.V.row(v).transpose()).norm());
    stats.outline_median_mm = quantile(d, 0.5), stats.outline_max_mm = *std::max_element(d.begin(), d.end());
  }
  return out;
}

Registration refine_with_texture(const TemplateFace& face, const Mesh& scan, const Eigen::MatrixX3d& V,
                                 const Landmarks* landmarks, const RegisterOptions& options,
                                 const RegistrationTexture& texture) {
  options.check();
  if (!texture.scan_diffuse || !texture.reference || options.texture.iterations < 1) {
    throw InvalidInput("", "the texture refinement needs the scan's diffuse, a reference and at least one round", "");
  }
  if (V.rows() != face.mesh.V.rows()) throw InvalidInput("", "the registration to refine is not in the template's topology", "");
  const auto t0 = std::chrono::steady_clock::now();
  Registration out;
  out.V = V;
  out.V_before_texture = V;
  const ScanSurface surface(scan, options.max_normal_angle_deg, options.outline_weight > 0);
  Nicp nicp(face, V, landmarks, options, surface, out.stats);
  texture_rounds(face, scan, texture, options, surface, nicp, out);
  out.stats.used_landmarks = landmarks != nullptr;
  out.stats.seconds_texture = seconds_since(t0);
  return out;
}

RegistrationErrors measure_registration(const TemplateFace& face, const Eigen::MatrixX3d& V, const Mesh& scan,
                                        const Landmarks* landmarks, const Eigen::MatrixX3d* truth_point,
                                        const Eigen::VectorXi* truth_face) {
  RegistrationErrors e;
  const SurfaceLocator locator(scan.V, scan.F);
  std::vector<double> distance(size_t(V.rows()));
  parallel_for(0, V.rows(), [&](int64_t b, int64_t end) {
    for (int64_t i = b; i < end; ++i) distance[size_t(i)] = (locator.locate(V.row(i).transpose()).point - V.row(i).transpose()).norm();
  }, 1024);
  e.distance_median = quantile(distance, 0.5);
  e.distance_p95 = quantile(distance, 0.95);
  e.distance_max = *std::max_element(distance.begin(), distance.end());
  e.per_vertex = Eigen::Map<Eigen::VectorXd>(distance.data(), Eigen::Index(distance.size()));
  if (truth_point && truth_point->rows() == V.rows()) {
    e.has_truth = true;
    std::vector<double> errors;
    for (Eigen::Index i = 0; i < V.rows(); ++i) {
      e.per_vertex(i) = (V.row(i) - truth_point->row(i)).norm();
      if (!truth_face || (*truth_face)(i) >= 0) errors.push_back(e.per_vertex(i));
    }
    e.correspondence_median = quantile(errors, 0.5);
    e.correspondence_p95 = quantile(errors, 0.95);
    e.correspondence_max = errors.empty() ? 0 : *std::max_element(errors.begin(), errors.end());
  }
  if (landmarks && landmarks->points.rows() == 68 && landmarks->points.cols() == 3) {
    e.has_landmarks = true;
    for (int k = 0; k < 68; ++k) {
      const double d = (V.row(face.landmark_vertices[size_t(k)]) - landmarks->points.row(k)).norm();
      e.landmark_mean += d / 68;
      e.landmark_max = std::max(e.landmark_max, d);
    }
  }
  return e;
}

}  // namespace bareskin
