#include "detect/face_recognition.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "detect/tfjs_weights.h"

namespace bareskin::detect {
namespace F = torch::nn::functional;
namespace {

constexpr double kMeanRgb[3] = {122.782, 117.001, 104.298};  // face-api's, on 0..255 pixels

// The residual layers in order, with whether each one halves the resolution.
struct Layer {
  const char* name;
  bool down;
};
constexpr Layer kLayers[] = {{"conv32_1", false},   {"conv32_2", false},       {"conv32_3", false},
                             {"conv64_down", true}, {"conv64_1", false},       {"conv64_2", false},
                             {"conv64_3", false},   {"conv128_down", true},    {"conv128_1", false},
                             {"conv128_2", false},  {"conv256_down", true},    {"conv256_1", false},
                             {"conv256_2", false},  {"conv256_down_out", true}};
// After which residual layers forward_features records a feature map (conv32_down is the first).
constexpr const char* kFeatureAfter[] = {"conv32_3", "conv64_3", "conv128_2", "conv256_2"};

int channels_of(const std::string& layer) {  // "conv64_1" → 64
  return std::stoi(layer.substr(4, layer.find('_') - 4));
}

const torch::Tensor& take(const std::map<std::string, torch::Tensor>& weights, const std::string& source,
                          const std::string& name, const std::vector<int64_t>& shape) {
  auto it = weights.find(name);
  if (it == weights.end())
    throw InvalidInput(source, "tensor '" + name + "' is missing", "it must hold face-api's face recognition model");
  if (it->second.sizes().vec() != shape)
    throw InvalidInput(source,
                       "tensor '" + name + "' has shape " + c10::str(it->second.sizes()) + ", expected " +
                           c10::str(torch::IntArrayRef(shape)),
                       "it must hold face-api's face recognition model");
  return it->second;
}

std::map<std::string, torch::Tensor> read_manifest(const std::string& folder) {
  const std::string manifest = (std::filesystem::path(folder) / kFaceRecognitionManifest).string();
  if (!std::filesystem::exists(manifest))
    throw IoError(manifest, "not found", "run 'make deps' (it fetches npm @vladmandic/face-api)");
  return read_tfjs_weights(manifest);
}

// One axis of tfjs's legacy bilinear resize of a `square`-long padded axis (the image occupies [before, before +
// extent)) to `out` samples: source = i · square/out, neighbours floor and min(ceil, square − 1); weights are zero
// where a neighbour falls on the padding.
struct LegacyAxis {
  torch::Tensor lo, hi, w_lo, w_hi;
};
LegacyAxis legacy_axis(int64_t square, int64_t before, int64_t extent, int64_t out, const torch::TensorOptions& options) {
  std::vector<int64_t> lo(out), hi(out);
  std::vector<double> w_lo(out), w_hi(out);
  const double ratio = double(square) / double(out);
  for (int64_t i = 0; i < out; ++i) {
    const double source = ratio * double(i), floor = std::floor(source);
    const double frac = source - floor;
    const int64_t a = int64_t(floor) - before;
    const int64_t b = std::min<int64_t>(square - 1, int64_t(std::ceil(source))) - before;
    lo[i] = std::clamp<int64_t>(a, 0, extent - 1);
    hi[i] = std::clamp<int64_t>(b, 0, extent - 1);
    w_lo[i] = (a >= 0 && a < extent) ? 1 - frac : 0;
    w_hi[i] = (b >= 0 && b < extent) ? frac : 0;
  }
  const auto index = torch::TensorOptions().dtype(torch::kLong).device(options.device());
  return {torch::tensor(lo, index), torch::tensor(hi, index), torch::tensor(w_lo, options),
          torch::tensor(w_hi, options)};
}

}  // namespace

FaceRecognitionNetImpl::FaceRecognitionNetImpl(const std::string& folder)
    : FaceRecognitionNetImpl(read_manifest(folder),
                             (std::filesystem::path(folder) / kFaceRecognitionManifest).string()) {}

FaceRecognitionNetImpl::FaceRecognitionNetImpl(const std::map<std::string, torch::Tensor>& weights,
                                               const std::string& source) {
  auto add = [&](const std::string& name, int64_t in, int64_t out, int64_t k) {
    const torch::Tensor filters = take(weights, source, name + "/conv/filters", {k, k, in, out}).to(torch::kFloat);
    const torch::Tensor bias = take(weights, source, name + "/conv/bias", {out}).to(torch::kFloat);
    const torch::Tensor scale = take(weights, source, name + "/scale/weights", {out}).to(torch::kFloat);
    const torch::Tensor shift = take(weights, source, name + "/scale/biases", {out}).to(torch::kFloat);
    for (const char* part : {"/conv/filters", "/conv/bias", "/scale/weights", "/scale/biases"})
      source_[name + part] = weights.at(name + part).to(torch::kFloat).contiguous();
    // (conv(x, W) + b)·s + β = conv(x, W·s) + (b·s + β)
    Conv c{(filters.permute({3, 2, 0, 1}) * scale.view({-1, 1, 1, 1})).contiguous(), bias * scale + shift};
    std::string buffer = name;
    std::replace(buffer.begin(), buffer.end(), '/', '_');
    c.weight = register_buffer(buffer + "_weight", c.weight);
    c.bias = register_buffer(buffer + "_bias", c.bias);
    convs_[name] = c;
  };
  add("conv32_down", 3, 32, 7);
  int64_t in = 32;
  for (const Layer& layer : kLayers) {
    const int64_t out = channels_of(layer.name);
    add(std::string(layer.name) + "/conv1", in, out, 3);
    add(std::string(layer.name) + "/conv2", out, out, 3);
    in = out;
  }
  source_["fc"] = take(weights, source, "fc", {256, kEmbeddingSize}).to(torch::kFloat).contiguous();
  fc_ = register_buffer("fc", source_["fc"].clone());
}

std::map<std::string, torch::Tensor> FaceRecognitionNetImpl::tfjs_weights() const { return source_; }

torch::Tensor FaceRecognitionNetImpl::prepare(const torch::Tensor& images) {
  TORCH_CHECK(images.dim() == 4 && images.size(1) == 3, "FaceRecognitionNet takes [B, 3, H, W] images, got ",
              images.sizes());
  const int64_t h = images.size(2), w = images.size(3), square = std::max(h, w), diff = square - std::min(h, w);
  torch::Tensor x = images;
  if (h != kInputSize || w != kInputSize) {
    // face-api appends round(diff / 2) and prepends the rest.
    const int64_t before = diff - int64_t(std::floor(diff * 0.5 + 0.5));
    const auto options = images.options();
    const LegacyAxis ys = legacy_axis(square, h < w ? before : 0, h, kInputSize, options);
    const LegacyAxis xs = legacy_axis(square, w < h ? before : 0, w, kInputSize, options);
    auto horizontal = [&](const torch::Tensor& rows) {
      return rows.index_select(3, xs.lo) * xs.w_lo + rows.index_select(3, xs.hi) * xs.w_hi;
    };
    const torch::Tensor top = horizontal(x.index_select(2, ys.lo)), bottom = horizontal(x.index_select(2, ys.hi));
    x = top * ys.w_lo.view({-1, 1}) + bottom * ys.w_hi.view({-1, 1});
  }
  const torch::Tensor mean =
      torch::tensor({kMeanRgb[0] / 255, kMeanRgb[1] / 255, kMeanRgb[2] / 255}, images.options()).view({1, 3, 1, 1});
  return x - mean;
}

torch::Tensor FaceRecognitionNetImpl::apply(const torch::Tensor& x, const Conv& c, int stride, bool relu) const {
  // Stride 1 convolutions use "same" padding (3×3: one pixel each side), stride 2 ones "valid".
  const int64_t pad = stride == 1 ? c.weight.size(2) / 2 : 0;
  torch::Tensor out = F::conv2d(x, c.weight.to(x.dtype()),
                                F::Conv2dFuncOptions().bias(c.bias.to(x.dtype())).stride(stride).padding(pad));
  return relu ? torch::relu(out) : out;
}

torch::Tensor FaceRecognitionNetImpl::residual(const torch::Tensor& x, const std::string& name) const {
  const torch::Tensor out = apply(apply(x, convs_.at(name + "/conv1"), 1, true), convs_.at(name + "/conv2"), 1, false);
  return torch::relu(out + x);
}

torch::Tensor FaceRecognitionNetImpl::residual_down(const torch::Tensor& x, const std::string& name) const {
  torch::Tensor out = apply(apply(x, convs_.at(name + "/conv1"), 2, true), convs_.at(name + "/conv2"), 1, false);
  torch::Tensor pooled = F::avg_pool2d(x, F::AvgPool2dFuncOptions(2).stride(2));
  // face-api appends one zero row and one zero column to the residual branch when the pool is larger (even sizes).
  if (pooled.size(2) != out.size(2) || pooled.size(3) != out.size(3))
    out = F::pad(out, F::PadFuncOptions({0, 1, 0, 1}));
  if (pooled.size(1) != out.size(1)) pooled = torch::cat({pooled, torch::zeros_like(pooled)}, 1);
  return torch::relu(pooled + out);
}

FaceRecognitionNetImpl::Output FaceRecognitionNetImpl::forward_features(const torch::Tensor& images, bool embedding) {
  Output result;
  torch::Tensor out = apply(prepare(images), convs_.at("conv32_down"), 2, true);
  result.features.push_back(out);
  out = F::max_pool2d(out, F::MaxPool2dFuncOptions(3).stride(2));
  for (const Layer& layer : kLayers) {
    if (!embedding && result.features.size() == size_t(kFeatureLevels)) return result;
    out = layer.down ? residual_down(out, layer.name) : residual(out, layer.name);
    if (std::any_of(std::begin(kFeatureAfter), std::end(kFeatureAfter),
                    [&](const char* n) { return std::string(n) == layer.name; }))
      result.features.push_back(out);
  }
  result.embedding = torch::matmul(out.mean({2, 3}), fc_.to(out.dtype()));
  return result;
}

torch::Tensor FaceRecognitionNetImpl::forward(const torch::Tensor& images) {
  return forward_features(images).embedding;
}

}  // namespace bareskin::detect
