// Per-view 2D landmark calibration for make-dataset's renders. The detector's error on a view, after the 3D
// convention calibration (`landmarks calibrate`, applied in the fits), has a part that is the same for every subject
// seen from that view (a bias of the eye, brow, lip and jaw points that depends on the yaw) and a part that scatters
// per subject. The bias (the median over subjects, which a view where the detector collapsed does not move) is learned
// on training subjects, whose truth make-dataset knows (each report carries every view's detected landmarks and the
// true ones as the fit's model sees them), and subtracted from the detected landmarks of every later run at the same
// yaw angles: no truth of the subject at hand is used.
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

namespace bareskin::texgen {

struct ViewCalibration {
  struct View {
    std::string name;
    double yaw_deg = 0;
    // median over the samples of (detected − truth) / render size, per coordinate
    Eigen::Matrix<double, 68, 2> bias = Eigen::Matrix<double, 68, 2>::Zero();
    Eigen::Matrix<double, 68, 1> scatter = Eigen::Matrix<double, 68, 1>::Zero();  // RMS distance around the bias, same unit
    int samples = 0;  // subject × light samples averaged
  };
  std::vector<View> views;
  std::string landmark_calibration;  // the 3D calibration's file name the truth was measured with ("" none)
  // The view's bias, or InvalidInput naming `source` when the file has no view of that name at that yaw.
  const View& at(const std::string& name, double yaw_deg, const std::string& source) const;
};

// `detected` (px at render_size) less the view's bias.
Eigen::Matrix<double, 68, 2> calibrated_landmarks(const Eigen::Matrix<double, 68, 2>& detected,
                                                  const ViewCalibration::View& view, int render_size);

// The median residual per view over make-dataset report files (reports/<subject>.json with landmarks_detected_px and
// landmarks_truth_px per view, sizes.render per light). InvalidInput naming the file for a report without them, for
// reports made with different 3D calibrations, or when fewer than two samples give a view.
ViewCalibration learn_view_calibration(const std::vector<std::string>& report_files);
// Every reports/*.json under a make-dataset output folder, sorted.
std::vector<std::string> report_files(const std::string& dataset_folder);

void write_view_calibration(const std::string& path, const ViewCalibration& calibration);
// InvalidInput naming the file when it is not a view calibration.
ViewCalibration read_view_calibration(const std::string& path);

}  // namespace bareskin::texgen
