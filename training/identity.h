// Identity loss: 1 − cosine similarity of face recognition descriptors (face-api's 128-d net, detect/
// face_recognition.h), as Deep3DFaceRecon's perceptual term with ArcFace (weight 0.2 there). Cropping the face and
// masking what should not count is the caller's job; the net resizes each crop to 150² itself.
#pragma once
#include <torch/types.h>

#include "detect/face_recognition.h"

namespace bareskin::losses {

// a, b: [B, 3, H, W] RGB face crops in [0, 1] → [B] values 1 − cos(e(a), e(b)) in [0, 2]. Gradients reach both
// inputs (detach the reference yourself).
torch::Tensor identity_distance(detect::FaceRecognitionNet& net, const torch::Tensor& a, const torch::Tensor& b);

// The batch mean of identity_distance: the loss.
torch::Tensor identity_loss(detect::FaceRecognitionNet& net, const torch::Tensor& a, const torch::Tensor& b);

}  // namespace bareskin::losses
