// Synthetic identities: smooth, plausible deformations of the template face, so that `scan synth` can make a population
// whose shapes are not trivially linear in a small basis (docs/pipeline.md).
//
// A displacement field on the template is the sum of
//  - a Gaussian-process sample with a multi-scale squared-exponential kernel (as in Gaussian process morphable models,
//    Lüthi et al. 2017), drawn with random Fourier features, mostly bilaterally symmetric like real faces, and mostly
//    along the (smoothed) surface normal (as is the sum below); and
//  - semantic feature controls (nose length/width, jaw width, cheekbones, eye spacing, lip thickness, brow ridge),
//    each a smooth bump around landmark anchors with a random signed strength.
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "template/template_face.h"

namespace bareskin {

struct IdentityOptions {
  // GP scales: length (mm) and standard deviation (mm) of each squared-exponential component.
  std::vector<double> gp_lengths = {60.0, 25.0, 10.0};
  std::vector<double> gp_sigmas = {3.0, 1.2, 0.2};
  int fourier_features = 256;   // per scale; the sample converges to the GP as this grows
  double symmetry = 0.85;       // share of the field that is mirror-symmetric in x (real faces: mostly symmetric)
  // Share of the displacement's component along the surface that is kept. Faces differ across their surface; a tangential
  // shift of a smooth field is invisible in the geometry, so it would make correspondence truth arbitrary.
  double tangential = 0.2;
  double feature_scale = 1.0;   // multiplies every semantic control's strength
  void check() const;           // InvalidInput when inconsistent
};

struct Identity {
  uint64_t seed = 0;
  Eigen::MatrixX3d displacement;           // #V by 3 (mm), added to the template's vertices
  std::map<std::string, double> features;  // semantic control strengths, in standard deviations
};

// The semantic controls and their anchors, for documentation and reports.
std::vector<std::string> identity_feature_names();

// Deterministic in (template, seed, options). Throws InvalidInput when the template lacks the 68 landmarks.
Identity sample_identity(const TemplateFace& face, uint64_t seed, const IdentityOptions& options = {});

}  // namespace bareskin
