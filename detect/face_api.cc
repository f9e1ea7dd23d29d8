#include "detect/face_api.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "core/assets.h"
#include "core/error.h"
#include "detect/tfjs_weights.h"

namespace bareskin::detect {
namespace F = torch::nn::functional;
namespace {

constexpr double kDetectorMean[3] = {117.001, 114.697, 97.404};
constexpr double kLandmarkMean[3] = {122.782, 117.001, 104.298};
constexpr double kAnchors[5][2] = {
    {1.603231, 2.094468}, {6.041143, 7.080126}, {2.882459, 3.518061}, {4.266906, 5.178857}, {9.041765, 10.66308}};
constexpr int kLandmarkSize = 112;

using Weights = std::map<std::string, torch::Tensor>;

torch::Tensor take(Weights& weights, const std::string& manifest, const std::string& name,
                   const std::vector<int64_t>& shape) {
  auto it = weights.find(name);
  if (it == weights.end())
    throw InvalidInput(manifest, "tensor '" + name + "' is missing", "the manifest belongs to another model");
  if (it->second.sizes().vec() != shape)
    throw InvalidInput(manifest, "tensor '" + name + "' has shape " + c10::str(it->second.sizes()) + ", expected " +
                                     c10::str(torch::IntArrayRef(shape)),
                       "the manifest belongs to another model");
  return it->second;
}

// TensorFlow layouts → LibTorch: filters HWIO → OIHW; depthwise [h, w, C, 1] → [C, 1, h, w].
torch::Tensor hwio_to_oihw(const torch::Tensor& t) { return t.permute({3, 2, 0, 1}).contiguous(); }
torch::Tensor depthwise_to_torch(const torch::Tensor& t) { return t.permute({2, 3, 0, 1}).contiguous(); }

// TensorFlow "same" padding for a k×k window at `stride`: the odd pixel goes after (bottom/right).
torch::Tensor pad_same(const torch::Tensor& x, int k, int stride, double value = 0) {
  std::vector<int64_t> pad;  // left, right, top, bottom
  for (int dim : {3, 2}) {
    const int64_t in = x.size(dim), out = (in + stride - 1) / stride;
    const int64_t total = std::max<int64_t>((out - 1) * stride + k - in, 0);
    pad.push_back(total / 2);
    pad.push_back(total - total / 2);
  }
  if (std::all_of(pad.begin(), pad.end(), [](int64_t p) { return p == 0; })) return x;
  return F::pad(x, F::PadFuncOptions(pad).value(value));
}

torch::Tensor leaky(const torch::Tensor& x) { return F::leaky_relu(x, F::LeakyReLUFuncOptions().negative_slope(0.1)); }

torch::Tensor max_pool_same(const torch::Tensor& x, int stride) {
  return F::max_pool2d(pad_same(x, 2, stride, -std::numeric_limits<double>::infinity()),
                       F::MaxPool2dFuncOptions(2).stride(stride));
}

// One axis of the legacy bilinear resize of a `square`-long padded axis (the image occupies [before, before +
// extent)) to `out` samples: source = i · square/out, neighbours floor/ceil, zero outside the image.
struct Axis {
  torch::Tensor lo, hi, w_lo, w_hi;  // indices into the image (clamped) and weights (0 where the padding is)
};
Axis resize_axis(int64_t square, int64_t before, int64_t extent, int out) {
  std::vector<int64_t> lo(out), hi(out);
  std::vector<float> w_lo(out), w_hi(out);
  const double ratio = double(square) / out;
  for (int i = 0; i < out; ++i) {
    const double source = ratio * i, floor = std::floor(source);
    const double ceil = std::min<double>(square - 1, std::ceil(source));
    const double frac = source - floor;
    const int64_t a = int64_t(floor) - before, b = int64_t(ceil) - before;
    lo[i] = std::clamp<int64_t>(a, 0, extent - 1);
    hi[i] = std::clamp<int64_t>(b, 0, extent - 1);
    w_lo[i] = (a >= 0 && a < extent) ? float(1 - frac) : 0.f;
    w_hi[i] = (b >= 0 && b < extent) ? float(frac) : 0.f;
  }
  return {torch::tensor(lo), torch::tensor(hi), torch::tensor(w_lo), torch::tensor(w_hi)};
}

Box clip_floor(const Box& box, int64_t width, int64_t height) {
  const double x = std::max(box.x, 0.0), y = std::max(box.y, 0.0);
  const double w = std::min(box.x + box.width - x, width - x), h = std::min(box.y + box.height - y, height - y);
  return {std::floor(x), std::floor(y), std::floor(w), std::floor(h)};
}

double iou(const Box& a, const Box& b) {
  const double w = std::max(0.0, std::min(a.x + a.width, b.x + b.width) - std::max(a.x, b.x));
  const double h = std::max(0.0, std::min(a.y + a.height, b.y + b.height) - std::max(a.y, b.y));
  return w * h / (a.width * a.height + b.width * b.height - w * h);
}

double sigmoid(double x) { return 1 / (1 + std::exp(-x)); }

}  // namespace

torch::Tensor photo_tensor(const Image& image, const std::string& source) {
  if (image.width < 64 || image.height < 64)
    throw InvalidInput(source, "is " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                                   " pixels; faces need at least 64x64", "use a larger photo");
  if (image.channels < 1 || image.channels > 4)
    throw InvalidInput(source, "has " + std::to_string(image.channels) + " channels", "convert it to RGB");
  Image converted;
  if (image.color_space == ColorSpace::Linear) converted = to_srgb(image);
  const Image& srgb = converted.empty() ? image : converted;
  torch::Tensor t = torch::from_blob(const_cast<float*>(srgb.pixels.data()),
                                     {srgb.height, srgb.width, srgb.channels}, torch::kFloat);
  t = srgb.channels >= 3 ? t.slice(2, 0, 3) : t.slice(2, 0, 1).expand({-1, -1, 3});
  return t.clamp(0, 1).contiguous();
}

std::string default_face_api_folder() {
  return (std::filesystem::path(find_data_dir(DataKind::Assets, "", "face_api")) / "face_api").string();
}

FaceApi::FaceApi(const std::string& folder) {
  const std::string detector = (std::filesystem::path(folder) / "tiny_face_detector_model-weights_manifest.json").string();
  const std::string landmark = (std::filesystem::path(folder) / "face_landmark_68_model-weights_manifest.json").string();
  for (const auto& manifest : {detector, landmark})
    if (!std::filesystem::exists(manifest))
      throw IoError(manifest, "not found", "run 'make deps' (it fetches npm @vladmandic/face-api) or pass --weights DIR");

  Weights w = read_tfjs_weights(detector);
  detector_conv0_ = {hwio_to_oihw(take(w, detector, "conv0/filters", {3, 3, 3, 16})),
                     take(w, detector, "conv0/bias", {16})};
  for (int i = 1, in = 16; i <= 5; ++i, in *= 2) {
    const std::string p = "conv" + std::to_string(i) + "/";
    detector_layers_.push_back({depthwise_to_torch(take(w, detector, p + "depthwise_filter", {3, 3, in, 1})),
                                hwio_to_oihw(take(w, detector, p + "pointwise_filter", {1, 1, in, 2 * in})),
                                take(w, detector, p + "bias", {2 * in})});
  }
  detector_conv8_ = {hwio_to_oihw(take(w, detector, "conv8/filters", {1, 1, 512, 25})),
                     take(w, detector, "conv8/bias", {25})};

  w = read_tfjs_weights(landmark);
  landmark_conv0_ = {hwio_to_oihw(take(w, landmark, "dense0/conv0/filters", {3, 3, 3, 32})),
                     take(w, landmark, "dense0/conv0/bias", {32})};
  for (int block = 0, in = 32; block < 4; ++block) {
    const int out = block == 0 ? 32 : 2 * in;
    for (int conv = block == 0 ? 1 : 0; conv < 4; ++conv) {
      const int c_in = conv == 0 ? in : out;
      const std::string p = "dense" + std::to_string(block) + "/conv" + std::to_string(conv) + "/";
      landmark_layers_.push_back({depthwise_to_torch(take(w, landmark, p + "depthwise_filter", {3, 3, c_in, 1})),
                                  hwio_to_oihw(take(w, landmark, p + "pointwise_filter", {1, 1, c_in, out})),
                                  take(w, landmark, p + "bias", {out})});
    }
    in = out;
  }
  fc_weight_ = take(w, landmark, "fc/weights", {256, 136}).t().contiguous();
  fc_bias_ = take(w, landmark, "fc/bias", {136});
}

void FaceApi::to(const torch::Device& device) {
  auto move = [&](torch::Tensor& t) { t = t.to(device); };
  for (Conv* c : {&detector_conv0_, &detector_conv8_, &landmark_conv0_}) move(c->filters), move(c->bias);
  for (auto* layers : {&detector_layers_, &landmark_layers_})
    for (auto& l : *layers) move(l.depthwise), move(l.pointwise), move(l.bias);
  move(fc_weight_), move(fc_bias_);
  device_ = device;
}

torch::Tensor FaceApi::detector_net(const torch::Tensor& x) const {
  torch::NoGradGuard no_grad;
  auto out = leaky(F::conv2d(x, detector_conv0_.filters) + detector_conv0_.bias.view({1, -1, 1, 1}));
  for (size_t i = 0; i < detector_layers_.size(); ++i) {
    out = max_pool_same(out, 2);
    const auto& l = detector_layers_[i];
    out = F::conv2d(F::pad(out, F::PadFuncOptions({1, 1, 1, 1})), l.depthwise,
                    F::Conv2dFuncOptions().groups(l.depthwise.size(0)));
    out = leaky(F::conv2d(out, l.pointwise) + l.bias.view({1, -1, 1, 1}));
  }
  out = max_pool_same(out, 1);
  return F::conv2d(out, detector_conv8_.filters) + detector_conv8_.bias.view({1, -1, 1, 1});
}

torch::Tensor FaceApi::landmark_net(const torch::Tensor& x) const {
  torch::NoGradGuard no_grad;
  auto separable = [](const torch::Tensor& in, const SeparableConv& l, int stride) {
    auto out = F::conv2d(pad_same(in, 3, stride), l.depthwise,
                         F::Conv2dFuncOptions().stride(stride).groups(l.depthwise.size(0)));
    return F::conv2d(out, l.pointwise) + l.bias.view({1, -1, 1, 1});
  };
  torch::Tensor out = x;
  size_t layer = 0;
  for (int block = 0; block < 4; ++block) {
    const torch::Tensor out1 =
        block == 0 ? torch::relu(F::conv2d(pad_same(x, 3, 2), landmark_conv0_.filters, F::Conv2dFuncOptions().stride(2)) +
                                 landmark_conv0_.bias.view({1, -1, 1, 1}))
                   : torch::relu(separable(out, landmark_layers_[layer++], 2));
    const torch::Tensor out2 = separable(out1, landmark_layers_[layer++], 1);
    const torch::Tensor out3 = separable(torch::relu(out1 + out2), landmark_layers_[layer++], 1);
    const torch::Tensor out4 = separable(torch::relu(out1 + (out2 + out3)), landmark_layers_[layer++], 1);
    out = torch::relu(out1 + (out2 + (out3 + out4)));
  }
  out = F::avg_pool2d(out, F::AvgPool2dFuncOptions(7).stride(2)).flatten(1);
  return torch::addmm(fc_bias_, out, fc_weight_.t());
}

torch::Tensor FaceApi::prepare(const torch::Tensor& image, int size, bool centre, const double mean[3]) {
  const int64_t h = image.size(0), w = image.size(1), square = std::max(h, w), diff = square - std::min(h, w);
  // face-api appends round(diff / 2) (centred) or all of it, and prepends the rest.
  const int64_t before = centre ? diff - int64_t(std::floor(diff * 0.5 + 0.5)) : 0;
  const Axis ys = resize_axis(square, h < w ? before : 0, h, size);
  const Axis xs = resize_axis(square, w < h ? before : 0, w, size);
  const torch::Tensor img = image.to(torch::kFloat).permute({2, 0, 1});  // [3, H, W] view
  auto horizontal = [&](const torch::Tensor& rows) {  // [3, size, W] → [3, size, size]
    return rows.index_select(2, xs.lo) * xs.w_lo + rows.index_select(2, xs.hi) * xs.w_hi;
  };
  const torch::Tensor top = horizontal(img.index_select(1, ys.lo)), bottom = horizontal(img.index_select(1, ys.hi));
  // tfjs: top + (bottom − top)·frac, where rows outside the image are zero.
  const torch::Tensor resized = top * ys.w_lo.view({-1, 1}) + bottom * ys.w_hi.view({-1, 1});
  const torch::Tensor m = torch::tensor({mean[0], mean[1], mean[2]}, torch::kFloat).view({3, 1, 1});
  return ((resized * 255 - m) / 255).unsqueeze(0).contiguous();
}

std::vector<Eigen::Matrix<double, 68, 2>> FaceApi::landmarks(const torch::Tensor& image,
                                                           const std::vector<Box>& boxes) const {
  std::vector<Eigen::Matrix<double, 68, 2>> result;
  if (boxes.empty()) return result;
  std::vector<torch::Tensor> inputs;
  std::vector<Box> crops;
  for (const Box& box : boxes) {
    Box crop = clip_floor(box, image.size(1), image.size(0));
    crop.width = std::max(crop.width, 1.0), crop.height = std::max(crop.height, 1.0);
    crop.x = std::min<double>(crop.x, image.size(1) - 1), crop.y = std::min<double>(crop.y, image.size(0) - 1);
    crop.width = std::min<double>(crop.width, image.size(1) - crop.x);
    crop.height = std::min<double>(crop.height, image.size(0) - crop.y);
    crops.push_back(crop);
    inputs.push_back(prepare(image.slice(0, int64_t(crop.y), int64_t(crop.y + crop.height))
                                 .slice(1, int64_t(crop.x), int64_t(crop.x + crop.width)),
                             kLandmarkSize, true, kLandmarkMean));
  }
  const torch::Tensor out = landmark_net(torch::cat(inputs).to(device_)).to(torch::kCPU, torch::kDouble);
  const auto o = out.accessor<double, 2>();
  for (size_t f = 0; f < crops.size(); ++f) {
    const Box& c = crops[f];
    // face-api's decoding: out · 112, minus half the (scaled) size difference, over the scaled crop size.
    const double scale = kLandmarkSize / std::max(c.width, c.height), sw = c.width * scale, sh = c.height * scale;
    const double pad_x = sw < sh ? (sh - sw) / 2 : 0, pad_y = sh < sw ? (sw - sh) / 2 : 0;
    Eigen::Matrix<double, 68, 2> points;
    for (int i = 0; i < 68; ++i) {
      points(i, 0) = (o[f][2 * i] * kLandmarkSize - pad_x) / sw * c.width + c.x;
      points(i, 1) = (o[f][2 * i + 1] * kLandmarkSize - pad_y) / sh * c.height + c.y;
    }
    result.push_back(points);
  }
  return result;
}

void DetectOptions::check() const {
  if (input_size < 32 || input_size > 4096 || input_size % 32 != 0)
    throw InvalidInput("the detector's input size (--input-size, --detector-size)",
                       std::to_string(input_size) + " is not a multiple of 32 in [32, 4096]",
                       "use e.g. 416 (default), 320 or 608");
  if (!(min_score >= 0 && min_score <= 1))
    throw InvalidInput("--min-score", std::to_string(min_score) + " is not a score in [0, 1]", "use e.g. 0.5 (default)");
  if (!(iou_threshold > 0 && iou_threshold <= 1))
    throw InvalidInput("the detector's overlap threshold", std::to_string(iou_threshold) + " is not in (0, 1]",
                       "use e.g. 0.4 (default)");
  if (max_faces < 0) throw InvalidInput("--max-faces", "must not be negative", "0 keeps every face");
}

std::vector<Face> FaceApi::detect(const torch::Tensor& image, const DetectOptions& options) const {
  BS_CHECK(image.dim() == 3 && image.size(2) == 3, "FaceApi::detect takes an [H, W, 3] image");
  options.check();
  const int s = options.input_size;
  const int64_t h = image.size(0), w = image.size(1);
  const torch::Tensor out =
      detector_net(prepare(image, s, false, kDetectorMean).to(device_)).to(torch::kCPU, torch::kDouble)[0];
  const auto o = out.accessor<double, 3>();
  const int64_t cells = out.size(1);
  // The image filled round(w·s/max) × round(h·s/max) of the input; boxes are relative to that.
  const double scale = double(s) / std::max(h, w);
  const double fx = s / std::round(w * scale), fy = s / std::round(h * scale);
  struct Candidate {
    double score;
    Box relative;
  };
  std::vector<Candidate> candidates;
  for (int64_t row = 0; row < cells; ++row)
    for (int64_t col = 0; col < cells; ++col)
      for (int a = 0; a < 5; ++a) {
        const double score = sigmoid(o[a * 5 + 4][row][col]);
        if (score <= options.min_score) continue;
        const double cx = (col + sigmoid(o[a * 5][row][col])) / cells * fx;
        const double cy = (row + sigmoid(o[a * 5 + 1][row][col])) / cells * fy;
        const double bw = std::exp(o[a * 5 + 2][row][col]) * kAnchors[a][0] / cells * fx;
        const double bh = std::exp(o[a * 5 + 3][row][col]) * kAnchors[a][1] / cells * fy;
        candidates.push_back({score, {cx - bw / 2, cy - bh / 2, bw, bh}});
      }
  // Greedy non-maximum suppression, highest score first (IoU on the relative boxes, as face-api).
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
  std::vector<Face> faces;
  std::vector<Box> kept;
  for (const Candidate& c : candidates) {
    if (std::any_of(kept.begin(), kept.end(), [&](const Box& k) { return iou(k, c.relative) > options.iou_threshold; }))
      continue;
    kept.push_back(c.relative);
    Face face;
    face.score = c.score;
    face.box = {c.relative.x * w, c.relative.y * h, c.relative.width * w, c.relative.height * h};
    const Box crop = clip_floor(face.box, w, h);
    if (crop.width <= 0 || crop.height <= 0) continue;  // entirely outside the image
    faces.push_back(face);
    if (options.max_faces > 0 && int(faces.size()) == options.max_faces) break;
  }
  std::vector<Box> boxes;
  for (const Face& f : faces) boxes.push_back(f.box);
  const auto points = landmarks(image, boxes);
  for (size_t i = 0; i < faces.size(); ++i) faces[i].points = points[i];
  return faces;
}

}  // namespace bareskin::detect
