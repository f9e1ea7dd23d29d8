// BareSkinNet's task options (bareskinnet.h), their JSON and the paper's ablation rows. No Torch here: the command
// that sets them builds without the Torch precompiled header.
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

namespace bareskin::bsn {

struct Options {
  int stage = 1;                  // 1: G alone (L_DD); 2: + L_FR through the reconstruction
  std::string target = "before";  // G's supervision: "before" (the paper: lit, no makeup) or "bare" (albedo truth
                                  // on the face region, the input elsewhere)
  // How G's image comes from the U-Net's Tanh output y (generator_forward):
  //  - "image": the paper's G, output = (y + 1) / 2;
  //  - "residual" (ours): output = input + y, a change of the input;
  //  - "affine" (ours, built for the job): y has 6 channels, output = input · exp(y₀…₂) + y₃…₅, a per-pixel gain
  //    and offset per channel. Light multiplies the albedo and a makeup layer blends over it, so the gain carries
  //    the shading and the offset the pigment while the input's skin detail passes through unchanged.
  // With "residual" and "affine" the last layer starts at zero: G starts as the identity and training is judged by
  // what it adds. options_of_run reads the configurations of older runs (their boolean `residual`).
  std::string head = "residual";
  int64_t size = 256;             // training resolution (the shards' 256² images are area-resized)
  nlohmann::json g = nlohmann::json::object();  // unet256 options over the zoo defaults (num_downs follows size)
  nlohmann::json d = nlohmann::json::object();  // patchgan options
  std::string gan = "vanilla";                  // pix2pix's loss
  std::string lpips_trunk = "vgg16-random";     // or "facenet" (face-api's recognition net; cheap on the CPU)
  std::string face_api;                         // folder of face-api's weights (facenet trunk)
  double w1 = 100, w2 = 1, w3 = 40;             // L1, GAN, LPIPS
  double w_coeff = 0.1, w_land = 0.08, w_diff = 100, w_light = 100, w_reg = 1e-3;
  // Stage 2's reconstruction of G's output: "E" (the student, the paper) or "F" (the teacher reads G's output
  // itself: the ablation rows d and e, without L_coeff).
  std::string recon = "E";
  bool tune_f = false;  // F trained along (row e) instead of frozen
  double lr_g = 2e-5, lr_d = 2e-5, lr_e = 1e-4, lr_f = 1e-5;
  double beta1 = 0.5, beta2 = 0.999;
  // Ours, not the paper's: an exponential moving average of G's weights and batch-norm statistics (0: off). Each
  // stage keeps G_ema ← d·G_ema + (1 − d)·G with d = ema_decay(ema, n) at the start of every step (so after N steps
  // it averages G after steps 0 … N − 1), starting from the G the stage starts with; the validation metrics, the
  // sample grids, eval.json and inference use G_ema. The trained G itself is unchanged by it.
  double ema = 0;
  // Ours, not the paper's: each stage's learning rates (G, D, E, a tuned F) fall linearly to 0 from this fraction of
  // the stage's steps on (1: constant, the paper; 0.5: the second half of each stage decays).
  double lr_decay = 1;
  // Ours, not the paper's: each step's gradients scaled to at most this norm per optimizer (D's; G's with E's and a
  // tuned F's), the norm before clipping logged as <optimizer>/grad_norm (training/trainer.h); 0: off.
  double clip_grad_norm = 0;
  // Ours, not the paper's: weight of L_level, the L1 distance between the mean colours (per image and channel) of
  // G's output and of its target over the face region (face.png); 0: off. It penalises the overall brightness G
  // leaves per light condition directly, which the per-pixel L1 only does through the sum of its signs.
  double w_level = 0;
  // Ours, not the paper's: weight of L_makeup, the L1 distance between G's output and its target over the region the
  // makeup changed (mean |makeup − before| over the channels > 0.02, on face.png: the evaluation's makeup region),
  // normalised by that region's area; 0: off. The whole-image L1 gives the lips, eyes and cheeks only their share of
  // the pixels.
  double w_makeup = 0;
  // Ours, not the paper's: the probability that a training sample's makeup gets a random hue (rotate_makeup_hue);
  // 0: off. The world's makeup families keep to their palettes; this shows G lipsticks and shadows of every hue, so
  // that it removes makeup by where it lies and how it covers the skin, not by its colour.
  double makeup_hue = 0;
  // Ours, not the paper's: the probability that a training sample's makeup is painted over in opaque colours of any
  // hue where it changed the face most (paint_makeup); 0: off. The held-out makeup family's saturated, opaque
  // colours (blue lips, green lids) lie outside the world's palettes, which a turn of the hue does not reach.
  double makeup_paint = 0;
  // Ours, not the paper's: L_diff compares G's output with the render's albedo times the gain per image and channel
  // that fits it best (least squares over the region, no gradient through the gain). The 3DMM's albedo space does
  // not span every skin tone; with the gain, stage 2 teaches G the shading it removes and leaves its level and colour
  // to L_DD. false: the paper's L_diff.
  bool diff_gain = false;
  void check() const;  // InvalidInput for a bad value (names the key)
};

void to_json(nlohmann::json& j, const Options& o);
void from_json(const nlohmann::json& j, Options& o);  // InvalidInput: unknown key, wrong type, bad value
// The task options of a trained run (its config.json's "task"), as load_generator reads them. Runs written before
// `head` existed say `residual` true (head "residual") or false, or nothing at all (both: the paper's G, "image").
Options options_of_run(const nlohmann::json& task);

// The paper's Fig. 7 rows as option changes: "b" L1 + GAN; "c" + LPIPS; "d" + frozen F; "e" + fine-tuned F;
// "f" + E (teacher-student) without L_light; "g" the full model. Rows b, c are stage 1 only. InvalidInput otherwise.
void ablation_preset(const std::string& row, Options& o);
// Whether the row trains a second stage.
bool ablation_has_stage2(const std::string& row);

}  // namespace bareskin::bsn
