// Shards of rendered faces with their true coefficients (recon/recon.h: write_rendered_faces).
#include "recon/recon.h"

#include <cstring>

#include "core/error.h"
#include "core/png.h"
#include "core/shards.h"

namespace bareskin::recon {
namespace {

Image to_image(const torch::Tensor& chw) {
  const torch::Tensor t = chw.detach().to(torch::kCPU, torch::kFloat).clamp(0, 1).permute({1, 2, 0}).contiguous();
  Image img(int(t.size(1)), int(t.size(0)), int(t.size(2)), ColorSpace::Data);
  std::memcpy(img.pixels.data(), t.data_ptr<float>(), img.pixels.size() * sizeof(float));
  return img;
}

}  // namespace

void RenderedFacesOptions::check() const {
  if (count < 1 || per_shard < 1) throw InvalidInput("rendered faces", "count and per_shard must be at least 1", "");
  if (size < 16 || size > 4096) throw InvalidInput("rendered faces", "size must lie in [16, 4096]", "e.g. 64");
  if (!(sigma >= 0) || !(max_yaw >= 0 && max_yaw <= 1.6))
    throw InvalidInput("rendered faces", "sigma must be >= 0 and max_yaw in [0, 1.6] radians", "");
  if (split != "train" && split != "val" && split != "test")
    throw InvalidInput("rendered faces", "split '" + split + "' is not train, val or test", "");
}

void write_rendered_faces(const std::string& dir, const FaceModel& model, const RenderedFacesOptions& o) {
  o.check();
  torch::NoGradGuard guard;
  torch::Generator gen = at::detail::createCPUGenerator(o.seed);
  const CoefficientLayout l = model.layout(true);
  const Camera camera = canonical_camera(o.size);
  // Skin: every region but eyes, brows and mouth.
  torch::Tensor skin_vertex = torch::ones({model.vertices(), 1});
  for (size_t k = 0; k < model.region_names().size(); ++k) {
    const std::string& n = model.region_names()[k];
    if (n == "eyes" || n == "brows" || n == "mouth") skin_vertex.masked_fill_((model.vertex_region() == int64_t(k)).unsqueeze(1), 0);
  }
  shards::ShardWriter writer(dir, "faces", o.per_shard);
  for (int64_t i = 0; i < o.count; ++i) {
    torch::Tensor c = torch::zeros({1, l.size()});
    c.narrow(1, 0, l.id + l.exp + l.app).normal_(0, o.sigma, gen);
    const torch::Tensor u = torch::rand({8}, gen) * 2 - 1;
    c[0][l.rotation_offset()] = 0.15 * u[0];
    c[0][l.rotation_offset() + 1] = o.max_yaw * u[1];
    c[0][l.rotation_offset() + 2] = 0.1 * u[2];
    c[0][l.translation_offset()] = 5 * u[3];
    c[0][l.translation_offset() + 1] = 5 * u[4];
    c[0][l.translation_offset() + 2] = 20 * u[5];
    torch::Tensor g = c.narrow(1, l.gamma_offset(), 27).view({3, 9});
    const torch::Tensor mono = torch::randn({9}, gen) * 0.12;
    g.copy_(mono.unsqueeze(0) + torch::randn({3, 9}, gen) * 0.02);
    g.select(1, 0).add_(0.8 + 0.2 * u[6].item<double>());
    const FaceRender r = model.render(c, camera);
    const torch::Tensor bg = (0.25 + 0.2 * u[7]) + 0.05 * torch::randn({1, 3, o.size, o.size}, gen);
    const torch::Tensor before = linear_to_srgb(r.colour.clamp(0, 1)) * r.mask + bg.clamp(0, 1) * (1 - r.mask);
    // The skin mask: the per-vertex indicator through the rasterizer (nearest: > 0.5).
    const torch::Tensor pos = r.projected;
    const render_torch::Raster raster = render_torch::rasterize(pos, model.triangles(), o.size, o.size);
    const torch::Tensor skin = (render_torch::interpolate(skin_vertex.unsqueeze(0), pos, model.triangles(), raster) > 0.5)
                                   .to(torch::kFloat)
                                   .permute({0, 3, 1, 2});
    char key[24];
    std::snprintf(key, sizeof key, "%08lld", static_cast<long long>(i));
    nlohmann::json meta = {{"subject", "render/" + std::string(key)}, {"split", o.split}, {"style", "none"},
                           {"coefficients", coefficients_to_json(c[0], l)}, {"has_truth", true},
                           {"camera", {{"focal", camera.focal}, {"cx", camera.cx}, {"cy", camera.cy},
                                       {"width", o.size}, {"height", o.size}}},
                           {"align", {{"similarity", {{1, 0, 0}, {0, 1, 0}}}, {"source", "truth"}}}};
    const torch::Tensor lm = r.landmarks[0].to(torch::kDouble).contiguous();
    nlohmann::json points = nlohmann::json::array();
    for (int k = 0; k < 68; ++k) points.push_back({lm[k][0].item<double>(), lm[k][1].item<double>()});
    meta["landmarks"] = points;
    meta["landmarks_visible"] = std::vector<bool>(68, true);
    shards::Sample s;
    s.key = key;
    const std::string png = encode_png(to_image(before[0]));
    s.members["before.png"] = png;
    s.members["makeup.png"] = png;
    s.members["skin.png"] = encode_png(to_image(skin[0]));
    s.members["face.png"] = encode_png(to_image(r.mask[0]));
    s.members["json"] = meta.dump();
    writer.write(s);
  }
  shards::Manifest manifest;
  manifest.shards = writer.finish();
  manifest.metadata = {{"generator", "bareskin recon::write_rendered_faces"}, {"model", model.path()},
                       {"size", o.size}, {"seed", o.seed}, {"split", o.split}};
  shards::write_manifest(dir, manifest);
}

}  // namespace bareskin::recon
