// `bareskin render` on files: pictures of a mesh, or of a morphable model at some coefficients. Without a camera the
// preview (render/preview.h: shaded, wireframe, landmarks from front/left/right, or the UV layout); with one the
// renderer proper (render/shade.h: a pinhole or weak-perspective camera, SH lighting, the passes colour, albedo, depth,
// normal and mask of one rasterization, the projected landmarks).
#pragma once
#include <string>
#include <vector>

#include "render/preview.h"

namespace bareskin {

struct RenderFilesOptions {
  std::string mesh;           // a mesh file, or
  std::string model, coeffs;  // a morphable model at these coefficients (with a camera: its appearance and light)
  std::string output;         // the picture; with several views or passes it takes {view} / {pass}
  std::string landmarks;      // "" or a landmark JSON with "vertex_ids" (drawn; with a camera: projected)
  std::string blendshapes;    // "" or blendshapes.safetensors to pose the mesh with ...
  std::vector<std::string> expression;  // ... at these NAME=WEIGHT pairs
  std::string texture;        // "" or a diffuse map in the mesh's UV
  std::string view = "front";  // front, left, right or uv (the UV layout; previews only)
  PreviewOptions preview;      // size, shading, wireframe (its view is `view`)
  // With a camera ("" = the preview):
  std::string camera;                          // pinhole or weak
  std::string sh = "default";                  // render/shade.h's read_sh_lighting
  bool sh_given = false;                       // `sh` was asked for: it wins over the coefficients' light
  std::vector<std::string> views;              // views to render (empty: `view`)
  std::vector<std::string> passes = {"colour"};
  bool cull = false;                           // drop back faces
  std::string landmarks_out;                   // "" or the 68 projected landmarks (JSON, px); may take {view}
  bool draw_landmarks = false;                 // on the colour and albedo passes
  void check() const;                          // InvalidInput naming the flag (and preview.check())
};

// Writes the picture(s). InvalidInput for a mesh and a model (or neither), several views or passes without {view} /
// {pass} in the output, landmark files of another count; nothing is written then.
void render_files(const RenderFilesOptions& options);

}  // namespace bareskin
