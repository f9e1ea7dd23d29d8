#include "training/nets/unet.h"

#include <ATen/ops/mkldnn_convolution.h>
#include <ATen/ops/mkldnn_reorder_conv2d_weight.h>
#include <torch/torch.h>

#include "core/error.h"
#include "core/json_options.h"
#include "training/nets/common.h"

namespace bareskin::nets {
namespace nn = torch::nn;
namespace {

const char* kUnet = "unet";

nn::AnyModule upsampler(const UNetOptions& o, int64_t in, int64_t out, bool bias) {
  if (o.upsample == "resize_conv") return nn::AnyModule(ResizeConv(in, out, bias));
  return nn::AnyModule(nn::ConvTranspose2d(nn::ConvTranspose2dOptions(in, out, 4).stride(2).padding(1).bias(bias)));
}

}  // namespace

void UNetOptions::check() const {
  const UNetOptions& o = *this;
  check_norm(o.norm, kUnet);
  require(o.upsample == "transpose" || o.upsample == "resize_conv", kUnet, "upsample '" + o.upsample + "' is not known",
          "use transpose or resize_conv");
  require(o.num_downs >= 5 && o.num_downs <= 12, kUnet, "num_downs " + std::to_string(o.num_downs) + " is out of range",
          "use 5 to 12 (8 for 256² inputs)");
  require(o.in_channels >= 1 && o.out_channels >= 1 && o.ngf >= 1, kUnet, "channel counts must be positive",
          "fix in_channels, out_channels or ngf");
  require(o.max_mult >= 1 && o.max_mult <= 64, kUnet, "max_mult " + std::to_string(o.max_mult) + " is out of range",
          "use 1 to 64 (8: pix2pix)");
}

// The keys of UNetOptions, listed once (core/json_options.h).
const auto kUNetFields = [](auto& v, auto& o) {
  v("in_channels", o.in_channels);
  v("out_channels", o.out_channels);
  v("ngf", o.ngf);
  v("num_downs", o.num_downs);
  v.unless_default("max_mult", o.max_mult);  // written only when set: configurations from before it read the same
  v.unless_default("tanh", o.tanh);          // the same
  v("norm", o.norm);
  v("dropout", o.dropout);
  v("upsample", o.upsample);
};

void to_json(nlohmann::json& j, const UNetOptions& o) { json_options::write(j, o, kUNetFields); }
void from_json(const nlohmann::json& j, UNetOptions& o) { json_options::read(j, o, "unet", kUNetFields); }

ResizeConvImpl::ResizeConvImpl(int64_t in, int64_t out, bool bias) {
  conv_ = register_module("conv", nn::Conv2d(nn::Conv2dOptions(in, out, 3).padding(1).bias(bias)));
}

torch::Tensor ResizeConvImpl::forward(torch::Tensor x) {
  namespace F = nn::functional;
  x = F::interpolate(x, F::InterpolateFuncOptions()
                            .scale_factor(std::vector<double>{2.0, 2.0})
                            .mode(torch::kBilinear)
                            .align_corners(false));
  return conv_(x);
}

// The reference's UnetSkipConnectionBlock, module for module (indices matter for the names):
//   outermost:    [downconv, submodule, ReLU, upconv(2·inner → outer, bias), Tanh (unless tanh is false)]
//   intermediate: [LeakyReLU, downconv, downnorm, submodule, ReLU, upconv(2·inner → outer), upnorm, (Dropout)]
//   innermost:    [LeakyReLU, downconv, ReLU, upconv(inner → outer), upnorm]
UNetBlockImpl::UNetBlockImpl(Kind kind, int64_t outer, int64_t inner, int64_t input, const UNetOptions& o, bool dropout,
                             nn::AnyModule submodule)
    : outermost_(kind == Kind::outermost) {
  const bool bias = o.norm != "batch";
  auto downconv = nn::Conv2d(nn::Conv2dOptions(input, inner, 4).stride(2).padding(1).bias(bias));
  auto leaky = nn::LeakyReLU(nn::LeakyReLUOptions().negative_slope(0.2));
  model_ = nn::Sequential();
  if (kind == Kind::outermost) {
    model_->push_back(downconv);
    model_->push_back(std::move(submodule));
    model_->push_back(nn::ReLU());
    model_->push_back(upsampler(o, inner * 2, outer, true));
    if (o.tanh) model_->push_back(nn::Tanh());
  } else if (kind == Kind::innermost) {
    model_->push_back(leaky);
    model_->push_back(downconv);
    model_->push_back(nn::ReLU());
    model_->push_back(upsampler(o, inner, outer, bias));
    push_norm(model_, o.norm, outer);
  } else {
    model_->push_back(leaky);
    model_->push_back(downconv);
    push_norm(model_, o.norm, inner);
    model_->push_back(std::move(submodule));
    model_->push_back(nn::ReLU());
    model_->push_back(upsampler(o, inner * 2, outer, bias));
    push_norm(model_, o.norm, outer);
    if (dropout) model_->push_back(nn::Dropout(0.5));
  }
  register_module("model", model_);
}

torch::Tensor UNetBlockImpl::forward(torch::Tensor x) {
  if (outermost_) return model_->forward(x);
  return torch::cat({x, model_->forward(x)}, 1);
}

void zero_last_layer(UNetImpl& net) {
  // The outermost block's Sequential is [downconv, submodule, ReLU, upconv, Tanh]: index 3 is the last layer.
  torch::NoGradGuard no_grad;
  int zeroed = 0;
  for (auto& p : net.named_parameters())
    if (p.key().rfind("model.model.3.", 0) == 0) {
      p.value().zero_();
      ++zeroed;
    }
  BS_CHECK(zeroed > 0, "the U-Net has no outermost up-convolution (model.model.3)");
}

UNetImpl::UNetImpl(const UNetOptions& o) : options_(o) {
  o.check();
  using Kind = UNetBlockImpl::Kind;
  // Level i (0: the outermost) has ngf × min(2^i, max_mult) channels; pix2pix's dropout is in the levels 3 to
  // num_downs − 3, the ones between the ×8 level and the innermost.
  const int n = o.num_downs;
  std::vector<int64_t> c(n);
  for (int i = 0; i < n; ++i) c[i] = int64_t(o.ngf) * std::min<int64_t>(int64_t(1) << i, o.max_mult);  // i < num_downs ≤ 12
  auto block = UNetBlock(Kind::innermost, c[n - 2], c[n - 1], c[n - 2], o, false, nn::AnyModule());
  for (int i = n - 3; i >= 0; --i)
    block = UNetBlock(Kind::intermediate, c[i], c[i + 1], c[i], o, o.dropout && i >= 3, nn::AnyModule(block));
  const int64_t g = c[0];
  model_ = register_module(
      "model", UNetBlock(Kind::outermost, o.out_channels, g, o.in_channels, o, false, nn::AnyModule(block)));
  init_normal_002(*this);
}

torch::Tensor UNetImpl::forward(torch::Tensor x) {
  const int64_t m = int64_t(1) << options_.num_downs;
  if (x.dim() != 4 || x.size(1) != options_.in_channels || x.size(2) % m || x.size(3) % m)
    throw InvalidInput(
        "unet input", "shape " + c10::str(x.sizes()) + " does not fit",
        "give [N, " + std::to_string(options_.in_channels) + ", H, W] with H and W multiples of " + std::to_string(m));
  return model_->forward(x);
}

}  // namespace bareskin::nets

// ---- UNetInference ----

namespace bareskin::nets {
namespace {

// The folded form of a batch norm in eval mode after a layer whose output channels lie along `dim` of its weight.
void fold_batch_norm(torch::Tensor& w, torch::Tensor& b, const nn::BatchNorm2dImpl& bn, int64_t dim) {
  const auto& o = bn.options;
  auto mean = bn.running_mean, var = bn.running_var;
  auto gamma = o.affine() ? bn.weight : torch::ones_like(mean);
  auto beta = o.affine() ? bn.bias : torch::zeros_like(mean);
  auto s = gamma / torch::sqrt(var + o.eps());
  std::vector<int64_t> shape(size_t(w.dim()), 1);
  shape[size_t(dim)] = -1;
  w = w * s.view(shape);
  b = ((b.defined() ? b : torch::zeros_like(mean)) - mean) * s + beta;
}

// Output phase (a, b) of a 4×4 stride-2 padding-1 transposed convolution: rows 2m + a take the input rows
// {m − 1, m} (a = 0, kernel rows 3, 1) or {m, m + 1} (a = 1, kernel rows 2, 0); columns alike. As one 2×2
// convolution of the input padded by 1, the phase (a, b) is its output shifted by (a, b).
torch::Tensor phase_weight(const torch::Tensor& w) {  // [in, out, 4, 4] → [4·out, in, 2, 2], phases (0,0) (0,1) (1,0) (1,1)
  const auto taps = [](int64_t a) { return torch::tensor(a ? std::vector<int64_t>{2, 0} : std::vector<int64_t>{3, 1}, torch::kLong); };
  auto wt = w.transpose(0, 1);
  std::vector<torch::Tensor> phases;
  for (int64_t a = 0; a < 2; ++a)
    for (int64_t c = 0; c < 2; ++c) phases.push_back(wt.index_select(2, taps(a).to(w.device())).index_select(3, taps(c).to(w.device())));
  return torch::cat(phases, 0).contiguous();
}

// The phases of the 2×2 convolution (padding 1: [N, 4·out, H + 1, W + 1]) interleaved into [N, out, 2H, 2W].
torch::Tensor interleave_phases(const torch::Tensor& y, int64_t out) {
  const int64_t N = y.size(0), H = y.size(2) - 1, W = y.size(3) - 1;
  auto z = torch::empty({N, out, H, 2, W, 2}, y.options());
  for (int64_t a = 0; a < 2; ++a)
    for (int64_t c = 0; c < 2; ++c)
      z.select(5, c).select(3, a).copy_(y.narrow(1, (a * 2 + c) * out, out).narrow(2, a, H).narrow(3, c, W));
  return z.view({N, out, 2 * H, 2 * W});
}

}  // namespace

UNetInference::UNetInference(const UNetImpl& net, int64_t phase_min_side)
    : options_(net.options()), phase_min_side_(phase_min_side) {
  torch::NoGradGuard no_grad;
  auto copy = [](const torch::Tensor& t) { return t.defined() ? t.detach().clone() : torch::Tensor(); };
  for (const UNetBlockImpl* block = net.model_.get(); block;) {
    Level l;
    l.outermost = block->outermost_;
    const UNetBlockImpl* inner = nullptr;
    // UNetBlockImpl's layouts in order: a norm belongs to the convolution just before it.
    bool last_up = false;
    for (const auto& any : *block->model_) {
      const auto m = any.ptr();
      if (auto* conv = m->as<nn::Conv2d>()) {
        l.down = Conv{copy(conv->weight), copy(conv->bias), {}, 2, 1};
        last_up = false;
      } else if (auto* up = m->as<nn::ConvTranspose2d>()) {
        l.up_w = copy(up->weight);
        l.up_b = copy(up->bias);
        l.up_out = up->options.out_channels();
        last_up = true;
      } else if (auto* rc = m->as<ResizeConv>()) {
        l.up_w = copy(rc->conv_->weight);
        l.up_b = copy(rc->conv_->bias);
        l.up_out = rc->conv_->options.out_channels();
        l.resize_conv = last_up = true;
      } else if (auto* b = m->as<UNetBlock>()) {
        inner = b;
      } else if (auto* bn = m->as<nn::BatchNorm2d>()) {
        // transposed weights hold the output channels in dim 1, ordinary ones in dim 0
        if (last_up) fold_batch_norm(l.up_w, l.up_b, *bn, l.resize_conv ? 0 : 1);
        else fold_batch_norm(l.down.w, l.down.b, *bn, 0);
      } else if (m->as<nn::InstanceNorm2d>()) {
        (last_up ? l.up_norm : l.down_norm) = std::dynamic_pointer_cast<nn::InstanceNorm2dImpl>(m->clone());
      }
    }
    l.down.pack();
    if (!l.resize_conv && l.up_out >= 16 && phase_min_side_ > 0) {
      l.phase = Conv{phase_weight(l.up_w), l.up_b.defined() ? l.up_b.repeat({4}) : torch::Tensor(), {}, 1, 1};
      l.phase.pack();
    }
    l.innermost = inner == nullptr;
    levels_.push_back(std::move(l));
    block = inner;
  }
}

void UNetInference::Conv::pack() {
  packed = torch::Tensor();
  if (w.defined() && w.device().is_cpu() && at::hasMKLDNN())
    packed = at::mkldnn_reorder_conv2d_weight(w.to_mkldnn(), {padding, padding}, {stride, stride}, {1, 1}, 1);
}

torch::Tensor UNetInference::Conv::operator()(const torch::Tensor& x) const {
  if (packed.defined() && x.device().is_cpu() && x.scalar_type() == torch::kFloat)
    return at::mkldnn_convolution(x.contiguous(), packed, b.defined() ? c10::optional<torch::Tensor>(b) : c10::nullopt,
                                  {padding, padding}, {stride, stride}, {1, 1}, 1);
  return nn::functional::conv2d(x, w, nn::functional::Conv2dFuncOptions().bias(b).stride(stride).padding(padding));
}

UNetInference& UNetInference::to(torch::Device device) {
  for (auto& l : levels_) {
    for (auto* c : {&l.down, &l.phase}) {
      for (auto* t : {&c->w, &c->b})
        if (t->defined()) *t = t->to(device);
      c->pack();
    }
    for (auto* t : {&l.up_w, &l.up_b})
      if (t->defined()) *t = t->to(device);
    for (auto* n : {&l.down_norm, &l.up_norm})
      if (*n) (*n)->to(device);
  }
  return *this;
}

torch::Tensor UNetInference::upsample(const Level& l, const torch::Tensor& x) const {
  namespace F = nn::functional;
  torch::Tensor y;
  if (l.resize_conv) {
    y = F::interpolate(x, F::InterpolateFuncOptions()
                              .scale_factor(std::vector<double>{2.0, 2.0})
                              .mode(torch::kBilinear)
                              .align_corners(false));
    y = F::conv2d(y, l.up_w, F::Conv2dFuncOptions().bias(l.up_b).padding(1));
  } else if (l.phase.w.defined() && std::min(x.size(2), x.size(3)) >= phase_min_side_) {
    y = interleave_phases(l.phase(x), l.up_out);
  } else {
    y = F::conv_transpose2d(x, l.up_w, F::ConvTranspose2dFuncOptions().bias(l.up_b).stride(2).padding(1));
  }
  return l.up_norm ? l.up_norm->forward(y) : y;
}

// One level: outermost  tanh(up(relu(inner(down(x))))) (without the tanh when options.tanh is false);
//            the others cat(x, up(relu(inner(down(leaky(x)))))) — the parent's ReLU follows the concatenation, and
//            relu(leaky(x)) = relu(x), so x may be replaced by leaky(x) in place (as the reference's in-place
//            LeakyReLU does).
torch::Tensor UNetInference::level_forward(size_t i, torch::Tensor x) const {
  namespace F = nn::functional;
  const Level& l = levels_[i];
  if (l.outermost) {
    auto h = level_forward(i + 1, l.down(x));
    auto y = upsample(l, torch::relu_(h));
    return options_.tanh ? torch::tanh_(y) : y;
  }
  torch::leaky_relu_(x, 0.2);
  auto h = l.down(x);
  if (l.down_norm) h = l.down_norm->forward(h);
  h = l.innermost ? h : level_forward(i + 1, h);
  return torch::cat({x, upsample(l, torch::relu_(h))}, 1);
}

torch::Tensor UNetInference::forward(const torch::Tensor& x) const {
  const int64_t m = int64_t(1) << options_.num_downs;
  if (x.dim() != 4 || x.size(1) != options_.in_channels || x.size(2) % m || x.size(3) % m)
    throw InvalidInput(
        "unet input", "shape " + c10::str(x.sizes()) + " does not fit",
        "give [N, " + std::to_string(options_.in_channels) + ", H, W] with H and W multiples of " + std::to_string(m));
  torch::NoGradGuard no_grad;
  return level_forward(0, x);
}

}  // namespace bareskin::nets
