#include "training/nets/pix2pixhd.h"

#include <torch/torch.h>

#include <algorithm>

#include "core/error.h"
#include "core/json_options.h"
#include "training/nets/common.h"

namespace bareskin::nets {
namespace nn = torch::nn;
namespace {

nn::Conv2d hd_conv(int64_t in, int64_t out, int64_t k, int64_t stride, int64_t pad) {
  return nn::Conv2d(nn::Conv2dOptions(in, out, k).stride(stride).padding(pad));
}
nn::ConvTranspose2d up_conv(int64_t in, int64_t out) {
  return nn::ConvTranspose2d(nn::ConvTranspose2dOptions(in, out, 3).stride(2).padding(1).output_padding(1));
}
nn::ReflectionPad2d reflect(int64_t p) { return nn::ReflectionPad2d(nn::ReflectionPad2dOptions(p)); }

// The global generator's modules; `head` false leaves out the last three (pad, 7×7 conv, Tanh) as LocalEnhancer does.
nn::Sequential global_layers(int64_t in, int64_t out, int64_t ngf, int n_down, int n_blocks, const std::string& norm,
                             bool head) {
  nn::Sequential m(reflect(3), hd_conv(in, ngf, 7, 1, 0));
  push_norm(m, norm, ngf);
  m->push_back(nn::ReLU());
  for (int i = 0; i < n_down; ++i) {
    const int64_t c = ngf << i;
    m->push_back(hd_conv(c, c * 2, 3, 2, 1));
    push_norm(m, norm, c * 2);
    m->push_back(nn::ReLU());
  }
  for (int i = 0; i < n_blocks; ++i) m->push_back(HDResnetBlock(ngf << n_down, norm));
  for (int i = 0; i < n_down; ++i) {
    const int64_t c = ngf << (n_down - i);
    m->push_back(up_conv(c, c / 2));
    push_norm(m, norm, c / 2);
    m->push_back(nn::ReLU());
  }
  if (head) {
    m->push_back(reflect(3));
    m->push_back(hd_conv(ngf, out, 7, 1, 0));
    m->push_back(nn::Tanh());
  }
  return m;
}

void check_multiple(const torch::Tensor& x, int64_t channels, int64_t m, const std::string& what) {
  if (x.dim() != 4 || x.size(1) != channels || x.size(2) % m || x.size(3) % m)
    throw InvalidInput(
        what + " input", "shape " + c10::str(x.sizes()) + " does not fit",
        "give [N, " + std::to_string(channels) + ", H, W] with H and W multiples of " + std::to_string(m));
}

}  // namespace

void GlobalGeneratorOptions::check() const {
  const GlobalGeneratorOptions& o = *this;
  const std::string w = "pix2pixhd_global";
  check_norm(o.norm, w, false);
  require(o.in_channels >= 1 && o.out_channels >= 1 && o.ngf >= 1 && o.n_blocks >= 0, w,
          "channel counts must be positive and n_blocks not negative", "fix the options");
  require(o.n_downsampling >= 0 && o.n_downsampling <= 8, w, "n_downsampling must be in 0..8", "pix2pixHD uses 4");
}

// The keys of GlobalGeneratorOptions, listed once (core/json_options.h).
const auto kGlobalGeneratorFields = [](auto& v, auto& o) {
  v("in_channels", o.in_channels);
  v("out_channels", o.out_channels);
  v("ngf", o.ngf);
  v("n_downsampling", o.n_downsampling);
  v("n_blocks", o.n_blocks);
  v("norm", o.norm);
};

void to_json(nlohmann::json& j, const GlobalGeneratorOptions& o) { json_options::write(j, o, kGlobalGeneratorFields); }
void from_json(const nlohmann::json& j, GlobalGeneratorOptions& o) {
  json_options::read(j, o, "pix2pixhd_global", kGlobalGeneratorFields);
}

void LocalEnhancerOptions::check() const {
  const LocalEnhancerOptions& o = *this;
  const std::string w = "pix2pixhd_local";
  check_norm(o.norm, w, false);
  require(o.in_channels >= 1 && o.out_channels >= 1 && o.ngf >= 1 && o.n_blocks_global >= 0 && o.n_blocks_local >= 0, w,
          "channel counts must be positive and block counts not negative", "fix the options");
  require(
      o.n_downsample_global >= 0 && o.n_downsample_global <= 8 && o.n_local_enhancers >= 1 && o.n_local_enhancers <= 3,
      w, "n_downsample_global must be in 0..8 and n_local_enhancers in 1..3", "pix2pixHD uses 4 and 1");
}

// The keys of LocalEnhancerOptions, listed once (core/json_options.h).
const auto kLocalEnhancerFields = [](auto& v, auto& o) {
  v("in_channels", o.in_channels);
  v("out_channels", o.out_channels);
  v("ngf", o.ngf);
  v("n_downsample_global", o.n_downsample_global);
  v("n_blocks_global", o.n_blocks_global);
  v("n_local_enhancers", o.n_local_enhancers);
  v("n_blocks_local", o.n_blocks_local);
  v("norm", o.norm);
};

void to_json(nlohmann::json& j, const LocalEnhancerOptions& o) { json_options::write(j, o, kLocalEnhancerFields); }
void from_json(const nlohmann::json& j, LocalEnhancerOptions& o) {
  json_options::read(j, o, "pix2pixhd_local", kLocalEnhancerFields);
}

void MultiscaleDiscriminatorOptions::check() const {
  const MultiscaleDiscriminatorOptions& o = *this;
  const std::string w = "pix2pixhd_multiscale_d";
  check_norm(o.norm, w, false);
  require(o.in_channels >= 1 && o.ndf >= 1 && o.n_layers >= 1 && o.n_layers <= 8 && o.num_D >= 1 && o.num_D <= 5, w,
          "in_channels and ndf must be positive, n_layers in 1..8 and num_D in 1..5", "pix2pixHD uses 6, 64, 3, 2");
}

// The keys of MultiscaleDiscriminatorOptions, listed once (core/json_options.h).
const auto kMultiscaleDiscriminatorFields = [](auto& v, auto& o) {
  v("in_channels", o.in_channels);
  v("ndf", o.ndf);
  v("n_layers", o.n_layers);
  v("norm", o.norm);
  v("num_D", o.num_D);
  v("get_interm_feat", o.get_interm_feat);
  v("use_sigmoid", o.use_sigmoid);
};

void to_json(nlohmann::json& j, const MultiscaleDiscriminatorOptions& o) {
  json_options::write(j, o, kMultiscaleDiscriminatorFields);
}
void from_json(const nlohmann::json& j, MultiscaleDiscriminatorOptions& o) {
  json_options::read(j, o, "pix2pixhd_multiscale_d", kMultiscaleDiscriminatorFields);
}

HDResnetBlockImpl::HDResnetBlockImpl(int64_t dim, const std::string& norm) {
  conv_block_ = nn::Sequential(reflect(1), hd_conv(dim, dim, 3, 1, 0));
  push_norm(conv_block_, norm, dim);
  conv_block_->push_back(nn::ReLU());
  conv_block_->push_back(reflect(1));
  conv_block_->push_back(hd_conv(dim, dim, 3, 1, 0));
  push_norm(conv_block_, norm, dim);
  register_module("conv_block", conv_block_);
}

torch::Tensor HDResnetBlockImpl::forward(torch::Tensor x) { return x + conv_block_->forward(x); }

GlobalGeneratorImpl::GlobalGeneratorImpl(const GlobalGeneratorOptions& o) : options_(o) {
  o.check();
  model_ = register_module(
      "model", global_layers(o.in_channels, o.out_channels, o.ngf, o.n_downsampling, o.n_blocks, o.norm, true));
  init_normal_002(*this);
}

torch::Tensor GlobalGeneratorImpl::forward(torch::Tensor x) {
  check_multiple(x, options_.in_channels, int64_t(1) << options_.n_downsampling, "pix2pixhd_global");
  return model_->forward(x);
}

LocalEnhancerImpl::LocalEnhancerImpl(const LocalEnhancerOptions& o) : options_(o) {
  o.check();
  const int64_t ngf_global = int64_t(o.ngf) << o.n_local_enhancers;
  model_ = register_module("model", global_layers(o.in_channels, o.out_channels, ngf_global, o.n_downsample_global,
                                                  o.n_blocks_global, o.norm, false));
  for (int n = 1; n <= o.n_local_enhancers; ++n) {
    const int64_t c = int64_t(o.ngf) << (o.n_local_enhancers - n);
    nn::Sequential front(reflect(3), hd_conv(o.in_channels, c, 7, 1, 0));
    push_norm(front, o.norm, c);
    front->push_back(nn::ReLU());
    front->push_back(hd_conv(c, c * 2, 3, 2, 1));
    push_norm(front, o.norm, c * 2);
    front->push_back(nn::ReLU());
    nn::Sequential back;
    for (int i = 0; i < o.n_blocks_local; ++i) back->push_back(HDResnetBlock(c * 2, o.norm));
    back->push_back(up_conv(c * 2, c));
    push_norm(back, o.norm, c);
    back->push_back(nn::ReLU());
    if (n == o.n_local_enhancers) {
      back->push_back(reflect(3));
      back->push_back(hd_conv(o.ngf, o.out_channels, 7, 1, 0));
      back->push_back(nn::Tanh());
    }
    front_.push_back(register_module("model" + std::to_string(n) + "_1", front));
    back_.push_back(register_module("model" + std::to_string(n) + "_2", back));
  }
  init_normal_002(*this);
}

torch::Tensor LocalEnhancerImpl::forward(torch::Tensor x) {
  const int levels = options_.n_downsample_global + options_.n_local_enhancers;
  check_multiple(x, options_.in_channels, int64_t(1) << levels, "pix2pixhd_local");
  std::vector<torch::Tensor> pyramid = {x};
  for (int i = 0; i < options_.n_local_enhancers; ++i) pyramid.push_back(downsample_avg(pyramid.back()));
  torch::Tensor out = model_->forward(pyramid.back());
  for (int n = 1; n <= options_.n_local_enhancers; ++n) {
    const torch::Tensor& input = pyramid[options_.n_local_enhancers - n];
    out = back_[n - 1]->forward(front_[n - 1]->forward(input) + out);
  }
  return out;
}

MultiscaleDiscriminatorImpl::MultiscaleDiscriminatorImpl(const MultiscaleDiscriminatorOptions& o) : options_(o) {
  o.check();
  const auto leaky = [] { return nn::LeakyReLU(nn::LeakyReLUOptions().negative_slope(0.2)); };
  for (int d = 0; d < o.num_D; ++d) {
    // Layer groups of the reference's NLayerDiscriminator: padding ceil((4 − 1) / 2) = 2, channels doubled up to 512.
    std::vector<nn::Sequential> groups;
    groups.push_back(nn::Sequential(hd_conv(o.in_channels, o.ndf, 4, 2, 2), leaky()));
    int64_t nf = o.ndf;
    for (int n = 1; n <= o.n_layers; ++n) {
      const int64_t prev = nf;
      nf = std::min<int64_t>(nf * 2, 512);
      nn::Sequential g(hd_conv(prev, nf, 4, n < o.n_layers ? 2 : 1, 2));
      push_norm(g, o.norm, nf);
      g->push_back(leaky());
      groups.push_back(g);
    }
    groups.push_back(nn::Sequential(hd_conv(nf, 1, 4, 1, 2)));
    if (o.use_sigmoid) groups.push_back(nn::Sequential(nn::Sigmoid()));
    if (o.get_interm_feat) {
      for (size_t j = 0; j < groups.size(); ++j)
        register_module("scale" + std::to_string(d) + "_layer" + std::to_string(j), groups[j]);
    } else {
      nn::Sequential flat;
      for (auto& g : groups)
        for (const auto& m : *g) flat->push_back(m);
      groups = {register_module("layer" + std::to_string(d), flat)};
    }
    scales_.push_back(groups);
  }
  init_normal_002(*this);
}

torch::Tensor downsample_avg(const torch::Tensor& x) {
  return torch::avg_pool2d(x, 3, 2, 1, /*ceil_mode=*/false, /*count_include_pad=*/false);
}

std::vector<std::vector<torch::Tensor>> MultiscaleDiscriminatorImpl::forward(torch::Tensor x) {
  std::vector<std::vector<torch::Tensor>> result;
  const int num_D = options_.num_D;
  for (int i = 0; i < num_D; ++i) {
    std::vector<torch::Tensor> features;
    torch::Tensor h = x;
    for (auto& group : scales_[num_D - 1 - i]) {
      h = group->forward(h);
      features.push_back(h);
    }
    if (!options_.get_interm_feat) features = {h};
    result.push_back(std::move(features));
    if (i != num_D - 1) x = downsample_avg(x);
  }
  return result;
}

}  // namespace bareskin::nets
