// What a run folder shows while and after it trains: metrics.csv and eval.csv (long format: step,name,value),
// losses.svg / eval.svg / lr.svg charts redrawn at every log, sample grids samples/step_NNNNNNN.png, and TensorBoard
// event files where the build has protobuf. Written by rank 0 only.
#pragma once
#include <torch/types.h>

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace bareskin::train {

class RunLog {
 public:
  // Opens the logs of `run_dir`; rows past `start_step` (written after the checkpoint a run resumes from) are dropped.
  RunLog(std::string run_dir, int64_t start_step);
  ~RunLog();
  void losses(int64_t step, const std::map<std::string, double>& losses, const std::map<std::string, double>& rates);
  void evaluation(int64_t step, const std::map<std::string, double>& metrics);
  // Rows of images [3,H,W] (or [1,H,W]) in [0,1], tiled into one PNG; images of a row are resized to the first's height.
  void samples(int64_t step, const std::vector<std::vector<torch::Tensor>>& rows);

 private:
  struct Series;
  void append(const std::string& file, int64_t step, const std::map<std::string, double>& values);
  void chart(const std::string& file, const std::string& title, const std::string& y_label, bool log_y,
             const std::string& prefix_filter);
  std::string dir_;
  std::map<std::string, std::map<std::string, std::vector<std::pair<int64_t, double>>>> history_;  // file -> name -> points
  struct TensorBoard;
  std::unique_ptr<TensorBoard> tensorboard_;
};

// Rows of images tiled into one [3,H,W] grid (2-pixel white gaps).
torch::Tensor image_grid(const std::vector<std::vector<torch::Tensor>>& rows);

}  // namespace bareskin::train
