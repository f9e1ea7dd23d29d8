// `texgen make-dataset`: the texture-inference training data (paper §5) from a folder of registered subjects and the
// morphable model, as shards (core/shards.h). Per subject and light, one sample (texture_sample.h) whose inputs are
// the views' merged unwrap, its confidence and the fitted 3DMM's appearance, normal and position maps, and whose
// targets are the subject's four maps baked (uvtools/bake.h) at the target and high resolutions; occlusion masks
// (occlusion_masks.h) go to their own shard set.
//
// Layout of the output folder:
//   {train,val,test}/texture-NNNNNN.tar + manifest.json   subjects split by identity (seeded)
//   masks/mask-NNNNNN.tar + manifest.json                 synthetic and CelebAMask-HQ UV masks
//   reports/<subject>.json                                per-subject fit errors, coverage and timings (not in shards)
//   .index/unit-NNNNNN.json                               what each finished work unit wrote (resume, manifests)
// Work is cut into units (a few subjects of one split, or a batch of CelebAMask photos), each written to a temporary
// folder and renamed into place when complete: a killed run leaves no partial shard and resumes at the first unfinished
// unit. With --shards n, worker i does the units u with u mod n = i (e.g. SLURM_ARRAY_TASK_ID); every worker rewrites
// the manifests from the finished units, and the last one to finish leaves them complete. The same options and seed
// give the same bytes (with the same thread count).
#pragma once
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/progress.h"
#include "texgen/texture_sample.h"
#include "uvtools/mask.h"

namespace bareskin::texgen {

struct TextureDatasetOptions {
  std::string registered, model, output;
  TextureSampleOptions sample;
  int lights = 1;                   // light 0: the default light; others: random SH lights (the photo that is fitted)
  std::string fitter = "mm-fit";    // "recon" (the teacher network F) once it exists
  // The detector's landmark convention (`landmarks calibrate`: reference points and per-landmark offsets to the truth,
  // in its reference frame), brought into the model frame (landmark_offsets, multiview_fit.h) for the landmark fits.
  struct LandmarkCalibration {
    std::string source;  // the file, for the manifests
    Eigen::Matrix<double, 68, 3> reference, offset;
  };
  std::optional<LandmarkCalibration> landmark_calibration;
  // After a complete run: the detector's per-view bias learned from this folder's reports (fitting/view_calibration.h),
  // written to this file for later runs' sample.view_calibration; empty: not written.
  std::string write_view_calibration;
  int target_res = 1024, hr_res = 4096;  // targets; hr 0 = none; each must divide the registered maps' size
  int masks_per_subject = 3;        // synthetic occluder masks per subject (views taken in turn)
  std::vector<Occluder> occluders = {Occluder::Hair, Occluder::Glasses, Occluder::Hand, Occluder::Hat};
  std::string celebamask;           // CelebAMask-HQ folder (optional)
  int celebamask_count = 500;       // photos used (the paper's 500), the lowest ids first
  int celebamask_per_shard = 100;
  std::array<double, 3> split = {0.8, 0.1, 0.1};  // train, val, test fractions of the subjects
  int subjects_per_shard = 1;
  int shard = 0, shards = 1;        // this worker and the worker count
  uint64_t seed = 1;
  bool keep_going = false;          // skip (and list) subjects or photos with bad input instead of stopping
  bool with_renders = false;        // also store the views' renders (render_<view>.png, bare_<view>.png)
  void check() const;               // InvalidInput when out of range
};

struct SkippedItem {
  std::string item, reason;
};

struct TextureDatasetReport {
  int subjects = 0;                         // in the registered folder
  std::array<int, 3> split_subjects{};      // train, val, test
  int units = 0, units_mine = 0, units_done = 0, units_resumed = 0;
  int64_t samples = 0, masks = 0;           // written by this run
  std::vector<SkippedItem> skipped;         // over every finished unit (all workers)
  bool complete = false;                    // every unit of every worker finished: the manifests are final
  double seconds = 0;
};

// InvalidInput naming the file or flag for bad input (a registered folder or a model of another template, a subject
// without its maps, maps too small for --hr-res, a CelebAMask photo without a face, ...): before any unit when the
// problem is visible up front, else when the unit meets it (its shard is then not written). With keep_going, bad
// subjects and photos are skipped and listed instead.
// `detect_render` finds the landmarks on the renders (a face on black), `detect_photo` on CelebAMask photos.
TextureDatasetReport make_texture_dataset(const TextureDatasetOptions& options, const FaceLandmarkDetector& detect_render,
                                          const FaceLandmarkDetector& detect_photo, const ProgressCallback& progress = {});

}  // namespace bareskin::texgen
