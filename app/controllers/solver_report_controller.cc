#include "app/controllers/solver_report_controller.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <iomanip>
#include <map>
#include <memory>
#include <sstream>

#include "app/io/dataset_io.h"
#include "app/io/file_util.h"
#include "app/sim/simulated_rig.h"
#include "app/sim/textile_scene.h"
#include "calibration/camera_model.h"
#include "calibration/raw_develop.h"
#include "calibration/rig.h"
#include "calibration/rig_light_field.h"
#include "core/field_error.h"
#include "core/format.h"
#include "solver/angular_error.h"
#include "solver/light_subset.h"
#include "solver/photometric_methods.h"
#include "solver/photometric_solver.h"
#include "solver/synthetic_scene.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

using Method = PhotometricSolverOptions::Method;

constexpr int kDiligentLights = 96;   // every DiLiGenT object has 96 lights
constexpr int kReportRingLights = 10;  // the DiLiGenT subsets: as many lights as the rig has LEDs

// One scene of the report: what the solver gets and the truth to score it.
struct ReportScene {
  std::string name;
  std::vector<ImageF> images;
  std::vector<ImageU8> sample_valid;
  std::unique_ptr<LightField> field;
  ImageF normal_truth;
  ImageF albedo_truth;  // empty: no albedo ground truth
  ImageU8 mask;         // pixels scored
  ImageU8 region;       // pixels asked for; empty = all
  // Bayer-domain variant of the same capture (RAW path only).
  std::vector<ImageF> mosaics;
  std::array<int, 4> cfa_channels = {0, 1, 1, 2};
};

ReportScene AnalyticScene(const std::string& name, const SyntheticSceneOptions& options) {
  SyntheticScene scene = MakeSyntheticScene(options);
  ReportScene out;
  out.name = name;
  out.images = std::move(scene.images);
  out.field = std::move(scene.light_field);
  out.normal_truth = std::move(scene.normal_in_table);
  out.albedo_truth = std::move(scene.albedo);
  out.mask = std::move(scene.object);
  return out;
}

std::string RigSceneName(bool raw_path, SurfaceMaterial material) {
  if (material == SurfaceMaterial::kCloth) {
    return "rig cloth twill 1232x816, RAW: velvet sheen, sensor noise, demosaiced";
  }
  if (material == SurfaceMaterial::kSatin) {
    return "rig satin 1232x816, RAW: anisotropic GGX lobe, sensor noise, demosaiced";
  }
  return raw_path ? "rig textile 1232x816, RAW: sensor noise, cast shadows, demosaiced"
                  : "rig textile 1232x816, near-field LEDs, cast shadows, noise-free";
}

// "DiLiGenT ballPNG (96 lights)", "DiLiGenT ballPNG (10 ring lights)" (the folder name).
std::string DiligentSceneName(const std::string& object, int num_lights, bool ring) {
  return "DiLiGenT " + object + " (" + std::to_string(num_lights) + (ring ? " ring lights)" : " lights)");
}

// The simulated rig's LEDs shining on the true surface points: the exact
// light field, so that the report measures the solver, not the light model;
// seen from the rig camera's centre, as `scanbench solve` sees them.
std::unique_ptr<LightField> RigLightsOnSurface(const RigDescription& rig, const ImageF& points) {
  return std::make_unique<PointLightField>(RigPointLights(rig), points, CameraCentreInTable(rig.camera));
}

// The simulated rig's default twill at the default size; `material` other
// than kLambert only through the RAW path (issue #13: the cloth and satin
// scenes are scored as the scanner would see them).
ReportScene RigScene(bool raw_path, int num_threads, SurfaceMaterial material = SurfaceMaterial::kLambert) {
  SimulatedRigOptions options;
  options.num_threads = num_threads;
  if (!raw_path) options.ambient = 0;  // noise-free linear frames: Lambertian + cast shadows only
  const RigDescription rig = MakeDefaultSimulatedRig(options.width, options.height);
  TextileSceneOptions textile;
  textile.material = material;
  const SimulatedRig sim(options, TextileScene(textile), rig);
  GroundTruthMaps truth = sim.RenderGroundTruth();
  ReportScene out;
  out.name = RigSceneName(raw_path, material);
  out.field = RigLightsOnSurface(rig, truth.point_in_table);
  if (!raw_path) {
    for (int k = 0; k < sim.num_leds(); ++k) out.images.push_back(sim.RenderLinear(k));
  } else {
    const RawImage dark = sim.RenderFrame(std::nullopt, 0);
    const double range = options.white_level - options.black_level;
    for (int p = 0; p < 4; ++p) out.cfa_channels[p] = CfaColorAt(options.cfa, p & 1, p >> 1);
    for (int k = 0; k < sim.num_leds(); ++k) {
      const RawImage raw = sim.RenderFrame(k, static_cast<uint64_t>(k + 1));
      DevelopedFrame developed = DevelopRaw(raw, &dark, RawDevelopOptions());
      out.images.push_back(std::move(developed.rgb));
      out.sample_valid.push_back(std::move(developed.valid));
      ImageF mosaic(raw.width(), raw.height(), 1);
      for (int y = 0; y < raw.height(); ++y) {
        for (int x = 0; x < raw.width(); ++x) {
          mosaic(x, y) = static_cast<float>((double(raw.mosaic(x, y)) - dark.mosaic(x, y)) / range);
        }
      }
      out.mosaics.push_back(std::move(mosaic));
    }
  }
  out.normal_truth = std::move(truth.normal_in_table);
  out.albedo_truth = std::move(truth.albedo);
  out.mask = std::move(truth.sample_mask);
  return out;
}

// `ring_lights` > 0 keeps that many lights chosen like the rig's two LED
// rings (solve-dataset --ring-lights), else all of them.
ReportScene DiligentScene(const fs::path& folder, int ring_lights) {
  PhotometricDataset dataset = LoadPhotometricDataset(folder);
  if (ring_lights > 0) dataset.KeepLights(SelectRingLights(dataset.CentralLightDirections(), ring_lights));
  ReportScene out;
  out.name = DiligentSceneName(dataset.name, dataset.num_lights(), ring_lights > 0);
  out.field = dataset.MakeLightField();
  out.images = std::move(dataset.images);
  out.normal_truth = dataset.normal_ground_truth ? std::move(*dataset.normal_ground_truth) : ImageF();
  out.mask = dataset.mask;
  out.region = std::move(dataset.mask);
  return out;
}

// A scene of the report, built only when its turn comes so that one scene
// at a time is in memory.
struct SceneBuilder {
  std::string kind;  // "analytic", "rig", "16mp", "diligent"
  std::string name;  // ReportScene::name as built (DiLiGenT: from the folder)
  std::function<ReportScene()> build;
};

// One solve of a scene: every method, the benchmark's baseline on DiLiGenT,
// and the Bayer-domain default where the scene has mosaics.
struct ReportRun {
  std::string label;
  PhotometricSolverOptions options;
  bool bayer = false;
};

std::vector<ReportRun> RunsFor(const ReportScene& scene, bool diligent, bool huge, int num_threads) {
  std::vector<ReportRun> runs;
  for (const PhotometricMethodRow& method : PhotometricMethods()) {
    if (NeedsUniformLightField(method) && !scene.field->IsUniform()) continue;
    // The network on every pixel of 16 MP takes minutes (docs/solver.md, "Learned normals"): left out there.
    if (huge && method.method == Method::kLearned) continue;
    PhotometricSolverOptions options;
    options.method = method.method;
    runs.push_back({method.name, options});
    if (method.method == Method::kAdaptive && scene.field->num_lights() <= options.adaptive_learned_max_lights) {
      // The default with the network on its robust pixels without a lobe: what it adds.
      PhotometricSolverOptions with_network = options;
      with_network.adaptive_learned = PhotometricSolverOptions::LearnedUse::kUnsupportedLobe;
      runs.push_back({"adaptive --learned unsupported", with_network});
    }
  }
  if (diligent) {
    // The benchmark's least-squares baseline: every sample kept.
    PhotometricSolverOptions baseline;
    baseline.method = Method::kJacobiSvd;
    baseline.min_sample_value = 0;
    runs.insert(runs.begin(), {"lsq baseline (jacobi_svd, all samples)", baseline});
  }
  if (!scene.mosaics.empty()) runs.push_back({"adaptive (Bayer domain)", PhotometricSolverOptions(), true});
  for (ReportRun& run : runs) run.options.num_threads = num_threads;
  return runs;
}

PhotometricSolverSummary SolveScene(const ReportScene& scene, const ReportRun& run, PhotometricSolution* solution,
                                    const ProgressCallback& progress) {
  if (run.bayer) {
    BayerSolverInput input;
    for (const ImageF& mosaic : scene.mosaics) input.mosaics.push_back(&mosaic);
    input.cfa_channels = scene.cfa_channels;
    input.light_field = scene.field.get();
    return SolvePhotometricStereoBayer(run.options, input, solution, progress);
  }
  PhotometricSolverInput input;
  for (const ImageF& image : scene.images) input.images.push_back(&image);
  for (const ImageU8& valid : scene.sample_valid) input.sample_valid.push_back(&valid);
  input.light_field = scene.field.get();
  input.region = scene.region.empty() ? nullptr : &scene.region;
  return SolvePhotometricStereo(run.options, input, solution, progress);
}

// The row of one solve: errors against the scene's truth, speed over the
// pixels asked for (the region), the share re-solved robustly.
SolverReportRow ScoreRun(const ReportScene& scene, const std::string& label, const PhotometricSolverSummary& solver,
                         const PhotometricSolution& solution) {
  SolverReportRow row;
  row.scene = scene.name;
  row.method = label;
  if (!scene.normal_truth.empty()) {
    const ErrorStatistics error = AngularErrorDegrees(solution.normal_in_table, scene.normal_truth, scene.mask);
    row.mean_error_deg = error.mean;
    row.median_error_deg = error.median;
  }
  if (!scene.albedo_truth.empty() && !solution.albedo.empty()) {
    row.albedo_error = AbsoluteError(solution.albedo, scene.albedo_truth, scene.mask).mean;
  }
  size_t asked = solver.num_pixels;
  if (!scene.region.empty()) {
    asked = static_cast<size_t>(std::count_if(scene.region.data(), scene.region.data() + scene.region.size(),
                                              [](uint8_t v) { return v != 0; }));
  }
  row.seconds = solver.seconds;
  row.megapixels_per_second = solver.seconds > 0 ? asked / 1e6 / solver.seconds : 0;
  row.threads = solver.num_threads;
  row.robust_fraction =
      solver.num_solved() > 0 ? double(solver.pixels_by_path[int(SolvePath::kRobust)]) / solver.num_solved() : 0;
  return row;
}

// The scenes in report order; what is left out is noted in `skipped`.
std::vector<SceneBuilder> SceneBuilders(const SolverReportOptions& options, std::vector<std::string>* skipped) {
  std::vector<SceneBuilder> builders;
  const int size = options.analytic_size;
  for (double noise : {0.001, 0.005}) {
    const std::string name = "sphere " + std::to_string(size) + "^2, distant, Lambertian, noise " + Fixed(noise, 3);
    builders.push_back({"analytic", name, [size, noise, name] {
      SyntheticSceneOptions o;
      o.width = o.height = size;
      o.noise_stddev = noise;
      return AnalyticScene(name, o);
    }});
  }
  const std::string sheen = "sphere " + std::to_string(size) + "^2, 20 distant lights, specular sheen, noise 0.002";
  builders.push_back({"analytic", sheen, [size, sheen] {
    SyntheticSceneOptions o;
    o.width = o.height = size;
    o.noise_stddev = 0.002;
    o.specular = 0.5;
    o.shininess = 50;
    o.num_lights = 20;
    return AnalyticScene(sheen, o);
  }});
  const int threads = options.num_threads;
  builders.push_back(
      {"rig", RigSceneName(false, SurfaceMaterial::kLambert), [threads] { return RigScene(false, threads); }});
  for (SurfaceMaterial material : {SurfaceMaterial::kLambert, SurfaceMaterial::kCloth, SurfaceMaterial::kSatin}) {
    builders.push_back({"rig", RigSceneName(true, material), [threads, material] {
      return RigScene(true, threads, material);
    }});
  }
  if (options.include_16mp) {
    const std::string name = "16 MP 4928x3264, 10 near-field LEDs, Lambertian, noise 0.002";
    builders.push_back({"16mp", name, [name] {
      SyntheticSceneOptions o;
      o.width = kD5100Width;
      o.height = kD5100Height;
      o.lights = SyntheticSceneOptions::Lights::kNearField;
      o.pixel_pitch = 150.0 / o.width;  // a 150 mm field of view, LEDs 500 mm away
      o.light_distance = 500;
      o.noise_stddev = 0.002;
      return AnalyticScene(name, o);
    }});
  } else {
    skipped->push_back("the 16 MP scene (--no-16mp)");
  }
  // Every light (the benchmark's setting), then 10 chosen like the rig's LED
  // rings (the scanner's regime, issue #13).
  // Each object of ../shared/data: the 16-bit ball and bear, the 8-bit crops.
  const std::pair<const fs::path*, const char*> objects[] = {
      {&options.diligent_dir, "ballPNG"},          {&options.diligent_dir, "bearPNG"},
      {&options.diligent_crop8_dir, "buddhaPNG"}, {&options.diligent_crop8_dir, "gobletPNG"},
      {&options.diligent_crop8_dir, "pot1PNG"}};
  for (int ring_lights : {0, kReportRingLights}) {
    for (const auto& [dir, object] : objects) {
      const fs::path folder = *dir / object;
      if (!dir->empty() && fs::is_directory(folder)) {
        builders.push_back({"diligent",
                            DiligentSceneName(object, ring_lights > 0 ? ring_lights : kDiligentLights, ring_lights > 0),
                            [folder, ring_lights] { return DiligentScene(folder, ring_lights); }});
      } else {
        skipped->push_back(std::string("DiLiGenT ") + object + (ring_lights > 0 ? " with 10 ring lights" : "") +
                           " (not found at " + folder.string() + ")");
      }
    }
  }
  return builders;
}

std::string ReportCsv(const std::vector<SolverReportRow>& rows) {
  std::ostringstream csv;
  csv << "scene,method,mean_error_deg,median_error_deg,albedo_error,megapixels_per_second,seconds,threads,"
         "robust_fraction\n";
  for (const SolverReportRow& row : rows) {
    csv << '"' << row.scene << "\",\"" << row.method << "\"," << row.mean_error_deg << "," << row.median_error_deg
        << "," << row.albedo_error << "," << row.megapixels_per_second << "," << row.seconds << "," << row.threads
        << "," << row.robust_fraction << "\n";
  }
  return csv.str();
}

}  // namespace

std::vector<std::string> SolverReportSceneNames(const SolverReportOptions& options, std::vector<std::string>* skipped) {
  std::vector<std::string> ignored;
  std::vector<std::string> names;
  for (const SceneBuilder& builder : SceneBuilders(options, skipped != nullptr ? skipped : &ignored)) {
    names.push_back(builder.name);
  }
  return names;
}

void SolverReportOptions::Check() const {
  if (output_dir.empty()) throw std::invalid_argument("SolverReportOptions.output_dir is empty; a folder is required");
  SCANBENCH_REQUIRE_GE_LE("SolverReportOptions", "num_threads", num_threads, 0, 256);
  SCANBENCH_REQUIRE_GE_LE("SolverReportOptions", "analytic_size", analytic_size, 64, 4096);
}

std::string SolverReportSummary::MarkdownTable() const {
  std::ostringstream out;
  out << "| scene | method | mean err (deg) | median err (deg) | albedo err | MP/s | s | threads | robust px |\n"
      << "|---|---|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const SolverReportRow& row : rows) {
    out << "| " << row.scene << " | " << row.method << " | " << Fixed(row.mean_error_deg, 2) << " | "
        << Fixed(row.median_error_deg, 2) << " | " << (row.albedo_error < 0 ? "n/a" : Fixed(row.albedo_error, 4))
        << " | " << Fixed(row.megapixels_per_second, 2) << " | " << Fixed(row.seconds, 2) << " | " << row.threads
        << " | " << Fixed(100 * row.robust_fraction, 1) << " % |\n";
  }
  for (const std::string& note : skipped) out << "\nLeft out: " << note << "\n";
  return out.str();
}

std::string ErrorVsTimeSvg(const std::vector<SolverReportRow>& rows) {
  std::vector<std::string> scenes;
  std::vector<std::string> methods;
  for (const SolverReportRow& row : rows) {
    if (std::find(scenes.begin(), scenes.end(), row.scene) == scenes.end()) scenes.push_back(row.scene);
    if (std::find(methods.begin(), methods.end(), row.method) == methods.end()) methods.push_back(row.method);
  }
  const char* colours[] = {"#d62728", "#1f77b4", "#2ca02c", "#ff7f0e", "#9467bd",
                           "#8c564b", "#e377c2", "#17becf", "#000000", "#bcbd22"};
  constexpr size_t kColours = sizeof(colours) / sizeof(colours[0]);
  const int columns = 3, panel_w = 380, panel_h = 260, left = 60, top = 40, legend_h = 30 + 18 * ((int(methods.size()) + 3) / 4);
  const int rows_n = (static_cast<int>(scenes.size()) + columns - 1) / columns;
  const int width = columns * panel_w + 20, height = legend_h + rows_n * panel_h + 20;
  std::ostringstream svg;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height
      << "\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      << "<text x=\"10\" y=\"18\" font-size=\"14\">Mean angular error against solve time (seconds per megapixel, "
         "log scale); line: Pareto front</text>\n";
  for (size_t m = 0; m < methods.size(); ++m) {
    const int x = 10 + 290 * static_cast<int>(m % 4), y = 34 + 18 * static_cast<int>(m / 4);
    svg << "<circle cx=\"" << x + 5 << "\" cy=\"" << y << "\" r=\"5\" fill=\"" << colours[m % kColours] << "\"/><text x=\""
        << x + 14 << "\" y=\"" << y + 4 << "\">" << XmlEscaped(methods[m]) << "</text>\n";
  }
  for (size_t s = 0; s < scenes.size(); ++s) {
    const int ox = 10 + panel_w * static_cast<int>(s % columns);
    const int oy = legend_h + panel_h * static_cast<int>(s / columns);
    const int pw = panel_w - left - 20, ph = panel_h - top - 40;
    std::vector<const SolverReportRow*> points;
    for (const SolverReportRow& row : rows) {
      if (row.scene == scenes[s] && row.megapixels_per_second > 0) points.push_back(&row);
    }
    if (points.empty()) continue;
    auto cost = [](const SolverReportRow* r) { return std::log10(1.0 / r->megapixels_per_second); };
    double x_min = 1e9, x_max = -1e9, y_max = 0;
    for (const SolverReportRow* r : points) {
      x_min = std::min(x_min, cost(r));
      x_max = std::max(x_max, cost(r));
      y_max = std::max(y_max, r->mean_error_deg);
    }
    x_min = std::floor(x_min * 2) / 2 - 0.1, x_max = std::ceil(x_max * 2) / 2 + 0.1;
    y_max = y_max > 0 ? y_max * 1.15 : 1;
    auto px = [&](double v) { return ox + left + (v - x_min) / (x_max - x_min) * pw; };
    auto py = [&](double v) { return oy + top + ph - v / y_max * ph; };
    svg << "<g>\n<text x=\"" << ox + left << "\" y=\"" << oy + 22 << "\" font-size=\"12\">"
        << XmlEscaped(scenes[s].size() > 54 ? scenes[s].substr(0, 51) + "..." : scenes[s]) << "</text>\n"
        << "<rect x=\"" << ox + left << "\" y=\"" << oy + top << "\" width=\"" << pw << "\" height=\"" << ph
        << "\" fill=\"none\" stroke=\"#888\"/>\n";
    for (double t = std::ceil(x_min); t <= x_max; t += 1) {
      svg << "<line x1=\"" << px(t) << "\" y1=\"" << oy + top << "\" x2=\"" << px(t) << "\" y2=\"" << oy + top + ph
          << "\" stroke=\"#eee\"/><text x=\"" << px(t) - 12 << "\" y=\"" << oy + top + ph + 14 << "\">"
          << (t >= 0 ? Fixed(std::pow(10.0, t), 0) : Fixed(std::pow(10.0, t), int(-t))) << "</text>\n";
    }
    const int digits = std::clamp(2 - static_cast<int>(std::floor(std::log10(y_max))), 0, 6);
    for (int tick = 0; tick <= 4; ++tick) {
      const double v = y_max * tick / 4;
      svg << "<text x=\"" << ox + 8 << "\" y=\"" << py(v) + 4 << "\">" << Fixed(v, digits) << "</text>\n";
    }
    svg << "<text x=\"" << ox + left + pw / 2 - 40 << "\" y=\"" << oy + top + ph + 30 << "\">s per MP</text>\n"
        << "<text x=\"" << ox + 8 << "\" y=\"" << oy + top - 6 << "\">deg</text>\n";
    // Pareto front: sorted by cost, keep the points better than all cheaper ones.
    std::vector<const SolverReportRow*> sorted = points;
    std::sort(sorted.begin(), sorted.end(), [&](auto* a, auto* b) { return cost(a) < cost(b); });
    std::string path;
    double best = 1e30;
    for (const SolverReportRow* r : sorted) {
      if (r->mean_error_deg < best) {
        best = r->mean_error_deg;
        path += (path.empty() ? "M" : " L") + Fixed(px(cost(r)), 1) + "," + Fixed(py(best), 1);
      }
    }
    svg << "<path d=\"" << path << "\" fill=\"none\" stroke=\"#333\" stroke-dasharray=\"4,3\"/>\n";
    for (const SolverReportRow* r : points) {
      const size_t m = std::find(methods.begin(), methods.end(), r->method) - methods.begin();
      svg << "<circle cx=\"" << Fixed(px(cost(r)), 1) << "\" cy=\"" << Fixed(py(r->mean_error_deg), 1)
          << "\" r=\"5\" fill=\"" << colours[m % kColours] << "\" fill-opacity=\"0.85\"><title>" << XmlEscaped(r->method)
          << ": " << Fixed(r->mean_error_deg, 2) << " deg, " << Fixed(r->megapixels_per_second, 2)
          << " MP/s</title></circle>\n";
    }
    svg << "</g>\n";
  }
  svg << "</svg>\n";
  return svg.str();
}

SolverReportController::SolverReportController(SolverReportOptions options) : options_(std::move(options)) {}

void SolverReportController::Run() {
  options_.Check();
  summary_ = SolverReportSummary();
  fs::create_directories(options_.output_dir);
  const std::vector<SceneBuilder> builders = SceneBuilders(options_, &summary_.skipped);
  for (size_t b = 0; b < builders.size(); ++b) {
    BeginStage("build scene " + std::to_string(b + 1) + "/" + std::to_string(builders.size()));
    const ReportScene scene = builders[b].build();
    for (const ReportRun& run :
         RunsFor(scene, builders[b].kind == "diligent", builders[b].kind == "16mp", options_.num_threads)) {
      const std::string stage = scene.name.substr(0, 40) + ": " + run.label;
      PhotometricSolution solution;
      const PhotometricSolverSummary solver = SolveScene(scene, run, &solution, StageCallback(stage));
      RequireSuccess(solver, stage);
      summary_.rows.push_back(ScoreRun(scene, run.label, solver, solution));
    }
  }
  WriteFileAtomic(options_.output_dir / "report.csv", ReportCsv(summary_.rows), OverwritePolicy::kReplace);
  WriteFileAtomic(options_.output_dir / "report.md", summary_.MarkdownTable(), OverwritePolicy::kReplace);
  WriteFileAtomic(options_.output_dir / "error_vs_time.svg", ErrorVsTimeSvg(summary_.rows), OverwritePolicy::kReplace);
}

}  // namespace scanbench
