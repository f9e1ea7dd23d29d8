#include "texgen/contact_sheet.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/png.h"
#include "core/shards.h"

namespace bareskin::texgen {
namespace fs = std::filesystem;
namespace {

// A 3x5 pixel font for the labels (rows top to bottom, 3 bits each, most significant bit on the left).
struct Glyph {
  char c;
  uint8_t rows[5];
};
constexpr Glyph kFont[] = {
    {'A', {2, 5, 7, 5, 5}}, {'B', {6, 5, 6, 5, 6}}, {'D', {6, 5, 5, 5, 6}}, {'E', {7, 4, 6, 4, 7}},
    {'F', {7, 4, 6, 4, 4}}, {'I', {7, 2, 2, 2, 7}}, {'K', {5, 5, 6, 5, 5}}, {'L', {4, 4, 4, 4, 7}},
    {'M', {5, 7, 7, 5, 5}}, {'N', {7, 5, 5, 5, 5}}, {'O', {7, 5, 5, 5, 7}}, {'P', {6, 5, 6, 4, 4}},
    {'R', {6, 5, 6, 5, 5}}, {'S', {3, 4, 2, 1, 6}}, {'U', {5, 5, 5, 5, 7}}, {'/', {1, 1, 2, 4, 4}},
};

void draw_text(Image& img, const std::string& text, int cx, int cy, int scale, const Eigen::Vector3f& colour) {
  const int advance = 4 * scale, width = int(text.size()) * advance - scale;
  int x0 = cx - width / 2;
  const int y0 = cy - 5 * scale / 2;
  for (char ch : text) {
    const char up = char(std::toupper(static_cast<unsigned char>(ch)));
    for (const Glyph& g : kFont) {
      if (g.c != up) continue;
      for (int r = 0; r < 5; ++r)
        for (int b = 0; b < 3; ++b) {
          if (!(g.rows[r] >> (2 - b) & 1)) continue;
          for (int dy = 0; dy < scale; ++dy)
            for (int dx = 0; dx < scale; ++dx) {
              const int x = x0 + b * scale + dx, y = y0 + r * scale + dy;
              if (x < 0 || y < 0 || x >= img.width || y >= img.height) continue;
              for (int c = 0; c < 3; ++c) img.at(x, y, c) = colour[c];
            }
        }
    }
    x0 += advance;
  }
}

// The member as an RGB tile of size² (bilinear), or empty when absent.
Image member_tile(const shards::Sample& s, const std::string& name, int size, const std::string& where) {
  const auto it = s.members.find(name);
  if (it == s.members.end()) return {};
  const Image in = decode_png(it->second, where + ": " + s.key + "." + name);
  Image out(size, size, 3, ColorSpace::sRGB);
  const float sx = float(in.width) / float(size), sy = float(in.height) / float(size);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const float fx = std::clamp((float(x) + 0.5f) * sx - 0.5f, 0.0f, float(in.width - 1)),
                  fy = std::clamp((float(y) + 0.5f) * sy - 0.5f, 0.0f, float(in.height - 1));
      const int x0 = int(fx), y0 = int(fy), x1 = std::min(x0 + 1, in.width - 1), y1 = std::min(y0 + 1, in.height - 1);
      const float tx = fx - float(x0), ty = fy - float(y0);
      for (int c = 0; c < 3; ++c) {
        const int k = std::min(c, in.channels >= 3 ? 2 : 0);
        out.at(x, y, c) = (1 - ty) * ((1 - tx) * in.at(x0, y0, k) + tx * in.at(x1, y0, k)) +
                          ty * ((1 - tx) * in.at(x0, y1, k) + tx * in.at(x1, y1, k));
      }
    }
  return out;
}

Image na_tile(int size) {
  Image t(size, size, 3, ColorSpace::sRGB, 0.5f);
  draw_text(t, "n/a", size / 2, size / 2, std::max(2, size / 40), {0.8f, 0.8f, 0.8f});
  return t;
}

// The 68 landmarks of the json member on a copy of `tile` (coordinates in the member's pixels, scaled to the tile).
Image landmark_tile(const shards::Sample& s, Image tile, int member_size, const std::string& where) {
  const auto it = s.members.find("json");
  if (it == s.members.end() || tile.empty()) return {};
  nlohmann::json meta;
  try {
    meta = nlohmann::json::parse(it->second);
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInput(where + ": " + s.key + ".json", std::string("malformed JSON: ") + e.what(),
                       "regenerate the shard");
  }
  if (!meta.contains("landmarks")) return {};
  const double scale = double(tile.width) / double(member_size);
  const auto& visible = meta.value("landmarks_visible", nlohmann::json::array());
  for (size_t k = 0; k < meta["landmarks"].size(); ++k) {
    const auto& p = meta["landmarks"][k];
    const bool vis = visible.size() <= k || visible[k].get<bool>();
    const int cx = int(std::floor(p[0].get<double>() * scale)), cy = int(std::floor(p[1].get<double>() * scale));
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int x = cx + dx, y = cy + dy;
        if (x < 0 || y < 0 || x >= tile.width || y >= tile.height) continue;
        tile.at(x, y, 0) = vis ? 0.1f : 1.0f;
        tile.at(x, y, 1) = vis ? 1.0f : 0.1f;
        tile.at(x, y, 2) = 0.1f;
      }
  }
  return tile;
}

std::vector<std::string> shard_sets(const std::string& dataset) {
  if (fs::is_regular_file(dataset) || fs::exists(fs::path(dataset) / "manifest.json")) return {dataset};
  std::vector<std::string> out;
  for (const char* split : {"train", "val", "test"})
    if (fs::exists(fs::path(dataset) / split / "manifest.json")) out.push_back((fs::path(dataset) / split).string());
  if (out.empty()) {
    throw InvalidInput(dataset, "is not a shard set (no manifest.json, no .tar, no train/val/test with one)",
                       "give a texgen output folder or one of its shard sets");
  }
  return out;
}

}  // namespace

void ContactSheetOptions::check() const {
  if (count < 1 || tile < 32 || tile > 4096)
    throw InvalidInput("--count", "count must be >= 1 and tile in [32, 4096]", "use e.g. --count 8");
}

Image contact_sheet(const std::string& dataset, const ContactSheetOptions& o) {
  o.check();
  static const char* const kColumns[] = {"makeup", "before", "bare", "skin", "landmarks"};
  const int t = o.tile, header = std::max(16, t / 10);
  std::vector<std::vector<Image>> rows;
  for (const std::string& set : shard_sets(dataset)) {
    const shards::Manifest manifest = shards::open_dataset(set);
    for (const shards::ShardInfo& info : manifest.shards) {
      const std::string path = shards::shard_path(set, info);
      shards::ShardReader reader(path);
      shards::Sample s;
      while (int(rows.size()) < o.count && reader.next(s)) {
        std::vector<Image> row;
        for (const char* name : {"makeup.png", "before.png", "bare.png", "skin.png"})
          row.push_back(member_tile(s, name, t, path));
        int member_size = t;
        if (s.members.count("makeup.png")) member_size = decode_png(s.members.at("makeup.png"), path).width;
        row.push_back(landmark_tile(s, row[0], member_size, path));
        rows.push_back(row);
      }
      if (int(rows.size()) >= o.count) break;
    }
    if (int(rows.size()) >= o.count) break;
  }
  if (rows.empty()) throw InvalidInput(dataset, "holds no sample", "generate the shards first");
  Image sheet(5 * t, header + int(rows.size()) * t, 3, ColorSpace::sRGB, 0.0f);
  for (int c = 0; c < 5; ++c)
    draw_text(sheet, kColumns[c], c * t + t / 2, header / 2, std::max(2, header / 8), {1, 1, 1});
  const Image na = na_tile(t);
  for (size_t r = 0; r < rows.size(); ++r)
    for (int c = 0; c < 5; ++c) {
      const Image& tile = rows[r][size_t(c)].empty() ? na : rows[r][size_t(c)];
      for (int y = 0; y < t; ++y)
        for (int x = 0; x < t; ++x)
          for (int k = 0; k < 3; ++k) sheet.at(c * t + x, header + int(r) * t + y, k) = tile.at(x, y, k);
    }
  return sheet;
}

}  // namespace bareskin::texgen
