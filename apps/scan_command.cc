// bareskin scan: `scan synth` (a synthetic population of scans with ground truth) and `scan register` (the template
// onto every scan of a folder: scan/register_folder.h).
#include <memory>

#include "apps/cli.h"
#include "apps/detector.h"
#include "core/error.h"
#include "core/files.h"
#include "scan/register_folder.h"
#include "scan/synth.h"

namespace bareskin::cli {

#ifndef BARESKIN_WITH_DETECT
// Without the Torch side there is no detector: scans without landmarks.json take the fallback alignment.
ScanLandmarkDetector scan_landmark_detector(const Globals&, const std::string&) { return {}; }
void set_torch_threads(const Globals&) {}
detect::PhotoDetector photo_detector(const Globals&, int) { return {}; }
#endif

namespace {

// `scan register`: flags into RegisterFolderOptions, then register_folder.
std::function<void()> add_scan_register(CLI::App& scan, const Globals& globals) {
  struct Options {
    std::string template_dir, map_format = "png", landmark_calibration;
    RegisterFolderOptions folder;
  };
  auto opt = std::make_shared<Options>();
  RegisterFolderOptions& f = opt->folder;
  CLI::App* app = scan.add_subcommand("register", "Register the template onto every scan (landmarks + NICP), with a report");
  app->add_option("--scans", f.scans, "Folder of scan folders (mesh.obj|ply; landmarks.json, maps and truth/ used if there)")
      ->capture_default_str();
  app->add_option("-o,--output", f.output, "Output folder: <id>/{mesh.ply, maps, report.json, qa_*.png}, summary.json")
      ->capture_default_str();
  app->add_option("--template", opt->template_dir, "Template folder from 'bareskin template' (default: BARESKIN_TEMPLATE, "
                                                   "then the installed one; docs/cli.md)");
  app->add_flag("--keep-going", f.keep_going, "Go on after a scan fails; list the failures at the end");
  app->add_flag("--no-landmarks", f.no_landmarks, "Ignore landmarks: fallback alignment (centroid + similarity ICP)");
  app->add_option("--scale", f.scale, "Multiply every scan and its landmarks by this on reading (1000: scans in metres)")
      ->capture_default_str()->check(CLI::PositiveNumber);
  RegisterOptions& n = f.nicp;
  app->add_option("--stiffness", n.stiffness, "NICP stiffness schedule")->capture_default_str()->group("NICP");
  app->add_option("--landmark-weight", n.landmark_weight, "Landmark weight per step")->capture_default_str()->group("NICP");
  app->add_option("--landmark-ids", n.landmark_ids, "Use only these landmarks (iBUG 0-67; default: all)")
      ->check(CLI::Range(0, 67))->group("NICP");
  app->add_option("--trim", n.trim_mm, "Correspondence distance trim per step (mm)")->capture_default_str()->group("NICP");
  app->add_option("--nodes", n.nodes, "NICP node count (template remeshed; 0: every template vertex)")
      ->capture_default_str()->group("NICP");
  app->add_option("--iterations", n.iterations_per_step, "ICP iterations per stiffness step")
      ->capture_default_str()->group("NICP");
  app->add_option("--max-normal-angle", n.max_normal_angle_deg, "Reject correspondences beyond this angle")
      ->capture_default_str()->group("NICP");
  app->add_option("--consistency", n.consistency, "Stiffness: weight of neighbouring affines agreeing at the nodes")
      ->capture_default_str()->group("NICP");
  app->add_option("--affine-stiffness", n.affine_stiffness,
                  "Stiffness: weight of Amberg's affine difference (--consistency 0 --affine-stiffness 1: Amberg's)")
      ->capture_default_str()->group("NICP");
  app->add_option("--huber", n.huber_mm, "Robust loss threshold (mm)")->capture_default_str()->group("NICP");
  app->add_option("--tangential-weight", n.tangential_weight,
                  "Per step: weight on each node's displacement along the surface from the start placed by the "
                  "best-fitting similarity (a prior that shapes differ along the normals; docs/pipeline.md); zeros: off")
      ->capture_default_str()->group("NICP");
  app->add_option("--outline-weight", n.outline_weight,
                  "For scans cut along the template's face outline (forehead, temples, jaw line; e.g. `scan synth`): "
                  "draw the template's outline to the scan's open border with this weight per vertex (0: off; "
                  "0.3 measured best; wrong for scans that go on past the face)")
      ->capture_default_str()->group("NICP");
  ModelPriorOptions& mp = n.prior;
  app->add_option("--model", f.model,
                  "3DMM (mm-build's model.safetensors, same template): fit its shape before NICP (docs/pipeline.md)")
      ->group("Model prior");
  app->add_option("--model-iterations", mp.iterations, "ICP rounds of the model fit")
      ->capture_default_str()->group("Model prior");
  app->add_option("--model-components", mp.components, "Identity components fitted (0: all)")
      ->capture_default_str()->group("Model prior");
  app->add_option("--model-vertices", mp.vertices,
                  "The fit's closest points for about this many well-spread template vertices (0: all)")
      ->capture_default_str()->group("Model prior");
  app->add_option("--model-regularisation", mp.regularisation,
                  "Prior on the coefficients against the mean squared point-to-plane residual (mm^2)")
      ->capture_default_str()->group("Model prior");
  app->add_option("--model-landmark-weight", mp.landmark_weight, "Landmarks' weight in the model fit (weak)")
      ->capture_default_str()->group("Model prior");
  app->add_option("--model-nicp-landmark-scale", mp.nicp_landmark_scale,
                  "NICP's landmark weights times this after the model fit")
      ->capture_default_str()->group("Model prior");
  app->add_flag("--sigma-weighted-landmarks", n.sigma_weighted_nicp,
                "NICP weights each detected landmark by (median sigma / sigma)^2 (the model fit always does)")
      ->group("NICP");
  TextureRefineOptions& t = n.texture;
  app->add_option("--texture-refine", t.iterations,
                  "Rounds of texture-aware refinement after NICP (flow in UV to --texture-reference; 0: off)")
      ->capture_default_str()->group("Texture refinement");
  app->add_option("--texture-landmarks", t.landmark_rounds,
                  "Rounds of finding the brows, eyes and lips in the scan's texture (flow to --texture-reference) and the "
                  "nose in its shape (curvature, flow to the template's), and registering again from them (for "
                  "detected landmarks: 3, about 2 s a round; docs/pipeline.md; 0: off)")
      ->capture_default_str()->group("Texture refinement");
  app->add_option("--texture-landmark-res", t.landmark_resolution, "UV size of the texture landmarks' flow (power of two)")
      ->capture_default_str()->group("Texture refinement");
  app->add_option("--shape-points", t.shape_points,
                  "In each texture-landmark round, about this many template vertices spread over the face placed by the "
                  "nose's curvature flow and held like weak landmarks: they hold the chin and cheeks (0: off)")
      ->capture_default_str()->group("Texture refinement");
  app->add_option("--shape-point-weight", t.shape_point_weight, "Each shape point's weight against a landmark's")
      ->capture_default_str()->group("Texture refinement");
  app->add_option("--texture-reference", f.texture_reference,
                  "Reference diffuse in the template UV (e.g. the mean of a first pass's diffuse maps; "
                  "docs/pipeline.md)")->group("Texture refinement");
  app->add_option("--texture-res", t.resolution, "UV size of the flow (power of two)")
      ->capture_default_str()->group("Texture refinement");
  app->add_option("--texture-weight", t.weight, "Texture correspondences against the closest-point term")
      ->capture_default_str()->group("Texture refinement");
  app->add_option("--texture-min-confidence", t.min_confidence, "Flow confidence below which a vertex gets no texture target")
      ->capture_default_str()->group("Texture refinement");
  app->add_option("--texture-smoothing", t.smoothing, "Flow regulariser: confidence-weighted smoothing (texels)")
      ->capture_default_str()->group("Texture refinement");
  app->add_option("--texture-stiffness", t.stiffness, "NICP stiffness during the refinement")
      ->capture_default_str()->group("Texture refinement");
  app->add_option("--texture-data-weight", t.data_weight, "Closest-point term's weight during the refinement")
      ->capture_default_str()->group("Texture refinement");
  app->add_option("--maps-res", f.maps.resolution,
                  "Transfer the maps the scan has (diffuse, normal, roughness, specular) into the template UV at this "
                  "resolution (0: no maps)")
      ->capture_default_str()->group("Maps");
  app->add_option("--map-format", opt->map_format, "png, tif or exr")->capture_default_str()->group("Maps");
  app->add_option("--heat-max", f.heat_max_mm, "Error (mm) shown red in the QA heat maps")->capture_default_str();
  app->add_option("--landmark-calibration", opt->landmark_calibration,
                  "For scans without landmarks.json: map the detected landmarks with this `landmarks calibrate` file");
  return [opt, &globals] {
    RegisterFolderOptions& f = opt->folder;
    f.maps.format = parse_map_format(opt->map_format);
    f.detect = scan_landmark_detector(globals, opt->landmark_calibration);
    ProgressBar bar = globals.progress("scan register");
    register_folder(opt->template_dir, f, bar.callback());
    bar.finish();
    globals.write_resolved_config(f.output + "/config.json");
  };
}

}  // namespace

std::function<void()> setup_scan_command(CLI::App& app, const Globals& globals) {
  auto population = std::make_shared<PopulationOptions>();
  PopulationOptions* opt = population.get();
  app.require_subcommand(1);
  CLI::App* synth = app.add_subcommand("synth", "Make a synthetic population of scans with ground truth");
  synth->add_option("-o,--output", opt->output, "Population folder (one folder per subject + manifest.json)")
      ->capture_default_str();
  synth->add_option("--template", opt->template_dir, "Template folder from 'bareskin template' (default: "
                                                     "BARESKIN_TEMPLATE, then the installed one; docs/cli.md)");
  synth->add_option("--count", opt->synth.count, "Subjects")->capture_default_str();
  synth->add_option("--seed", opt->synth.seed, "Population seed (same seed: identical files)")->capture_default_str();
  synth->add_option("--vertices", opt->synth.scan_vertices, "Vertices per scan (about; 2 triangles each)")
      ->capture_default_str()->group("Scan mesh");
  synth->add_option("--remesh-iterations", opt->synth.remesh_iterations, "Isotropic remeshing passes per scan")
      ->capture_default_str()->group("Scan mesh");
  synth->add_option("--noise", opt->synth.noise_mm, "Measurement noise along normals, sigma in mm")
      ->capture_default_str()->group("Realism");
  synth->add_option("--scale-jitter", opt->synth.scale_jitter, "Random scale in [1-s, 1+s]")
      ->capture_default_str()->group("Realism");
  synth->add_option("--rotation-jitter", opt->synth.rotation_jitter_deg, "Random rotation up to this many degrees")
      ->capture_default_str()->group("Realism");
  synth->add_option("--translation-jitter", opt->synth.translation_jitter_mm, "Random shift up to this many mm per axis")
      ->capture_default_str()->group("Realism");
  synth->add_flag("--holes", opt->synth.holes, "Cut the nostrils open, as scanners leave them")->group("Realism");
  synth->add_option("--skin-detail", opt->synth.skin_detail, "Skin micro-detail 0..1 (pigment speckle, freckles, moles, "
                    "darker pores: what a synthetic capture's photos need for COLMAP)")->capture_default_str()->group("Realism");
  synth->add_option("--res", opt->synth.maps.resolution, "Map resolution in the scan's atlas (0: no maps; 16384 works)")
      ->capture_default_str()->group("Maps");
  synth->add_option("--map-format", opt->map_format, "png (16-bit, sRGB diffuse), tif (16-bit) or exr (half, linear)")
      ->capture_default_str()->group("Maps");
  synth->add_option("--gutter", opt->synth.maps.gutter, "Texels filled beyond each chart's edge")
      ->capture_default_str()->group("Maps");
  synth->add_option("--truth-res", opt->synth.truth_resolution,
                    "Also bake the true maps in the template UV at this resolution into truth/maps/ (0: no)")
      ->capture_default_str()->group("Maps");
  synth->add_option("--feature-scale", opt->synth.identity.feature_scale, "Strength of the semantic feature controls")
      ->capture_default_str()->group("Identity");
  synth->add_option("--tangential", opt->synth.identity.tangential,
                    "Share of the identity displacement along the surface that is kept [0,1]")
      ->capture_default_str()->group("Identity");
  synth->add_option("--symmetry", opt->synth.identity.symmetry, "Mirror-symmetric share of the random field [0,1]")
      ->capture_default_str()->group("Identity");
  const std::function<void()> register_action = add_scan_register(app, globals);
  return [population, &globals, synth, register_action] {
    if (!synth->parsed()) return register_action();
    population->synth.maps.format = parse_map_format(population->map_format);
    ProgressBar bar = globals.progress("scan synth");
    write_population(*population, bar.callback());
    bar.finish();
    globals.write_resolved_config(population->output + "/config.json");
    spdlog::info("scan synth: {} subjects in {}", population->synth.count, population->output);
  };
}

}  // namespace bareskin::cli
