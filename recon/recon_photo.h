// Photo → 3DMM coefficients by a reconstruction network (the teacher F, or the student E, of a `bareskin train recon`
// run): the pipeline `bareskin recon` and `bareskin run` share. The caller's detector gives the 68 landmarks; the face
// is aligned (detect/align.h's 5-point similarity, at the net's size), the net answers the coefficients, and
// optionally mm-fit's fitters (morphable/fit.h) refine them from that answer. Joins the geometry side (mm-fit, the
// model file), so it is not built on the Torch-only GPU machine. docs/training.md, "Inference and confidence".
#pragma once
#include <torch/torch.h>

#include <string>
#include <vector>
#include <utility>

#include "core/image.h"
#include "detect/align.h"
#include "morphable/coefficients.h"
#include "morphable/model.h"
#include "recon/recon.h"

namespace bareskin::recon {

struct PhotoReconOptions {
  ConfidenceOptions confidence;
  bool refine = false;         // continue with mm-fit (landmarks, then appearance and light) from the net's answer
  int refine_iterations = 30;  // landmark-fit iterations of the refinement
  void check() const;          // InvalidInput naming the flag
};

struct PhotoReconstruction {
  // In the coefficient file's units, seen by the canonical camera of the aligned frame (the same pose at every
  // frame size). extra: the net, its confidence, flags, residuals, the forward time, and the refinement's figures.
  Coefficients coefficients;
  Reconstruction answer;          // the net's own answer (before any refinement)
  detect::Similarity similarity;  // photo → the aligned frame at the net's size (identity scale for aligned input)
  Image aligned;                  // the net's input: sRGB at the net's size
  detect::Landmarks68 landmarks;  // the detected landmarks in that frame
};

// A face already in detect/align.h's frame at any size (sRGB; resampled by area to the net's size) with its 68
// landmarks in that frame's pixels. InvalidInput when the image is not square RGB.
PhotoReconstruction reconstruct_aligned(const TrainedRecon& net, const MorphableModel& geometry, const Image& aligned,
                                        const detect::Landmarks68& landmarks, const PhotoReconOptions& options = {});

// A photo (sRGB) and its detected landmarks (photo pixels): aligned at the net's size, then as above.
PhotoReconstruction reconstruct_photo(const TrainedRecon& net, const MorphableModel& geometry, const Image& photo,
                                      const detect::Landmarks68& detected, const PhotoReconOptions& options = {});

// The lit render of `c` over the photo (sRGB, the photo's size; the aligned frame's camera mapped back through the
// similarity) and the 68 projected landmarks in photo pixels.
std::pair<Image, detect::Landmarks68> photo_overlay(const TrainedRecon& net, const Coefficients& c,
                                                    const detect::Similarity& similarity, const Image& photo);

struct PhotoFilesOptions {
  std::string input;   // a photo, or a folder of photos (.png, .jpg, .jpeg, .tif, .tiff)
  std::string output;  // the output folder (per photo a subfolder when the input is a folder)
  std::string run, model;  // the net's run and its morphable model file ("": the one the run was trained with)
  torch::Device device = torch::kCPU;
  PhotoReconOptions recon;
  bool keep_going = false;  // with a folder: report a photo that fails on stderr and go on (InvalidInput at the end)
  bool quiet = false;       // no line per photo on stderr
  void check() const;       // InvalidInput naming the flag
};

// `bareskin recon`: per photo face-api's 68 landmarks, reconstruct_photo, and coefficients.json, mesh.obj,
// overlay.png, aligned.png, landmarks.json, written only once all are computed (a failure leaves no output).
void reconstruct_photo_files(const PhotoFilesOptions& options);

// A coefficient row of the net's layout (with γ) ↔ the coefficient file's struct.
Coefficients to_coefficients(const torch::Tensor& row, const CoefficientLayout& layout);
torch::Tensor coefficients_row(const Coefficients& c, const CoefficientLayout& layout);

}  // namespace bareskin::recon
