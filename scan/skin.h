// Procedural skin appearance for synthetic scans (docs/pipeline.md): diffuse albedo, meso-scale relief (for normal maps),
// roughness and specular, defined as closed-form fields on the *template* surface. A scan's texel is evaluated at the
// template point it corresponds to, so the true value at any surface point of any scan — and in the template UV after
// a perfect registration — is known exactly.
//
// Diffuse is a two-chromophore model in the spirit of Jimenez et al. 2010 / Donner & Jensen 2006: albedo =
// R0 * exp(-(melanin * K_m + haemoglobin * K_h)) per linear RGB channel, with K_m and K_h fitted so that melanin 0.02..0.6
// spans very light to very dark skin. Spatial structure: low-frequency mottling, freckles, blemishes, cheek and nose
// blush, lips (more blood, less melanin), eyebrow hair, darker pores. Relief, given by its gradient (the normal map's
// truth): pores (Gaussian dimples, deeper on nose and cheeks, none on lips), forehead wrinkles, micro-relief, each an
// analytic field whose gradient is exact, scaled by slowly varying regional amplitudes (held constant across a pore,
// as bump modulation is). Roughness and specular are regional (T-zone oily, lips glossy, brows matte). Every component
// is low-passed to the texel footprint, so maps of any resolution are the same field seen through a smaller or larger
// filter.
#pragma once
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "template/template_face.h"

namespace bareskin {

struct Appearance {
  uint64_t seed = 0;
  double melanin = 0.1;      // epidermal melanin fraction: 0.02 very light .. 0.6 very dark
  double haemoglobin = 0.05; // dermal blood fraction
  double freckles = 0;       // freckle density 0..1
  double blush = 0.5;        // extra blood on cheeks and nose, relative
  double lip_redness = 1;    // extra blood in the lips, relative
  double oiliness = 0.5;     // T-zone: lower roughness, higher specular
  double pore_scale = 1;     // pore size and spacing multiplier
  double wrinkles = 0.3;     // forehead wrinkle depth 0..1 (age)
  double detail = 0;         // skin micro-detail 0..1: pigment speckle, ephelides, moles, darker pores (0: off)
  Eigen::Vector3d hair = {0.05, 0.03, 0.02};  // eyebrow colour, linear RGB
  Eigen::Vector3d iris = {0.06, 0.03, 0.015};  // linear RGB
  std::map<std::string, double> to_map() const;  // for truth/identity.json
};

// Light to dark skin across a population (melanin log-uniform), freckles mostly on light skin, brows from the tone.
Appearance sample_appearance(uint64_t seed);

struct SkinMaterial {
  Eigen::Vector3f diffuse;  // linear RGB albedo
  float roughness;          // perceptual GGX roughness, 0..1
  float specular;           // specular intensity (linear scale of the specular lobe; skin about 0.2-0.6)
};

struct SkinSample {
  SkinMaterial material;
  Eigen::Vector3f relief_gradient;  // gradient of the relief height (mm/mm) in template space; tilts the normal
};

class SkinModel {
 public:
  SkinModel(const TemplateFace& face, const Appearance& appearance);

  // The skin at the template point p (mm) with template UV `uv`, low-passed to `footprint` (mm per texel).
  SkinSample sample(const Eigen::Vector3f& p, const Eigen::Vector2f& uv, float footprint) const;

  // Region masks in [0,1] (exposed for tests and reports).
  float lips(const Eigen::Vector2f& uv) const;
  float brows(const Eigen::Vector3f& p) const;
  // Open eyes inside the lid contours (iBUG 36-41, 42-47): coverage in [0,1]; `colour` gets sclera, iris, pupil and
  // the lash line (linear RGB) where it is > 0.
  float eyes(const Eigen::Vector2f& uv, const Eigen::Vector3f& p, Eigen::Vector3f* colour) const;
  float t_zone(const Eigen::Vector3f& p) const;
  float cheeks(const Eigen::Vector3f& p) const;

  const Appearance& appearance() const { return appearance_; }

 private:
  struct Pores {
    float value;               // dimple coverage, about 0..1
    Eigen::Vector3f gradient;  // of the coverage
  };
  Pores pores(const Eigen::Vector3f& p, float footprint) const;
  float forehead(const Eigen::Vector3f& p) const;
  float nose(const Eigen::Vector3f& p) const;

  Appearance appearance_;
  uint32_t seed_;
  std::array<Eigen::Vector3f, 68> landmarks_;
  std::vector<Eigen::Vector2f> lip_polygon_;  // outer lip contour in template UV
  std::vector<Eigen::Vector2f> eye_polygon_[2];  // lid contours in template UV
  Eigen::Vector3f eye_centre_[2];
  float uv_to_mm_;                            // template UV units to mm (mean scale)
  float brow_top_y_, face_mid_x_;
  Eigen::Vector3f cheek_[2];
};

}  // namespace bareskin
