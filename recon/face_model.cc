#include "recon/face_model.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <utility>

#include "core/error.h"
#include "core/safetensors.h"
#include "render/sh.h"
#include "training/tensor_io.h"

namespace bareskin::recon {
namespace {

namespace F = torch::nn::functional;

torch::Tensor tensor_of(const SafeTensors& file, const std::string& path, const std::string& name, DType dtype,
                        const std::vector<int64_t>& shape) {
  bool found = false;
  for (const std::string& n : file.names()) found = found || n == name;
  if (!found) throw InvalidInput(path, "the model has no tensor '" + name + "'", "rebuild it with mm-build");
  return to_tensor(file.tensor(name, dtype, shape), path);
}

// α/β/δ lists of a coefficient file: at most `n` finite numbers, padded with 0.
void read_list(const nlohmann::json& j, const char* key, int64_t n, float* out, const std::string& source) {
  if (!j.contains(key)) return;
  const nlohmann::json& v = j.at(key);
  if (!v.is_array() || int64_t(v.size()) > n) {
    throw InvalidInput(source, std::string("'") + key + "' must be a list of at most " + std::to_string(n) + " numbers",
                       "use coefficients of the same model");
  }
  for (size_t i = 0; i < v.size(); ++i) {
    if (!v[i].is_number() || !std::isfinite(v[i].get<double>())) {
      throw InvalidInput(source, std::string("'") + key + "' holds a value that is not a finite number", "");
    }
    out[i] = v[i].get<float>();
  }
}

void read_fixed(const nlohmann::json& j, const char* key, int64_t n, float* out, const std::string& source) {
  if (!j.contains(key)) return;
  if (!j.at(key).is_array() || int64_t(j.at(key).size()) != n) {
    throw InvalidInput(source, std::string("'") + key + "' must hold " + std::to_string(n) + " numbers", "");
  }
  read_list(j, key, n, out, source);
}

torch::Tensor matrix_of(const Eigen::Matrix3d& m) {
  torch::Tensor t = torch::empty({3, 3}, torch::kDouble);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) t[i][j] = m(i, j);
  }
  return t;
}

}  // namespace

std::string CoefficientLayout::describe() const {
  return "K_id " + std::to_string(id) + ", K_exp " + std::to_string(exp) + ", K_app " + std::to_string(app) +
         (gamma ? ", gamma" : ", no gamma");
}

torch::Tensor euler_rotation(const torch::Tensor& angles) {
  const torch::Tensor c = torch::cos(angles), s = torch::sin(angles);
  const torch::Tensor one = torch::ones_like(angles.select(1, 0)), zero = torch::zeros_like(one);
  const auto mat = [](std::vector<torch::Tensor> e) { return torch::stack(e, 1).reshape({-1, 3, 3}); };
  const torch::Tensor cx = c.select(1, 0), sx = s.select(1, 0), cy = c.select(1, 1), sy = s.select(1, 1);
  const torch::Tensor cz = c.select(1, 2), sz = s.select(1, 2);
  const torch::Tensor Rx = mat({one, zero, zero, zero, cx, -sx, zero, sx, cx});
  const torch::Tensor Ry = mat({cy, zero, sy, zero, one, zero, -sy, zero, cy});
  const torch::Tensor Rz = mat({cz, -sz, zero, sz, cz, zero, zero, zero, one});
  return torch::bmm(Rz, torch::bmm(Ry, Rx));
}

Camera canonical_camera(int size) { return view_camera("front", size, Eigen::Vector3d::Zero(), 1000); }

torch::Tensor ambient_gamma(torch::TensorOptions options) {
  torch::Tensor g = torch::zeros({27}, options);
  for (int c = 0; c < 3; ++c) g[9 * c] = kDeep3dAmbient;
  return g;
}

FaceModel FaceModel::load(const std::string& path) {
  const SafeTensors file = SafeTensors::open(path);
  FaceModel m;
  m.path_ = path;
  const auto format = file.metadata().find("format");
  if (format == file.metadata().end() || format->second != "bareskin.morphable_model") {
    throw InvalidInput(path, "is not a BareSkin morphable model (metadata format)", "give the model.safetensors of mm-build");
  }
  m.mean_ = tensor_of(file, path, "shape_mean", DType::F32, {-1, 3});
  const int64_t V = m.mean_.size(0);
  const auto basis = [&](const char* b, const char* sd, const std::vector<int64_t>& shape) {
    const torch::Tensor u = tensor_of(file, path, b, DType::F32, shape);
    const torch::Tensor s = tensor_of(file, path, sd, DType::F32, {u.size(0)});
    return (u.reshape({u.size(0), -1}) * s.unsqueeze(1)).contiguous();
  };
  m.id_basis_ = basis("shape_basis", "shape_stddev", {-1, V, 3});
  m.exp_basis_ = basis("expression_basis", "expression_stddev", {-1, V, 3});
  m.app_mean_ = tensor_of(file, path, "appearance_mean", DType::F32, {-1, -1, 3});
  const int64_t R = m.app_mean_.size(0);
  if (R == 0 || m.app_mean_.size(1) != R) throw InvalidInput(path, "the appearance mean is not square", "rebuild the model");
  m.app_basis_ = basis("appearance_basis", "appearance_stddev", {-1, R, R, 3});
  m.triangles_ = tensor_of(file, path, "triangles", DType::I32, {-1, 3}).to(torch::kLong);
  const torch::Tensor uvs = tensor_of(file, path, "uvs", DType::F32, {-1, 2});
  const torch::Tensor uv_tri = tensor_of(file, path, "uv_triangles", DType::I32, {m.triangles_.size(0), 3}).to(torch::kLong);
  m.landmarks_ = tensor_of(file, path, "landmark_vertices", DType::I32, {68}).to(torch::kLong);
  m.region_ = tensor_of(file, path, "vertex_region", DType::U8, {V}).to(torch::kLong);
  if (m.triangles_.numel() == 0 || m.triangles_.min().item<int64_t>() < 0 || m.triangles_.max().item<int64_t>() >= V ||
      uv_tri.min().item<int64_t>() < 0 || uv_tri.max().item<int64_t>() >= uvs.size(0) ||
      m.landmarks_.min().item<int64_t>() < 0 || m.landmarks_.max().item<int64_t>() >= V) {
    throw InvalidInput(path, "a triangle or landmark index is out of range", "rebuild the model");
  }
  if (!torch::isfinite(m.mean_).all().item<bool>() || !torch::isfinite(m.id_basis_).all().item<bool>() ||
      !torch::isfinite(m.exp_basis_).all().item<bool>() || !torch::isfinite(m.app_basis_).all().item<bool>()) {
    throw InvalidInput(path, "the model holds NaN or Inf", "rebuild the model");
  }
  const auto names = file.metadata().find("region_names");
  if (names != file.metadata().end()) m.region_names_ = nlohmann::json::parse(names->second).get<std::vector<std::string>>();
  m.layout_ = {m.id_basis_.size(0), m.exp_basis_.size(0), m.app_basis_.size(0), true};

  // One render vertex per distinct (vertex, uv) corner pair.
  const int64_t Fn = m.triangles_.size(0);
  const int64_t* t = m.triangles_.data_ptr<int64_t>();
  const int64_t* tu = uv_tri.contiguous().data_ptr<int64_t>();
  std::map<std::pair<int64_t, int64_t>, int64_t> index;
  std::vector<int64_t> vertex, uv, tri(size_t(3 * Fn));
  for (int64_t i = 0; i < 3 * Fn; ++i) {
    const auto key = std::make_pair(t[i], tu[i]);
    auto it = index.find(key);
    if (it == index.end()) {
      it = index.emplace(key, int64_t(vertex.size())).first;
      vertex.push_back(t[i]);
      uv.push_back(tu[i]);
    }
    tri[size_t(i)] = it->second;
  }
  m.render_vertex_ = torch::tensor(vertex, torch::kLong);
  m.render_uv_ = uvs.index_select(0, torch::tensor(uv, torch::kLong));
  m.render_triangles_ = torch::tensor(tri, torch::kLong).reshape({Fn, 3});
  return m;
}

FaceModel FaceModel::to(torch::Device device, torch::Dtype dtype) const {
  FaceModel m = *this;
  for (torch::Tensor* f : {&m.mean_, &m.id_basis_, &m.exp_basis_, &m.app_basis_, &m.app_mean_, &m.render_uv_}) {
    *f = f->to(device, dtype);
  }
  for (torch::Tensor* i : {&m.triangles_, &m.landmarks_, &m.region_, &m.render_vertex_, &m.render_triangles_}) {
    *i = i->to(device);
  }
  return m;
}

CoefficientLayout FaceModel::layout(bool gamma) const {
  CoefficientLayout l = layout_;
  l.gamma = gamma;
  return l;
}

FaceCoefficients FaceModel::split(const torch::Tensor& c) const {
  const CoefficientLayout with = layout(true), without = layout(false);
  if (c.dim() != 2 || (c.size(1) != with.size() && c.size(1) != without.size())) {
    throw InvalidInput(path_, "coefficients of width " + std::to_string(c.dim() == 2 ? c.size(1) : -1) + " for a model with " +
                                  with.describe() + " (" + std::to_string(with.size()) + " or " +
                                  std::to_string(without.size()) + " numbers)",
                       "use a network or coefficients made for this model file");
  }
  FaceCoefficients out;
  out.alpha = c.narrow(1, 0, with.id);
  out.beta = c.narrow(1, with.id, with.exp);
  out.delta = c.narrow(1, with.id + with.exp, with.app);
  out.rotation = c.narrow(1, with.rotation_offset(), 3);
  out.translation = c.narrow(1, with.translation_offset(), 3);
  if (c.size(1) == with.size()) out.gamma = c.narrow(1, with.gamma_offset(), 27);
  return out;
}

torch::Tensor FaceModel::join(const FaceCoefficients& c) const {
  std::vector<torch::Tensor> parts = {c.alpha, c.beta, c.delta, c.rotation, c.translation};
  if (c.gamma.defined()) parts.push_back(c.gamma);
  return torch::cat(parts, 1);
}

torch::Tensor FaceModel::shape(const torch::Tensor& alpha, const torch::Tensor& beta) const {
  const int64_t B = alpha.size(0);
  torch::Tensor s = mean_.reshape({1, -1}).expand({B, -1});
  if (layout_.id) s = s + torch::mm(alpha.to(mean_.dtype()), id_basis_);
  if (layout_.exp) s = s + torch::mm(beta.to(mean_.dtype()), exp_basis_);
  return s.reshape({B, -1, 3});
}

torch::Tensor FaceModel::displacement(const torch::Tensor& alpha, const torch::Tensor& beta) const {
  torch::Tensor d = layout_.id ? torch::mm(alpha.to(mean_.dtype()), id_basis_)
                               : torch::zeros({alpha.size(0), mean_.numel()}, mean_.options());
  if (layout_.exp) d = d + torch::mm(beta.to(mean_.dtype()), exp_basis_);
  return d.reshape({alpha.size(0), -1, 3});
}

torch::Tensor FaceModel::posed(const FaceCoefficients& c) const {
  const torch::Tensor S = shape(c.alpha, c.beta);
  const torch::Tensor R = euler_rotation(c.rotation.to(S.dtype()));
  return torch::bmm(S, R.transpose(1, 2)) + c.translation.to(S.dtype()).unsqueeze(1);
}

torch::Tensor FaceModel::albedo_texture(const torch::Tensor& delta) const {
  const int64_t B = delta.size(0), R = app_mean_.size(0);
  torch::Tensor a = app_mean_.reshape({1, -1}).expand({B, -1});
  if (layout_.app) a = a + torch::mm(delta.to(app_mean_.dtype()), app_basis_);
  return a.reshape({B, R, R, 3}).permute({0, 3, 1, 2});
}

torch::Tensor FaceModel::normals(const torch::Tensor& v) const {
  const int64_t B = v.size(0), V = v.size(1);
  const torch::Tensor a = v.index_select(1, triangles_.select(1, 0)), b = v.index_select(1, triangles_.select(1, 1)),
                      c = v.index_select(1, triangles_.select(1, 2));
  const torch::Tensor fn = torch::cross(b - a, c - a, 2);  // length 2 × area: area weighting
  torch::Tensor n = torch::zeros({B, V, 3}, v.options());
  for (int k = 0; k < 3; ++k) n = n.index_add(1, triangles_.select(1, k), fn);
  return n / n.norm(2, 2, true).clamp_min(1e-20);
}

torch::Tensor FaceModel::project(const torch::Tensor& points, const Camera& cam) {
  const auto opt = points.options();
  const torch::Tensor R = matrix_of(cam.R).to(opt);
  const torch::Tensor t = torch::tensor({cam.t.x(), cam.t.y(), cam.t.z()}, torch::kDouble).to(opt);
  const torch::Tensor p = torch::matmul(points, R.t()) + t;
  const torch::Tensor x = p.select(2, 0), y = p.select(2, 1), z = p.select(2, 2);
  if (cam.model == Camera::Model::WeakPerspective) {
    return torch::stack({cam.cx + cam.scale * x, cam.cy - cam.scale * y, -z}, 2);
  }
  const torch::Tensor depth = -z;
  return torch::stack({cam.cx + cam.focal * x / depth, cam.cy - cam.focal * y / depth, depth}, 2);
}

torch::Tensor FaceModel::landmarks(const FaceCoefficients& c, const Camera& camera) const {
  const torch::Tensor S = shape(c.alpha, c.beta).index_select(1, landmarks_);
  const torch::Tensor R = euler_rotation(c.rotation.to(S.dtype()));
  const torch::Tensor P = torch::bmm(S, R.transpose(1, 2)) + c.translation.to(S.dtype()).unsqueeze(1);
  return project(P, camera).narrow(2, 0, 2);
}

FaceRender FaceModel::render(const torch::Tensor& coefficients, const Camera& camera, const torch::Tensor& gamma) const {
  FaceCoefficients c = split(coefficients);
  if (gamma.defined()) c.gamma = gamma;
  return render(c, camera);
}

FaceRender FaceModel::render(const FaceCoefficients& c, const Camera& camera) const {
  namespace rt = render_torch;
  FaceRender out;
  out.vertices = posed(c);
  out.projected = project(out.vertices, camera);
  const int64_t B = out.vertices.size(0), H = camera.height, W = camera.width;
  out.landmarks = out.projected.index_select(1, landmarks_).narrow(2, 0, 2);
  const torch::Tensor pos = out.projected.index_select(1, render_vertex_);
  const rt::Raster raster = rt::rasterize(pos, render_triangles_, H, W);
  const torch::Tensor covered = (raster.triangle >= 0).to(pos.dtype()).unsqueeze(3);  // [B, H, W, 1]
  const torch::Tensor Rt = matrix_of(camera.R).t().to(pos.options());
  const torch::Tensor n = torch::matmul(normals(out.vertices), Rt).index_select(1, render_vertex_);  // camera frame
  const torch::Tensor uv = render_uv_.unsqueeze(0).expand({B, -1, -1});
  const torch::Tensor uv_img = rt::interpolate(uv, pos, render_triangles_, raster);
  const torch::Tensor n_img = rt::interpolate(n, pos, render_triangles_, raster);
  const torch::Tensor albedo = rt::texture(albedo_texture(c.delta), uv_img) * covered;  // [B, H, W, 3]
  const torch::Tensor colour = c.gamma.defined() ? rt::sh_shade(albedo, n_img, c.gamma.to(pos.dtype())) : albedo;
  out.albedo = albedo.permute({0, 3, 1, 2});
  out.colour = colour.permute({0, 3, 1, 2});
  out.mask = covered.permute({0, 3, 1, 2});
  return out;
}

torch::Tensor coefficients_from_json(const nlohmann::json& j, const CoefficientLayout& l, const std::string& source) {
  if (!j.is_object()) throw InvalidInput(source, "the coefficients are not a JSON object", "");
  std::vector<float> v(size_t(l.size()), 0.0f);
  read_list(j, "alpha", l.id, v.data(), source);
  read_list(j, "beta", l.exp, v.data() + l.id, source);
  read_list(j, "delta", l.app, v.data() + l.id + l.exp, source);
  read_fixed(j, "rotation", 3, v.data() + l.rotation_offset(), source);
  read_fixed(j, "translation", 3, v.data() + l.translation_offset(), source);
  if (l.gamma) {
    for (int c = 0; c < 3; ++c) v[size_t(l.gamma_offset() + 9 * c)] = float(kDeep3dAmbient);
    read_fixed(j, "gamma", 27, v.data() + l.gamma_offset(), source);
  }
  return torch::tensor(v, torch::kFloat);
}

nlohmann::json coefficients_to_json(const torch::Tensor& row, const CoefficientLayout& l) {
  const torch::Tensor r = row.detach().to(torch::kCPU, torch::kDouble).contiguous();
  BS_CHECK(r.dim() == 1 && r.size(0) == l.size(), "a coefficient row of the layout's width");
  const double* p = r.data_ptr<double>();
  const auto list = [&](int64_t at, int64_t n) { return std::vector<double>(p + at, p + at + n); };
  nlohmann::json j;
  j["alpha"] = list(0, l.id);
  j["beta"] = list(l.id, l.exp);
  j["delta"] = list(l.id + l.exp, l.app);
  j["rotation"] = list(l.rotation_offset(), 3);
  j["translation"] = list(l.translation_offset(), 3);
  if (l.gamma) j["gamma"] = list(l.gamma_offset(), 27);
  return j;
}

}  // namespace bareskin::recon

namespace bareskin::recon {
namespace {

// iBUG-68 positions on the toy face (mm, x to the face's left = image right, y up).
std::vector<std::array<double, 2>> toy_landmarks() {
  std::vector<std::array<double, 2>> p;
  for (int k = 0; k <= 16; ++k) p.push_back({-65 * std::cos(M_PI * k / 16), 5 - 85 * std::sin(M_PI * k / 16)});
  for (int k = 0; k < 5; ++k) p.push_back({-55 + 10.75 * k, 35 + 4 * std::sin(M_PI * k / 4)});
  for (int k = 0; k < 5; ++k) p.push_back({12 + 10.75 * k, 35 + 4 * std::sin(M_PI * k / 4)});
  for (double y : {25.0, 15.0, 5.0, -5.0}) p.push_back({0, y});
  for (double x : {-14.0, -7.0, 0.0, 7.0, 14.0}) p.push_back({x, -15});
  const double eye[6][2] = {{-12, 0}, {-4, 4}, {4, 4}, {12, 0}, {4, -4}, {-4, -4}};
  for (const auto& e : eye) p.push_back({-32 + e[0], 22 + e[1]});
  for (const auto& e : eye) p.push_back({32 + e[0], 22 + e[1]});
  const double lips[20][2] = {{-25, -40}, {-16, -34}, {-7, -31}, {0, -32}, {7, -31}, {16, -34}, {25, -40},
                              {16, -48},  {7, -51},   {0, -52},  {-7, -51}, {-16, -48}, {-20, -40}, {-8, -37},
                              {0, -37},   {8, -37},   {20, -40}, {8, -43},  {0, -43},   {-8, -43}};
  for (const auto& l : lips) p.push_back({l[0], l[1]});
  return p;
}

// K smooth random fields over the vertices or texels (columns of `points` [N, 2] in [-1, 1]) with `channels` values
// each, orthonormalised: [K, N * channels].
torch::Tensor smooth_basis(const torch::Tensor& points, int K, int channels, torch::Generator& gen) {
  const int64_t N = points.size(0);
  const torch::Tensor x = points.select(1, 0).unsqueeze(1), y = points.select(1, 1).unsqueeze(1);
  std::vector<torch::Tensor> features;  // [N, 1] each
  for (int a = 0; a < 4; ++a) {
    for (int b = 0; b < 4; ++b) features.push_back(torch::cos(a * M_PI * 0.5 * (x + 1)) * torch::cos(b * M_PI * 0.5 * (y + 1)));
  }
  const torch::Tensor phi = torch::cat(features, 1);  // [N, 16]
  const torch::Tensor w = torch::randn({K, int64_t(features.size()), channels}, gen, torch::kDouble);
  const torch::Tensor fields = torch::einsum("nf,kfc->knc", {phi, w}).reshape({K, N * channels});
  const auto qr = torch::linalg_qr(fields.t());
  return std::get<0>(qr).t().contiguous();  // orthonormal rows
}

}  // namespace

void ToyModelOptions::check() const {
  if (grid < 2 || grid > 1024) throw InvalidInput("toy model", "the grid must have 2 to 1024 cells a side", "e.g. 48");
  if (id < 1 || exp < 1 || app < 1)
    throw InvalidInput("toy model", "needs at least one identity, expression and appearance component", "e.g. 6, 4, 3");
  if (resolution < 8 || resolution > 4096)
    throw InvalidInput("toy model", "the appearance image must be 8 to 4096 texels a side", "e.g. 64");
}

void save_toy_model(const std::string& path, const ToyModelOptions& o) {
  o.check();
  torch::Generator gen = at::detail::createCPUGenerator(o.seed);
  const int n = o.grid, side = n + 1;
  const int64_t V = int64_t(side) * side;
  torch::Tensor mean = torch::empty({V, 3}, torch::kDouble), uv = torch::empty({V, 2}, torch::kDouble);
  torch::Tensor unit = torch::empty({V, 2}, torch::kDouble);
  std::vector<uint8_t> region(size_t(V), 5);  // cheeks_jaw
  for (int j = 0; j < side; ++j) {
    for (int i = 0; i < side; ++i) {
      const int64_t v = int64_t(j) * side + i;
      const double u = double(i) / n, w = double(j) / n, x = -75 + 150 * u, y = -95 + 190 * w;
      const double r2 = (x / 80) * (x / 80) + (y / 100) * (y / 100);
      const double z = 70 * std::sqrt(std::max(0.0, 1 - r2)) + 20 * std::exp(-(x / 9) * (x / 9) - ((y + 2) / 20) * ((y + 2) / 20));
      mean[v][0] = x, mean[v][1] = y, mean[v][2] = z;
      uv[v][0] = u, uv[v][1] = w;
      unit[v][0] = 2 * u - 1, unit[v][1] = 2 * w - 1;
      uint8_t& r = region[size_t(v)];
      if (y > 45) r = 0;                                                            // forehead
      if (y > 30 && y <= 45 && std::abs(x) > 10 && std::abs(x) < 58) r = 1;         // brows
      if (std::abs(std::abs(x) - 32) < 13 && std::abs(y - 22) < 6) r = 2;            // eyes
      if (std::abs(x) < 15 && y > -18 && y < 28) r = 3;                              // nose
      if (std::abs(x) < 27 && y < -28 && y > -55) r = 4;                             // mouth
    }
  }
  std::vector<int32_t> tri, uvtri;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const int32_t a = j * side + i, b = a + 1, c = a + side + 1, d = a + side;
      // The right half takes its UVs from a second copy of the list: a seam down the middle.
      const int32_t s = i >= n / 2 ? int32_t(V) : 0;
      for (int32_t k : {a, b, c, a, c, d}) {
        tri.push_back(k);
        uvtri.push_back(k + s);
      }
    }
  }
  std::vector<int32_t> lm;
  for (const auto& p : toy_landmarks()) {
    const int i = std::clamp(int(std::lround((p[0] + 75) / 150 * n)), 0, n);
    const int j = std::clamp(int(std::lround((p[1] + 95) / 190 * n)), 0, n);
    lm.push_back(j * side + i);
  }
  const auto sd = [](int K, double first) {
    torch::Tensor s = torch::empty({K}, torch::kDouble);
    for (int k = 0; k < K; ++k) s[k] = first / std::sqrt(k + 1.0);
    return s;
  };
  const double root = std::sqrt(3.0 * double(V));
  const torch::Tensor id = smooth_basis(unit, o.id, 3, gen), ex = smooth_basis(unit, o.exp, 3, gen);
  // Albedo: a skin tone with a low-frequency pattern (so that texture lookups are tested), darker eyes, redder lips.
  const int R = o.resolution;
  torch::Tensor texel = torch::empty({int64_t(R) * R, 2}, torch::kDouble), amean = torch::empty({R, R, 3}, torch::kDouble);
  for (int row = 0; row < R; ++row) {
    for (int col = 0; col < R; ++col) {
      const double u = (col + 0.5) / R, v = 1 - (row + 0.5) / R, x = -75 + 150 * u, y = -95 + 190 * v;
      texel[row * R + col][0] = 2 * u - 1, texel[row * R + col][1] = 2 * v - 1;
      const double pattern = 0.08 * std::sin(9 * u) * std::cos(7 * v) + 0.04 * std::sin(31 * u + 17 * v);
      double rgb[3] = {0.55 + pattern, 0.38 + 0.8 * pattern, 0.30 + 0.6 * pattern};
      if (std::abs(std::abs(x) - 32) < 10 && std::abs(y - 22) < 4) rgb[0] = rgb[1] = rgb[2] = 0.12;
      if (std::abs(x) < 24 && std::abs(y + 41) < 9) rgb[0] = 0.55, rgb[1] = 0.2, rgb[2] = 0.2;
      for (int c = 0; c < 3; ++c) amean[row][col][c] = rgb[c];
    }
  }
  const torch::Tensor ab = smooth_basis(texel, o.app, 3, gen);
  std::map<std::string, torch::Tensor> t;
  const auto f32 = [](const torch::Tensor& x) { return x.to(torch::kFloat).contiguous(); };
  t["shape_mean"] = f32(mean);
  t["shape_basis"] = f32(id.reshape({o.id, V, 3}));
  t["shape_stddev"] = f32(sd(o.id, 2 * root));
  t["expression_basis"] = f32(ex.reshape({o.exp, V, 3}));
  t["expression_stddev"] = f32(sd(o.exp, 1.5 * root));
  t["appearance_mean"] = f32(amean);
  t["appearance_basis"] = f32(ab.reshape({o.app, R, R, 3}));
  t["appearance_stddev"] = f32(sd(o.app, 0.03 * std::sqrt(3.0 * R * R)));
  t["appearance_mask"] = torch::ones({R, R}, torch::kUInt8);
  t["triangles"] = torch::tensor(tri, torch::kInt).reshape({-1, 3});
  t["uv_triangles"] = torch::tensor(uvtri, torch::kInt).reshape({-1, 3});
  t["uvs"] = f32(torch::cat({uv, uv}, 0));
  t["landmark_vertices"] = torch::tensor(lm, torch::kInt);
  t["vertex_region"] = torch::tensor(std::vector<int64_t>(region.begin(), region.end()), torch::kLong).to(torch::kUInt8);
  t["procrustes"] = torch::eye(4, torch::kFloat).unsqueeze(0);
  std::vector<std::string> exp_names;
  for (int k = 0; k < o.exp; ++k) exp_names.push_back("toy_expression_" + std::to_string(k));
  save_tensors(path, t,
               {{"format", "bareskin.morphable_model"},
                {"format_version", "1"},
                {"units", "mm"},
                {"provenance", "bareskin toy model (recon/face_model.h), seed " + std::to_string(o.seed)},
                {"components", nlohmann::json{{"shape", o.id}, {"expression", o.exp}, {"appearance", o.app}}.dump()},
                {"region_names", nlohmann::json({"forehead", "brows", "eyes", "nose", "mouth", "cheeks_jaw"}).dump()},
                {"expression_names", nlohmann::json(exp_names).dump()},
                {"subjects", nlohmann::json::array({"toy"}).dump()},
                {"appearance_image", "row 0 is the top of the UV square (v = 1), columns along u"}});
}

}  // namespace bareskin::recon
