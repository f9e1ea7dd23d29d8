#include "uvtools/bake.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/mesh_io.h"
#include "core/parallel.h"

namespace bareskin {
namespace {

namespace fs = std::filesystem;

enum class Kind { Colour, Normal, Scalar };

struct MapFile {
  std::string name, path;
  Kind kind;
};

std::vector<MapFile> find_maps(const std::string& dir) {
  const std::pair<const char*, Kind> names[] = {
      {"diffuse", Kind::Colour}, {"normal", Kind::Normal}, {"roughness", Kind::Scalar}, {"specular", Kind::Scalar}};
  std::vector<MapFile> maps;
  for (const auto& [name, kind] : names) {
    for (const char* ext : {".exr", ".tif", ".tiff", ".png"}) {
      const std::string p = dir + "/" + name + ext;
      if (fs::exists(p)) {
        maps.push_back({name, p, kind});
        break;
      }
    }
  }
  if (maps.empty()) {
    throw InvalidInput(dir, "holds no diffuse, normal, roughness or specular map (.exr, .tif, .png)",
                       "point at a folder of maps");
  }
  return maps;
}

// Output texels with no island texel under them take the mean of their filled 8-neighbours, `passes` times. Each pass
// visits only the unfilled texels next to a filled one (the front), so its cost follows the gutter, not the map.
void fill_gutter(std::vector<float>& value, std::vector<uint8_t>& filled, int s, int channels, int passes) {
  const auto neighbours = [s](size_t i, auto&& f) {
    const int64_t y = int64_t(i) / s, x = int64_t(i) % s;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int64_t yy = y + dy, xx = x + dx;
        if (yy < 0 || yy >= s || xx < 0 || xx >= s || (dx == 0 && dy == 0)) continue;
        f(size_t(yy) * size_t(s) + size_t(xx));
      }
  };
  // The first front: unfilled texels with a filled neighbour, row by row (no index division per texel).
  std::vector<uint8_t> queued(filled.size(), 0);
  std::vector<size_t> front;
  for (int y = 0; y < s; ++y) {
    const uint8_t* above = y > 0 ? &filled[size_t(y - 1) * size_t(s)] : nullptr;
    const uint8_t* row = &filled[size_t(y) * size_t(s)];
    const uint8_t* below = y + 1 < s ? &filled[size_t(y + 1) * size_t(s)] : nullptr;
    for (int x = 0; x < s; ++x) {
      if (row[x]) continue;
      const int x0 = std::max(0, x - 1), x1 = std::min(s - 1, x + 1);
      bool next_to_filled = false;
      for (int xx = x0; xx <= x1 && !next_to_filled; ++xx)
        next_to_filled = row[xx] || (above && above[xx]) || (below && below[xx]);
      if (next_to_filled) {
        queued[size_t(y) * size_t(s) + size_t(x)] = 1;
        front.push_back(size_t(y) * size_t(s) + size_t(x));
      }
    }
  }
  for (int pass = 0; pass < passes && !front.empty(); ++pass) {
    // Values of this pass come from texels filled before it only; the front is unfilled, so the order is free.
    for (size_t i : front) {
      float sum[4] = {0, 0, 0, 0};
      int n = 0;
      neighbours(i, [&](size_t j) {
        if (!filled[j]) return;
        for (int c = 0; c < channels; ++c) sum[c] += value[j * size_t(channels) + size_t(c)];
        ++n;
      });
      for (int c = 0; c < channels; ++c) value[i * size_t(channels) + size_t(c)] = sum[c] / float(n);
    }
    for (size_t i : front) filled[i] = 1;
    std::vector<size_t> next;
    for (size_t i : front)
      neighbours(i, [&](size_t j) {
        if (!filled[j] && !queued[j]) queued[j] = 1, next.push_back(j);
      });
    front.swap(next);
  }
}

}  // namespace

void MapResizeOptions::check() const {
  if (sizes.empty()) throw InvalidInput("", "no output sizes", "give --sizes, e.g. 4096,1024");
  for (int s : sizes)
    if (s < 1 || s > 65536) throw InvalidInput("", "output sizes must lie in [1, 65536]", "");
  if (format != "exr" && format != "png" && format != "tif") {
    throw InvalidInput("", "unknown format '" + format + "'", "use exr, png or tif");
  }
  if (gutter < 0 || gutter > 256) throw InvalidInput("", "--gutter must lie in [0, 256]", "");
}

namespace {

// One output size of one map while it is being filtered.
struct Output {
  int size, factor;
  std::vector<float> value;
  std::vector<uint8_t> filled;
  std::vector<float> length;  // normals: the averaged vector's length (for Toksvig)
};

// The map set: every map square, one size for the set, each output size dividing it. Sizes come back largest first.
int check_map_set(const std::vector<MapFile>& maps, std::vector<int>& sizes) {
  const int N = probe_image(maps.front().path).width;
  for (const MapFile& m : maps) {
    const ImageFileInfo info = probe_image(m.path);
    if (info.width != info.height) {
      throw InvalidInput(m.path, "is " + std::to_string(info.width) + "x" + std::to_string(info.height) + ", not square",
                         "UV maps must be square");
    }
    if (info.width != N) {
      throw InvalidInput(m.path, "is " + std::to_string(info.width) + " wide, " + maps.front().path + " is " +
                                     std::to_string(N), "give one set of maps of one size");
    }
    if (m.kind == Kind::Normal && info.channels < 3) {
      throw InvalidInput(m.path, "a normal map needs 3 channels, it has " + std::to_string(info.channels), "");
    }
  }
  std::sort(sizes.begin(), sizes.end(), std::greater<int>());
  sizes.erase(std::unique(sizes.begin(), sizes.end()), sizes.end());
  for (int s : sizes) {
    if (s > N || N % s != 0) {
      throw InvalidInput(maps.front().path, "is " + std::to_string(N) + " wide; " + std::to_string(s) +
                                                " does not divide it", "choose sizes that divide the input size");
    }
  }
  return N;
}

// srgb_to_linear of the floats an 8-bit file decodes to (k / 255, however the reader rounds it), from a table; other
// values (16-bit, float files) through the formula. Same values as the formula, without a pow per texel.
class SrgbDecodeTable {
 public:
  SrgbDecodeTable() {
    for (int k = 0; k < 256; ++k) {
      key_[0][k] = float(k) / 255.f;
      key_[1][k] = float(k) * (1.f / 255.f);
      for (int i = 0; i < 2; ++i) value_[i][k] = srgb_to_linear(key_[i][k]);
    }
  }
  float operator()(float p) const {
    const long k = std::lround(p * 255.f);
    if (k >= 0 && k < 256) {
      if (p == key_[0][k]) return value_[0][k];
      if (p == key_[1][k]) return value_[1][k];
    }
    return srgb_to_linear(p);
  }

 private:
  float key_[2][256], value_[2][256];
};

// Decodes a band in place: sRGB → linear, normals (v + 1) / 2 → v; a zero normal inside an island is an error.
void decode_band(const MapFile& m, bool decode_srgb, int C, int Cin, int N, int y0, int rows, std::vector<float>& band,
                 const std::vector<uint8_t>& mask) {
  static const SrgbDecodeTable srgb;
  parallel_for(0, rows, [&](int64_t r0, int64_t r1) {
    for (int64_t r = r0; r < r1; ++r)
      for (int x = 0; x < N; ++x) {
        float* p = &band[(size_t(r) * size_t(N) + size_t(x)) * size_t(Cin)];
        if (decode_srgb) {
          for (int c = 0; c < std::min(C, 3); ++c) p[c] = srgb(p[c]);
        } else if (m.kind == Kind::Normal) {
          for (int c = 0; c < 3; ++c) p[c] = 2 * p[c] - 1;
          if (mask[size_t(r) * size_t(N) + size_t(x)] && p[0] * p[0] + p[1] * p[1] + p[2] * p[2] < 0.0025f) {
            throw InvalidInput(m.path, "holds a zero normal vector at texel (" + std::to_string(x) + ", " +
                                           std::to_string(y0 + r) + ") inside a UV island",
                               "repair the normal map (unit vectors encoded as (n + 1) / 2)");
          }
        }
      }
  }, 8);
}

// The box filter of one output size over the band's island texels (normals renormalised, their length kept).
void filter_band(Kind kind, int C, int Cin, int N, int y0, int rows, const std::vector<float>& band,
                 const std::vector<uint8_t>& mask, Output& o) {
  const int f = o.factor, out_rows = rows / f;
  parallel_for(0, int64_t(out_rows), [&](int64_t r0, int64_t r1) {
    for (int oy = int(r0); oy < int(r1); ++oy)
      for (int ox = 0; ox < o.size; ++ox) {
        const size_t o_i = size_t(y0 / f + oy) * size_t(o.size) + size_t(ox);
        float* v = &o.value[o_i * size_t(C)];
        if (f == 1) {  // the input size itself: the island texels as they are (what the mean of one gives)
          const size_t i = size_t(oy) * size_t(N) + size_t(ox);
          if (!mask[i]) continue;
          for (int c = 0; c < C; ++c) v[c] = band[i * size_t(Cin) + size_t(c)];
        } else {
          double sum[4] = {0, 0, 0, 0};
          int n = 0;
          for (int dy = 0; dy < f; ++dy) {
            const size_t row = size_t(oy * f + dy) * size_t(N);
            for (int dx = 0; dx < f; ++dx) {
              const size_t i = row + size_t(ox * f + dx);
              if (!mask[i]) continue;
              const float* p = &band[i * size_t(Cin)];
              for (int c = 0; c < C; ++c) sum[c] += p[c];
              ++n;
            }
          }
          if (!n) continue;
          for (int c = 0; c < C; ++c) v[c] = float(sum[c] / n);
        }
        o.filled[o_i] = 1;
        if (kind == Kind::Normal) {
          const float len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
          o.length[o_i] = len;
          for (int c = 0; c < 3; ++c) v[c] /= std::max(len, 1e-12f);
        }
      }
  }, std::max(1, 256 / o.size));  // output rows per task: about 256 texels at least
}

// Toksvig: the averaged normal's length L < 1 measures the normal variance under the texel; with GGX alpha =
// roughness^2, alpha'^2 = alpha^2 + (1 - L) / L.
void toksvig(Output& o, int C, const std::vector<float>& L) {
  for (size_t i = 0; i < o.filled.size(); ++i) {
    if (!o.filled[i]) continue;
    const double l = std::clamp(double(L[i]), 1e-3, 1.0);
    for (int c = 0; c < C; ++c) {
      const double a = double(o.value[i * size_t(C) + size_t(c)]) * o.value[i * size_t(C) + size_t(c)];
      o.value[i * size_t(C) + size_t(c)] = float(std::sqrt(std::min(1.0, std::sqrt(a * a + (1 - l) / l))));
    }
  }
}

// Gutters and normals encoded; the values move into the image (no second copy of a 4K map).
Image finish_output(Output& o, const MapFile& m, int C, const MapResizeOptions& options) {
  fill_gutter(o.value, o.filled, o.size, C, options.gutter);
  if (m.kind == Kind::Normal) {  // encode (n + 1) / 2; beyond the gutter, +z
    for (size_t i = 0; i < o.filled.size(); ++i)
      for (int c = 0; c < 3; ++c) {
        float& v = o.value[i * size_t(C) + size_t(c)];
        v = o.filled[i] ? 0.5f * (v + 1) : (c == 2 ? 1.f : 0.5f);
      }
  }
  Image img;
  img.width = img.height = o.size;
  img.channels = C;
  img.color_space = m.kind == Kind::Colour ? ColorSpace::Linear : ColorSpace::Data;
  img.pixels = std::move(o.value);
  std::vector<uint8_t>().swap(o.filled);
  return img;
}

// One row's coverage by the layout's triangles: the covered columns into `row` (1), and the count of texel centres
// strictly inside two or more triangles.
struct UvTriangle {
  Eigen::Vector2d p[3];
};
int64_t scan_row(const std::vector<UvTriangle>& triangles, const std::vector<int>& candidates, double yc, int size,
                 std::vector<uint8_t>& row, std::vector<uint8_t>& hits) {
  std::fill(row.begin(), row.end(), 0);
  std::fill(hits.begin(), hits.end(), 0);
  for (int id : candidates) {
    const UvTriangle& t = triangles[size_t(id)];
    double x0 = 1e300, x1 = -1e300;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector2d &a = t.p[k], &c = t.p[(k + 1) % 3];
      if ((a.y() - yc) * (c.y() - yc) > 0 || a.y() == c.y()) {
        if (a.y() == yc) x0 = std::min(x0, a.x()), x1 = std::max(x1, a.x());
        continue;
      }
      const double x = a.x() + (yc - a.y()) / (c.y() - a.y()) * (c.x() - a.x());
      x0 = std::min(x0, x), x1 = std::max(x1, x);
    }
    if (x0 > x1) continue;
    const int c0 = std::max(0, int(std::ceil(x0 - 0.5))), c1 = std::min(size - 1, int(std::floor(x1 - 0.5)));
    for (int c = c0; c <= c1; ++c) {
      row[size_t(c)] = 1;
      if (c + 0.5 > x0 && c + 0.5 < x1 && hits[size_t(c)] < 255) ++hits[size_t(c)];
    }
  }
  int64_t n = 0;
  for (uint8_t h : hits) n += h > 1;
  return n;
}

}  // namespace

UvIslands::UvIslands(const Mesh& layout, int size) : size_(size) {
  if (!layout.has_uv()) throw InvalidInput("layout", "the layout mesh has no UVs", "give a mesh with UVs (the template)");
  // The triangles in pixel space (y down), bucketed by the bands of rows they touch.
  const int band_rows = 64, bands = (size + band_rows - 1) / band_rows;
  std::vector<UvTriangle> triangles;
  std::vector<std::vector<int>> buckets(static_cast<size_t>(bands));
  int positive = 0;
  std::vector<double> area(size_t(layout.F.rows()));
  for (Eigen::Index f = 0; f < layout.F.rows(); ++f) {
    UvTriangle t;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector2d uv = layout.UV.row(layout.FUV(f, k)).transpose();
      t.p[k] = {uv.x() * size, (1 - uv.y()) * size};
    }
    area[size_t(f)] = (t.p[1] - t.p[0]).x() * (t.p[2] - t.p[0]).y() - (t.p[1] - t.p[0]).y() * (t.p[2] - t.p[0]).x();
    if (area[size_t(f)] > 0) ++positive;
    const double y0 = std::min({t.p[0].y(), t.p[1].y(), t.p[2].y()}), y1 = std::max({t.p[0].y(), t.p[1].y(), t.p[2].y()});
    if (std::abs(area[size_t(f)]) < 1e-12 || y1 < 0 || y0 > size) continue;
    const int id = int(triangles.size());
    triangles.push_back(t);
    for (int b = std::max(0, int(y0) / band_rows); b <= std::min(bands - 1, int(y1) / band_rows); ++b)
      buckets[size_t(b)].push_back(id);
  }
  const bool majority_positive = 2 * positive >= layout.F.rows();
  for (double a : area)
    if (a != 0 && (a > 0) != majority_positive) ++flipped_triangles;
  // Row by row: the covered columns as spans.
  std::vector<std::vector<std::pair<int32_t, int32_t>>> rows(static_cast<size_t>(size));
  std::atomic<int64_t> overlaps{0}, covered{0};
  parallel_for(0, size, [&](int64_t y0, int64_t y1) {
    std::vector<uint8_t> row(static_cast<size_t>(size)), hits(static_cast<size_t>(size));
    for (int64_t y = y0; y < y1; ++y) {
      overlaps += scan_row(triangles, buckets[size_t(y / band_rows)], double(y) + 0.5, size, row, hits);
      int64_t n = 0;
      for (int x = 0; x < size;) {
        if (!row[size_t(x)]) {
          ++x;
          continue;
        }
        int e = x;
        while (e + 1 < size && row[size_t(e + 1)]) ++e;
        rows[size_t(y)].push_back({x, e});
        n += e - x + 1;
        x = e + 1;
      }
      covered += n;
    }
  }, 16);
  row_start_.assign(size_t(size) + 1, 0);
  for (int y = 0; y < size; ++y) row_start_[size_t(y) + 1] = row_start_[size_t(y)] + int64_t(rows[size_t(y)].size());
  spans_.reserve(size_t(row_start_.back()));
  for (const auto& r : rows) spans_.insert(spans_.end(), r.begin(), r.end());
  overlapping_texels = overlaps.load();
  fraction = double(covered.load()) / (double(size) * size);
}

void UvIslands::mask_rows(int y0, int rows, std::vector<uint8_t>& mask) const {
  BS_CHECK(y0 >= 0 && rows >= 0 && y0 + rows <= size_, "UvIslands::mask_rows: rows out of range");
  mask.assign(size_t(rows) * size_t(size_), 0);
  for (int r = 0; r < rows; ++r)
    for (int64_t k = row_start_[size_t(y0 + r)]; k < row_start_[size_t(y0 + r) + 1]; ++k) {
      uint8_t* m = &mask[size_t(r) * size_t(size_)];
      std::fill(m + spans_[size_t(k)].first, m + spans_[size_t(k)].second + 1, uint8_t(1));
    }
}

int map_set_size(const std::string& in_dir) {
  std::vector<int> none;
  return check_map_set(find_maps(in_dir), none);
}

MapResizeReport bake_maps(const std::string& in_dir, const UvIslands* islands, const MapResizeOptions& options,
                          const BakedMapSink& sink, const ProgressCallback& progress) {
  // 1. The maps and sizes; the layout's islands (without a layout every texel counts: a plain resize).
  options.check();
  std::vector<MapFile> maps = find_maps(in_dir);
  MapResizeReport result;
  std::vector<int> sizes = options.sizes;
  const int N = check_map_set(maps, sizes);
  if (islands && islands->size() != N)
    throw InvalidInput(in_dir, "holds " + std::to_string(N) + "² maps, the layout raster is " +
                                   std::to_string(islands->size()) + "²", "bake each map size through its own raster");
  result.input_size = N;
  result.layout = islands != nullptr;
  result.flipped_triangles = islands ? islands->flipped_triangles : 0;
  result.island_fraction = islands ? islands->fraction : 1.0;
  result.overlapping_texels = islands ? islands->overlapping_texels : 0;
  const int F = N / sizes.back();                       // the largest factor
  const int band_rows = F * std::max(1, 128 / F);        // input rows per pass: a multiple of every factor

  // 2. Map by map, band by band: read, decode, box-filter into every output size. Diffuse first (make-dataset renders
  // with it while the others bake), then normal before roughness, so that Toksvig can use the normals' lengths.
  std::stable_sort(maps.begin(), maps.end(), [](const MapFile& a, const MapFile& b) { return int(a.kind) < int(b.kind); });
  std::map<int, std::vector<float>> normal_length;  // per output size, for Toksvig
  const int64_t bands = (N + band_rows - 1) / band_rows;
  for (size_t mi = 0; mi < maps.size(); ++mi) {
    const MapFile& m = maps[mi];
    result.maps.push_back(m.name);
    ImageStreamReader in(m.path, m.kind == Kind::Colour ? std::nullopt : std::optional<ColorSpace>(ColorSpace::Data));
    const int C = std::min(in.info().channels, 4), Cin = in.info().channels;
    const bool decode_srgb = m.kind == Kind::Colour && in.info().color_space == ColorSpace::sRGB;
    std::vector<Output> outs;
    for (int s : sizes) {
      Output o{s, N / s, std::vector<float>(size_t(s) * size_t(s) * size_t(C), 0.f), std::vector<uint8_t>(size_t(s) * size_t(s), 0), {}};
      if (m.kind == Kind::Normal) o.length.assign(size_t(s) * size_t(s), 1.f);
      outs.push_back(std::move(o));
    }
    std::vector<float> band(size_t(band_rows) * size_t(N) * size_t(Cin));
    std::vector<uint8_t> mask;
    for (int64_t b = 0; b < bands; ++b) {
      const int y0 = int(b * band_rows), rows = std::min(band_rows, N - y0);
      in.read_rows(y0, y0 + rows, band.data());
      if (islands) islands->mask_rows(y0, rows, mask);
      else mask.assign(size_t(rows) * size_t(N), 1);
      decode_band(m, decode_srgb, C, Cin, N, y0, rows, band, mask);
      for (Output& o : outs) filter_band(m.kind, C, Cin, N, y0, rows, band, mask, o);
      report(progress, int64_t(mi) * bands + b + 1, int64_t(maps.size()) * bands, "resizing " + m.name);
    }
    // 3. Toksvig, gutters, the images.
    if (m.kind == Kind::Normal) {
      for (Output& o : outs) normal_length[o.size] = o.length;
    }
    if (options.toksvig && m.name == "roughness" && !normal_length.empty()) {
      for (Output& o : outs) toksvig(o, C, normal_length[o.size]);
    }
    for (Output& o : outs) sink(m.name, o.size, finish_output(o, m, C, options));
  }
  return result;
}

MapResizeReport resize_maps(const std::string& in_dir, const Mesh* layout, const MapResizeOptions& options,
                            const std::string& out_dir, const ProgressCallback& progress) {
  options.check();
  if (layout && !layout->has_uv()) throw InvalidInput("layout", "the layout mesh has no UVs", "give a mesh with UVs (the template)");
  std::vector<int> sizes = options.sizes;
  const int N = check_map_set(find_maps(in_dir), sizes);  // bad maps or sizes stop before the raster
  std::optional<UvIslands> islands;
  if (layout) islands.emplace(*layout, N);
  AtomicDirectory out(out_dir);
  for (int s : options.sizes) make_directories(out.path() + "/" + std::to_string(s));
  const MapResizeReport result = bake_maps(in_dir, islands ? &*islands : nullptr, options, [&](const std::string& map, int size, Image img) {
    ImageWriteOptions w;
    if (options.format == "exr") {
      w.type = PixelType::Half;
      w.compression = "zip";
      w.tiled = true;
    } else {
      w.type = PixelType::UInt16;
      if (img.color_space == ColorSpace::Linear) img = to_srgb(img);
    }
    w.mipmap = options.mipmap && options.format != "png";
    write_image(out.path() + "/" + std::to_string(size) + "/" + map + "." + options.format, img, w);
  }, progress);
  out.commit();
  return result;
}

void BakeFilesOptions::check() const {
  if (input.empty() || output.empty()) throw InvalidInput("uvtools bake", "needs an input and an output folder", "see --help");
  resize.check();
}

MapResizeReport bake_files(const BakeFilesOptions& o, const ProgressCallback& progress) {
  check_output_apart(o.output, {o.input, o.layout});
  o.check();
  if (!std::filesystem::is_directory(o.input)) {
    throw IoError(o.input, "is not a folder", "give the folder holding diffuse, normal, roughness, specular maps");
  }
  std::optional<Mesh> layout;
  if (!o.layout.empty()) layout = read_mesh(o.layout);
  const auto t0 = std::chrono::steady_clock::now();
  const MapResizeReport r = resize_maps(o.input, layout ? &*layout : nullptr, o.resize, o.output, progress);
  // After the bake, so that a refused input gives one line only.
  if (!layout) spdlog::info("uvtools bake: no --layout: a plain area-correct resize per map type, without seam handling");
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  nlohmann::json j = {{"input", o.input},           {"input_size", r.input_size},
                      {"sizes", o.resize.sizes},    {"maps", r.maps},
                      {"layout", layout ? o.layout : "none: plain resize, no seam handling"},
                      {"island_fraction", r.island_fraction}, {"flipped_uv_triangles", r.flipped_triangles},
                      {"overlapping_texels", r.overlapping_texels}, {"seconds", seconds}};
  write_file_atomic(o.output + "/bake.json", j.dump(1) + "\n");
  if (r.flipped_triangles) {
    spdlog::warn("uvtools bake: {}: {} UV triangles are flipped against the others", o.layout, r.flipped_triangles);
  }
  if (r.overlapping_texels) {
    spdlog::warn("uvtools bake: {}: {} texels lie in two or more UV triangles (overlapping islands)", o.layout,
                 r.overlapping_texels);
  }
  std::string sizes;
  for (int size : o.resize.sizes) sizes += (sizes.empty() ? "" : ",") + std::to_string(size);
  spdlog::info("uvtools bake: {} map(s) {}² -> {} in {:.1f} s ({})", r.maps.size(), r.input_size, sizes, seconds,
               layout ? fmt::format("{:.1f}% of texels in UV islands", 100 * r.island_fraction) : "no layout");
  return r;
}

}  // namespace bareskin
