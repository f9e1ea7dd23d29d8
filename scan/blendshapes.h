// An expression blendshape set on the template, standing in for the paper's 236 artist-made blendshapes: ARKit-style
// names (jawOpen, mouthSmile_L, eyeBlink_L, browInnerUp, ...), each a smooth, region-weighted displacement anchored
// at iBUG-68 landmarks. "_L" is the subject's left (+x in our axes). mm-build turns them into the expression basis.
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

#include "template/template_face.h"

namespace bareskin {

struct Blendshape {
  std::string name;
  Eigen::MatrixX3d delta;  // #V by 3 (mm) at full activation
};

// The set for a template with the 68 iBUG landmark vertices (InvalidInput otherwise).
std::vector<Blendshape> make_blendshapes(const TemplateFace& face);

// dir/blendshapes.safetensors: "deltas" F32 [K, #V, 3]; metadata "names" (JSON list), units, format.
void write_blendshapes(const std::string& dir, const std::vector<Blendshape>& shapes);
// Reads such a file (a user's own set works too). InvalidInput naming the file when it is not one.
std::vector<Blendshape> read_blendshapes(const std::string& path);

}  // namespace bareskin
