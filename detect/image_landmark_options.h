// The settings of face-api's landmarks in a photo or a render (detect/scan_landmarks.h's find_image_landmarks), in a
// header without Torch, so that geometry-side commands (`texgen make-dataset`) bind their flags to the one set of
// defaults.
#pragma once

namespace bareskin::detect {

// face-api's detector input (pixels, a multiple of 32) unless a flag says otherwise: every default of it is this one.
inline constexpr int kDetectorInputSize = 416;

// Landmarks in a photo or a render, as `texgen make-dataset` finds them (no truth used): face-api's detector box
// (scores above 0.3) at input_size², then `refinements` landmark passes on the box the previous points imply, and with
// `flip` the average with the mirrored image's landmarks. With `coverage_fallback` (renders: a face on black) a
// rejected or misplaced detection (IoU with the non-black pixels' box < 0.3) is replaced by that box, and points that
// collapse onto a small part of the face are found again from it.
struct ImageLandmarkOptions {
  int input_size = kDetectorInputSize;
  int refinements = 2;
  bool flip = true;
  bool coverage_fallback = false;
  void check() const;  // InvalidInput naming the option (defined on the Torch side, detect/scan_landmarks.cc)
};

}  // namespace bareskin::detect
