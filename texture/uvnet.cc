#include "texture/uvnet.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "training/nets/zoo.h"

namespace bareskin::texture {

torch::Tensor uv_base(const torch::Tensor& inputs, UVFill fill) {
  // Channels: unwrap 0–2, confidence 3, mm_albedo 4–6 (texture/maps.h, input_maps()).
  auto seen = (inputs.narrow(1, 3, 1) > -1).to(inputs.dtype());
  auto unwrap = inputs.narrow(1, 0, 3), albedo = inputs.narrow(1, 4, 3);
  if (fill == UVFill::matched) {  // in [0, 1]: albedo × Σ_seen unwrap / Σ_seen albedo, per sample and channel
    auto u = (unwrap + 1) * 0.5, a = (albedo + 1) * 0.5;
    auto gain = (seen * u).sum({2, 3}, true) / (seen * a).sum({2, 3}, true).clamp_min(1e-3);
    gain = torch::where(seen.sum({2, 3}, true) > 0, gain, torch::ones_like(gain)).clamp(0.25, 4);
    albedo = (a * gain).clamp(0, 1) * 2 - 1;
  }
  auto diffuse = seen * unwrap + (1 - seen) * albedo;
  auto normal = torch::zeros_like(diffuse);
  normal.narrow(1, 2, 1).fill_(1);
  auto grey = torch::zeros_like(inputs.narrow(1, 0, 2));
  return torch::cat({diffuse, normal, grey}, 1);
}

UVNetImpl::UVNetImpl(const nlohmann::json& generator, int64_t res) {
  nlohmann::json unet = generator;
  if (unet.contains("fill")) {
    const auto& f = unet["fill"];
    if (f != "albedo" && f != "matched")
      throw InvalidInput("texture model", "fill " + f.dump() + " is not albedo or matched",
                         "set \"fill\": \"albedo\" (the 3DMM albedo where the photo did not see) or \"matched\"");
    fill_ = f == "matched" ? UVFill::matched : UVFill::albedo;
    unet.erase("fill");
  }
  nlohmann::json o = nets::find_model("unet256").defaults;
  const int levels = int(std::lround(std::log2(double(res))));
  o.update({{"ngf", 16}, {"norm", "none"}, {"dropout", false}, {"upsample", "resize_conv"},
            {"num_downs", std::max(5, std::min(7, levels))}});
  o.update(unet);
  o["in_channels"] = 13;
  o["out_channels"] = 8;
  nets::UNetOptions options;
  nets::from_json(o, options);  // InvalidInput for a bad key, type or value
  const int64_t multiple = int64_t(1) << options.num_downs;
  if (res % multiple != 0)
    throw InvalidInput("texture model", "res " + std::to_string(res) + " is not a multiple of 2^num_downs = " +
                                            std::to_string(multiple),
                       "pick --res as a multiple of " + std::to_string(multiple) + " or set num_downs");
  unet_ = register_module("unet", nets::UNet(options));
  prior_ = register_parameter("prior", torch::zeros({1, 8, res, res}));
  nets::zero_last_layer(*unet_);  // Δ starts at zero: the net starts at its base
}

torch::Tensor UVNetImpl::forward(const torch::Tensor& inputs) {
  return uv_base(inputs, fill_) + prior_ + unet_->forward(inputs);
}

}  // namespace bareskin::texture
