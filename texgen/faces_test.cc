// texgen faces against independent truth: the json's coefficients rendered by the model through render_frame (the
// preview renderer, not the generator's shading code) reproduce bare.png, and the json landmarks are the landmark
// vertices projected by the canonical camera; splits are disjoint by subject (the held-out style family reaches only
// test); the same seed gives the same bytes however the shards are spread over workers or resumed.
#include "texgen/faces.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>

#include "core/error.h"
#include "core/files.h"
#include "core/png.h"
#include "core/test_util.h"
#include "morphable/coefficients.h"
#include "render/camera.h"
#include "render/shade.h"
#include "template/template_face.h"

namespace bareskin::texgen {
namespace {
namespace fs = std::filesystem;

// Orthonormal rows (Gram-Schmidt) of smooth fields.
void orthonormalise(RowMatrixXf& rows) {
  for (int k = 0; k < rows.rows(); ++k) {
    for (int j = 0; j < k; ++j) rows.row(k) -= rows.row(k).dot(rows.row(j)) * rows.row(j);
    rows.row(k).normalize();
  }
}

// A small morphable model on the test template: 2 identity, 2 expression and 2 appearance components, 64² albedo.
const std::string& tiny_model() {
  static const std::string path = [] {
    const TemplateFace t = read_template(BARESKIN_TEMPLATE_DIR + "/face.obj", BARESKIN_TEMPLATE_DIR + "/landmarks.json");
    MorphableModel m;
    m.topology = t.mesh;
    m.landmark_vertices = t.landmark_vertices;
    const int V = int(t.mesh.V.rows()), R = 64;
    m.vertex_region.assign(size_t(V), 0);
    m.region_names = {"face"};
    m.shape_basis.resize(2, 3 * V);
    m.expression_basis.resize(2, 3 * V);
    for (int v = 0; v < V; ++v) {
      const Eigen::Vector3d p = t.mesh.V.row(v);
      m.shape_basis.block<2, 3>(0, 3 * v) << float(p.x()), 0, 0, 0, 0, float(std::max(0.0, p.z()));
      m.expression_basis.block<2, 3>(0, 3 * v) << 0, float(std::min(0.0, p.y() + 40)), 0, float(p.x() * 0.1), 0, 0;
    }
    orthonormalise(m.shape_basis);
    orthonormalise(m.expression_basis);
    m.shape_stddev = Eigen::Vector2f(4, 3);
    m.expression_stddev = Eigen::Vector2f(5, 2);
    m.appearance_resolution = R;
    m.appearance_mean.resize(R * R * 3);
    m.appearance_basis.resize(2, R * R * 3);
    for (int y = 0; y < R; ++y)
      for (int x = 0; x < R; ++x) {
        const int i = 3 * (y * R + x);
        const float g = float(x) / R;
        m.appearance_mean.segment<3>(i) << 0.45f + 0.1f * g, 0.3f, 0.25f - 0.05f * g;
        m.appearance_basis.block<2, 3>(0, i) << 1, 0.8f, 0.7f, g - 0.5f, 0.2f, -0.3f;
      }
    orthonormalise(m.appearance_basis);
    m.appearance_stddev = Eigen::Vector2f(3, 2);
    m.appearance_mask.assign(size_t(R) * R, 1);
    m.subjects = {"nobody"};
    m.procrustes = {Eigen::Matrix4d::Identity()};
    const std::string dir = testing::temp_dir();
    write_model(dir + "/model.safetensors", m);
    return dir + "/model.safetensors";
  }();
  return path;
}

FacesOptions tiny_options(const std::string& out) {
  FacesOptions o;
  o.model = tiny_model();
  o.output = out;
  o.count = 12;
  o.seed = 7;
  o.mm_subjects = 10;
  o.val = 2;
  o.test = 0.2;
  o.shard_size = 4;
  o.align = "truth";
  o.map_size = 64;
  o.layer_size = 32;
  o.backgrounds = "";
  o.occluder_prob = 0.5;
  return o;
}

Image decode(const shards::Sample& s, const std::string& member) {
  return decode_png(s.members.at(member), member);
}

// Decoding bare.png back to linear light and rendering the json's coefficients with the model must agree.
TEST(Faces, JsonCoefficientsRenderedByTheModelReproduceBarePng) {
  const FaceGenerator gen(tiny_options(testing::temp_dir()));
  const MorphableModel model = read_model(tiny_model());
  for (int64_t index : {0, 3, 5}) {
    const shards::Sample s = gen.render(index, {});
    const nlohmann::json j = nlohmann::json::parse(s.members.at("json"));
    ASSERT_EQ(j.at("subject").get<std::string>().substr(0, 3), "mm/");
    const std::string coeffs = testing::temp_dir() + "/c.json";
    write_file_atomic(coeffs, j.at("coefficients").dump());
    const Coefficients c = read_coefficients(coeffs);
    const Mesh mesh = posed_mesh(model, c);
    const Camera cam = view_camera("front", 256, Eigen::Vector3d::Zero(), 1000);
    EXPECT_DOUBLE_EQ(j["camera"]["focal"].get<double>(), cam.focal);
    const Image texture = appearance_image(model, c);
    ShadeOptions so;
    so.texture = &texture;
    so.cull_back_faces = true;
    const Frame frame = render_frame(mesh, cam, so);
    const Image bare = decode(s, "bare.png"), face = decode(s, "face.png");
    int64_t both = 0, disagree = 0;
    double error = 0;
    for (int i = 0; i < 256 * 256; ++i) {
      const bool ours = bare.pixels[3 * size_t(i)] + bare.pixels[3 * size_t(i) + 1] > 0, theirs = frame.mask.pixels[size_t(i)] > 0;
      disagree += ours != theirs;
      if (face.pixels[size_t(i)] > 0) EXPECT_TRUE(theirs) << "face.png outside the face at pixel " << i;
      if (!(ours && theirs)) continue;
      ++both;
      for (int k = 0; k < 3; ++k)
        error += std::abs(srgb_to_linear(bare.pixels[3 * size_t(i) + size_t(k)]) - frame.albedo.pixels[3 * size_t(i) + size_t(k)]);
    }
    ASSERT_GT(both, 10000) << "the face covers a good part of the 256² frame";
    EXPECT_LT(double(disagree) / double(both), 0.002) << index;
    EXPECT_LT(error / (3.0 * double(both)), 0.002) << index;  // 8-bit sRGB quantisation is below this
    // Landmarks: the landmark vertices of the posed model through the canonical camera.
    for (int k = 0; k < 68; ++k) {
      const Eigen::Vector3d p = cam.project(mesh.V.row(model.landmark_vertices[size_t(k)]).transpose());
      EXPECT_NEAR(j["landmarks"][size_t(k)][0].get<double>(), p.x(), 1e-6);
      EXPECT_NEAR(j["landmarks"][size_t(k)][1].get<double>(), p.y(), 1e-6);
    }
    // The aligned render sits on the standard face: the 5-point alignment of its own landmarks is nearly identity.
    detect::Landmarks68 lm;
    for (int k = 0; k < 68; ++k) lm.row(k) << j["landmarks"][size_t(k)][0].get<double>(), j["landmarks"][size_t(k)][1].get<double>();
    const detect::Similarity again = detect::alignment(lm);
    EXPECT_NEAR(again.scale, 1.0, 0.05) << index;
    EXPECT_LT((again.apply({128, 128}) - Eigen::Vector2d(128, 128)).norm(), 6.0) << index;
  }
}

TEST(Faces, SplitsAreDisjointBySubjectAndCountsFollowTheFlags) {
  FacesOptions o = tiny_options("");
  o.count = 100;
  const FacesPlan p = plan_faces(o, {"scan/a", "scan/b", "scan/c"});
  ASSERT_EQ(p.subjects.size(), 13u);
  int per_split[3] = {0, 0, 0};
  for (int s : p.subject_split) ++per_split[s];
  EXPECT_EQ(per_split[1], 2);                        // --val 2: a count
  EXPECT_EQ(per_split[2], 3);                        // --test 0.2: a fraction of 13, rounded
  std::map<int, int> split_of;
  int64_t total = 0;
  for (int split = 0; split < 3; ++split) {
    total += int64_t(p.split_samples[size_t(split)].size());
    for (int64_t i : p.split_samples[size_t(split)]) {
      const int subject = p.sample_subject[size_t(i)];
      EXPECT_EQ(p.subject_split[size_t(subject)], split);
      const auto [it, fresh] = split_of.emplace(subject, split);
      EXPECT_EQ(it->second, split) << "subject " << subject << " in two splits";
    }
  }
  EXPECT_EQ(total, 100);
  o.val = 5;
  o.test = 8;
  EXPECT_THROW(plan_faces(o, {"scan/a"}), InvalidInput);  // nothing left to train on
}

std::string bytes_of(const fs::path& p) { return read_file(p.string()); }

// One run, the same run spread over two workers, and a resumed run give the same bytes; the excluded family is drawn
// only for test subjects.
TEST(Faces, SameSeedSameBytesAcrossWorkersAndResumeAndExcludedStylesOnlyInTest) {
  const std::string a = testing::temp_dir() + "/a", b = testing::temp_dir() + "/b";
  FacesOptions o = tiny_options(a);
  o.exclude_styles = "dramatic,heavy";
  FaceGenerator(o).run({}, {});
  FacesOptions o2 = tiny_options(b);
  o2.exclude_styles = o.exclude_styles;
  o2.shards = 2;
  for (int worker : {1, 0}) {
    o2.shard = worker;
    const FacesReport r = FaceGenerator(o2).run({}, {});
    // A split's manifest is written by whichever worker finds all its shards there: worker 0 runs last here.
    if (worker == 0) EXPECT_EQ(r.complete_splits.size(), 3u);
    else EXPECT_LT(r.complete_splits.size(), 3u);
  }
  // Resume: remove one shard, rerun: only it is written again.
  fs::remove(fs::path(b) / "train" / "faces-000001.tar");
  o2.shards = 1;
  o2.shard = 0;
  const FacesReport resumed = FaceGenerator(o2).run({}, {});
  EXPECT_EQ(resumed.shards_written, 1);
  int shards = 0;
  std::set<std::string> styles[3];
  for (int split = 0; split < 3; ++split) {
    const fs::path da = fs::path(a) / kSplitNames[split], db = fs::path(b) / kSplitNames[split];
    EXPECT_EQ(bytes_of(da / "manifest.json"), bytes_of(db / "manifest.json"));
    for (const auto& e : fs::directory_iterator(da)) {
      if (e.path().extension() != ".tar") continue;
      ++shards;
      EXPECT_EQ(bytes_of(e.path()), bytes_of(db / e.path().filename())) << e.path();
      shards::ShardReader reader(e.path().string());
      shards::Sample s;
      while (reader.next(s)) {
        const auto j = nlohmann::json::parse(s.members.at("json"));
        EXPECT_EQ(j["split"].get<std::string>(), kSplitNames[split]);
        styles[split].insert(j["style"].get<std::string>());
        for (const char* m : {"makeup.png", "before.png", "bare.png", "skin.png", "face.png", "layer.png", "finish.png"})
          EXPECT_TRUE(s.members.count(m)) << m;
      }
    }
  }
  EXPECT_GE(shards, 3);
  for (int split : {0, 1})
    for (const char* held_out : {"dramatic", "heavy"}) EXPECT_FALSE(styles[split].count(held_out)) << held_out;
}

TEST(Faces, BadInputIsRefusedBeforeAnyOutput) {
  FacesOptions o = tiny_options(testing::temp_dir() + "/x");
  o.count = 0;
  EXPECT_THROW(FaceGenerator{o}, InvalidInput);
  o = tiny_options(testing::temp_dir() + "/x");
  o.styles = "gothic";
  EXPECT_THROW(FaceGenerator{o}, InvalidInput);
  o = tiny_options(testing::temp_dir() + "/x");
  const std::string empty = testing::temp_dir() + "/registered";
  fs::create_directories(empty + "/subject_0000");
  testing::write_text(empty + "/subject_0000/mesh.ply", "ply\n");
  o.registered = empty;
  EXPECT_THROW(FaceGenerator{o}, InvalidInput);  // no maps there
  EXPECT_FALSE(fs::exists(o.output));
}

// ITA° of a linear RGB colour, written out here (sRGB primaries, D65) as the skin-tone bench computes it.
double ita_of(const Eigen::Vector3d& rgb) {
  const Eigen::Vector3d xyz = (Eigen::Matrix3d() << 0.4124, 0.3576, 0.1805, 0.2126, 0.7152, 0.0722, 0.0193, 0.1192,
                               0.9505).finished() * rgb;
  const auto f = [](double t) { return t > 0.008856 ? std::cbrt(t) : 7.787 * t + 16.0 / 116; };
  const double fy = f(xyz.y()), fz = f(xyz.z() / 1.089);
  return std::atan2(116 * fy - 16 - 50, 200 * (fy - fz)) * 180 / M_PI;
}

// --skin-tones balanced: subject i's mean albedo (the model's appearance at its δ, unclamped) lies in ITA group i mod
// 6, very light (> 55°) to dark (< −30°); a model whose appearance reaches no dark skin is refused in one line.
TEST(Faces, BalancedSkinTonesGiveEachSubjectItsGroup) {
  MorphableModel wide = read_model(tiny_model());
  wide.appearance_stddev = Eigen::Vector2f(19, 6);  // about ±0.4 in red at ±2σ: dark to very light skin
  const RegisteredSubjects none;
  // The ITA group of a subject's mean albedo, by an ITA of our own (ita_of) and the groups' floors.
  const auto group_of = [&wide](const FaceSubject& s) {
    const std::vector<float> a = wide.appearance(s.delta);
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (size_t t = 0; t < a.size(); t += 3) mean += Eigen::Vector3d(a[t], a[t + 1], a[t + 2]);
    const double ita = ita_of(mean / double(a.size() / 3)), floors[5] = {55, 41, 28, 10, -30};
    int group = 0;
    while (group < 5 && ita < floors[group]) ++group;
    return group;
  };
  for (int i = 0; i < 12; ++i)
    EXPECT_EQ(group_of(model_subject(wide, none, 3, i, SkinTones::Balanced)), i % 6) << "subject " << i;
  EXPECT_EQ(model_subject(wide, none, 3, 5).delta.size(), 2);  // the model's draw is still there
  // --skin-tones mixed: the even subjects are the model's draws, subject 2k + 1 lies in group k mod 6.
  for (int i = 0; i < 24; ++i) {
    const FaceSubject mixed = model_subject(wide, none, 3, i, SkinTones::Mixed);
    if (i % 2 == 0)
      EXPECT_EQ(mixed.delta, model_subject(wide, none, 3, i).delta) << "subject " << i;
    else
      EXPECT_EQ(group_of(mixed), (i / 2) % 6) << "subject " << i;
  }
  const MorphableModel narrow = read_model(tiny_model());
  try {
    model_subject(narrow, none, 3, 5, SkinTones::Balanced);
    ADD_FAILURE() << "a model without dark skin was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("reaches no dark skin"), std::string::npos) << e.what();
  }
  FacesOptions o = tiny_options(testing::temp_dir() + "/tones");
  o.skin_tones = "even";
  EXPECT_THROW(FaceGenerator{o}, InvalidInput);
  EXPECT_FALSE(fs::exists(o.output));
}

// Every 3DMM subject's albedo is skin, whatever the tones: within [0, 1] on all but 2% of the model's texels, on a
// model whose ±2σ tails leave that range (clamped, such a face would be painted in one colour).
TEST(Faces, SubjectsAlbedoStaysWithinTheRangeOfSkin) {
  MorphableModel wide = read_model(tiny_model());
  wide.appearance_stddev = Eigen::Vector2f(19, 6);
  const auto out_of_range = [&wide](const Eigen::VectorXd& delta) {
    const std::vector<float> a = wide.appearance(delta);
    int texels = 0, out = 0;
    for (size_t t = 0; t < a.size() / 3; ++t) {
      if (!wide.appearance_mask.empty() && !wide.appearance_mask[t]) continue;
      ++texels;
      bool outside = false;
      for (int c = 0; c < 3; ++c) outside |= a[3 * t + c] < 0 || a[3 * t + c] > 1;
      out += outside;
    }
    return double(out) / texels;
  };
  EXPECT_GT(std::max(out_of_range(Eigen::Vector2d(2, 0)), out_of_range(Eigen::Vector2d(-2, 0))), 0.5);
  const RegisteredSubjects none;
  for (const SkinTones tones : {SkinTones::Model, SkinTones::Balanced, SkinTones::Mixed})
    for (int i = 0; i < 24; ++i)
      EXPECT_LE(out_of_range(model_subject(wide, none, 3, i, tones).delta), 0.02) << "subject " << i;
  // A model none of whose draws is skin (its mean albedo past white) is refused in one line that names it.
  MorphableModel white = read_model(tiny_model());
  white.appearance_mean.array() += 2.0f;
  try {
    model_subject(white, none, 3, 0);
    ADD_FAILURE() << "a model whose albedo is never within [0, 1] was accepted";
  } catch (const InvalidInput& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("--model"), std::string::npos) << what;
    EXPECT_NE(what.find("reaches no skin whose albedo stays within [0, 1]"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace bareskin::texgen
