// Preview pictures of a mesh for reports and QA: an orthographic, z-buffered, shaded view with wireframe and
// landmarks, or the UV layout. Plain CPU code with no framework; the differentiable renderer is separate.
#pragma once
#include <string>
#include <vector>

#include "core/image.h"
#include "core/mesh.h"

namespace bareskin {

enum class PreviewView { Front, Left, Right, UV };
PreviewView parse_preview_view(const std::string& name);  // "front", "left", "right", "uv"; InvalidInput otherwise

struct PreviewOptions {
  PreviewView view = PreviewView::Front;
  int size = 1024;            // output is size x size pixels
  bool shaded = true;         // grey Lambert shading (3D views)
  bool wireframe = true;      // triangle edges
  double wire_opacity = 0.35;
  std::vector<int> landmark_vertices;  // drawn as red dots with their iBUG index order
  const Image* texture = nullptr;      // diffuse albedo in the mesh's UV (needs UVs): shaded colour instead of grey
  Eigen::MatrixX3f vertex_colors;      // or per-vertex sRGB colours (e.g. an error heat map), #V by 3
  void check() const;                  // InvalidInput naming the option
};

// A perceptual blue-to-red heat colour (sRGB) for t in [0, 1] (clamped).
Eigen::Vector3f heat_color(double t);

// Overlays on an sRGB image, in pixel coordinates with the top-left pixel's centre at (0.5, 0.5): iBUG-68 points
// (dots joined along jaw, brows, nose, eyes and lips; other counts as dots only) and a rectangle outline.
void draw_landmarks(Image& image, const Eigen::MatrixXd& points, const Eigen::Vector3f& colour, int radius = 2);
void draw_box(Image& image, double x, double y, double width, double height, const Eigen::Vector3f& colour);

// Returns an sRGB image. Left/right views look at the face's left/right side (a camera on the +x / -x axis).
Image render_preview(const Mesh& mesh, const PreviewOptions& options);

}  // namespace bareskin
