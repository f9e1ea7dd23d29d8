// Face detection and iBUG-68 landmarks with the two small networks that ship in npm @vladmandic/face-api (MIT),
// rebuilt in LibTorch from their TensorFlow.js weights:
// - TinyFaceDetector: a Tiny-YOLOv2 with depthwise-separable convolutions, 5 anchors, one class, 32× downsampling;
// - FaceLandmark68Net: four dense blocks of separable convolutions on a 112² crop, then a 136-way linear layer.
// Pre- and post-processing follow face-api so that outputs match its JavaScript (tests/node/face_api_reference.mjs):
// TensorFlow's "same" padding (the extra row/column after, at stride 2), the legacy bilinear resize
// (source = destination · in/out, no half-pixel offset), black padding to a square, mean-RGB subtraction and /255.
// One change: landmarks are shifted by the crop's integer origin, which is where the network looked (face-api shifts
// them by the unrounded box, up to a pixel off).
// Coordinates are image pixels with the origin at the top-left corner of the top-left pixel (its centre is at 0.5).
#pragma once
#include <torch/types.h>

#include <Eigen/Core>
#include <string>

#include "core/image.h"
#include "detect/image_landmark_options.h"
#include <vector>

namespace bareskin::detect {

struct Box {
  double x = 0, y = 0, width = 0, height = 0;  // pixels
};

struct Face {
  double score = 0;  // the detector's confidence in [0, 1]
  Box box;           // the detector's box
  Eigen::Matrix<double, 68, 2> points = Eigen::Matrix<double, 68, 2>::Zero();  // iBUG-68, pixels
};

struct DetectOptions {
  int input_size = kDetectorInputSize;  // detector input (multiple of 32); smaller is faster and finds only larger faces
  double min_score = 0.5;       // detections below are dropped
  double iou_threshold = 0.4;   // non-maximum suppression
  int max_faces = 0;            // 0: all
  void check() const;           // InvalidInput naming the flag
};

class FaceApi {
 public:
  // Reads both networks from `folder` (face_landmark_68_model-weights_manifest.json,
  // tiny_face_detector_model-weights_manifest.json and their .bin); InvalidInput/IoError naming the file, including
  // tensors missing or of the wrong shape.
  explicit FaceApi(const std::string& folder);

  // Moves the weights (CPU by default); inputs are moved to the same device.
  void to(const torch::Device& device);
  torch::Device device() const { return device_; }

  // image: [H, W, 3] RGB float in [0, 1] as read from the file (sRGB-encoded, as the networks were trained), on
  // the CPU. Faces by decreasing score.
  std::vector<Face> detect(const torch::Tensor& image, const DetectOptions& options = {}) const;

  // Landmarks for given boxes (e.g. from another detector): the crops are batched through the landmark network.
  std::vector<Eigen::Matrix<double, 68, 2>> landmarks(const torch::Tensor& image, const std::vector<Box>& boxes) const;

  // The raw networks, for tests and benchmarks. detector_net: [N, 3, S, S] normalised input → [N, 25, S/32, S/32];
  // landmark_net: [N, 3, 112, 112] normalised → [N, 136] (x, y interleaved, relative to the padded square crop).
  torch::Tensor detector_net(const torch::Tensor& x) const;
  torch::Tensor landmark_net(const torch::Tensor& x) const;

  // Preprocessing as face-api: black padding to a square (at the end, or centred), legacy bilinear resize to size²,
  // ·255, minus `mean`, /255 → [1, 3, size, size]. The padded square is never built (8K photos stay cheap).
  static torch::Tensor prepare(const torch::Tensor& image, int size, bool centre, const double mean[3]);

 private:
  struct SeparableConv {
    torch::Tensor depthwise, pointwise, bias;
  };
  struct Conv {
    torch::Tensor filters, bias;
  };
  Conv detector_conv0_, detector_conv8_;
  std::vector<SeparableConv> detector_layers_;  // conv1..conv5
  Conv landmark_conv0_;
  std::vector<SeparableConv> landmark_layers_;  // dense0 conv1..3, dense1..3 conv0..3 (15)
  torch::Tensor fc_weight_, fc_bias_;
  torch::Device device_ = torch::kCPU;
};

// A photo as the networks take it: [H, W, 3] sRGB-encoded floats in [0, 1], sharing no memory with `image`. Grey
// is repeated, alpha dropped, linear images (EXR) encoded to sRGB. InvalidInput naming `source` for images smaller
// than 64 px or with another channel count.
torch::Tensor photo_tensor(const Image& image, const std::string& source);

// The default weights folder: face_api/ in the assets folder core/assets.h finds (IoError listing the places searched).
std::string default_face_api_folder();

}  // namespace bareskin::detect
