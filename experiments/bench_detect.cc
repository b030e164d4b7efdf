#include "experiments/bench_detect.h"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <opencv2/core.hpp>

#include "core/error.h"
#include "core/file_io.h"
#include "core/gnuplot.h"
#include "core/stats.h"
#include "detect/detect.h"
#include "experiments/machine_info.h"
#include "experiments/scene_lookup.h"
#include "experiments/trial.h"
#include "pattern/pattern_json.h"

namespace curvecheck::experiments {
namespace {
namespace fs = std::filesystem;

struct Result {
  std::string pattern, detector, failure;
  double median_ms = 0, min_ms = 0, rms_px = NAN, max_px = NAN;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  int found = 0, visible = 0;
  bool pareto = false;
};

// Within each pattern (a detector's error depends on the pattern), the detectors no other beats in both
// median time and RMS error against the truth; a detector that found nothing is never on the front.
void MarkParetoFronts(std::vector<Result>& results) {
  for (size_t i = 0; i < results.size(); ++i) {
    std::vector<double> t, e;
    std::vector<size_t> index;
    for (size_t j = 0; j < results.size(); ++j) {
      if (results[j].pattern != results[i].pattern) continue;
      index.push_back(j);
      t.push_back(results[j].median_ms);
      e.push_back(results[j].found > 0 ? results[j].rms_px : NAN);
    }
    const std::vector<bool> front = ParetoFront(t, e);
    for (size_t k = 0; k < index.size(); ++k) {
      if (index[k] == i) results[i].pareto = front[k];
    }
  }
}

// Median time against RMS error, log-log, one colour per pattern, the Pareto front of each as a line.
std::string ChartScript(const std::string& title, const std::vector<std::string>& patterns) {
  std::string plots;
  for (size_t i = 0; i < patterns.size(); ++i) {
    const std::string quoted = GnuplotString(patterns[i]);
    plots += fmt::format(
        "  'detect_bench.csv' skip 2 using (strcol(1) eq {q} ? $3 : 1/0):9 with points pt 7 ps 1.4 lc {c} "
        "title {q}, \\\n"
        "  '< grep \"^{p},.*,1$\" detect_bench.csv | sort -t, -k3 -g' using 3:9 with lines lw 2 lc {c} "
        "notitle, \\\n",
        fmt::arg("q", quoted), fmt::arg("p", patterns[i]), fmt::arg("c", i + 1));
  }
  return fmt::format(R"(set datafile separator ','
set title {title}
set logscale xy
set grid xtics ytics mxtics mytics lc rgb '#dddddd'
set key outside right top
set xlabel 'median detection time (ms), photo decoding excluded'
set ylabel 'RMS corner error against the truth (camera px)'
plot \
{plots}  'detect_bench.csv' skip 2 using 3:9:2 with labels offset 0.8,0.5 left font ',7' notitle
)",
                     fmt::arg("title", GnuplotString(title)), fmt::arg("plots", plots));
}

struct Case {
  std::string label;
  DetectOptions options;
};

}  // namespace

void BenchDetectOptions::Check() const {
  CheckCount(runs, 1, 100, "--runs");
}

void RunBenchDetect(const BenchDetectOptions& a, const fs::path& dir, std::ostream& log) {
  a.Check();
  SyntheticScene scene = FindScene(a.scene, "--scene");  // a file or an embedded scene
  if (a.uniform_display) {  // as the detect tests: no screen-door grid, finer supersampling
    scene.display.fill_factor = 1;
    scene.display.rgb_stripes = false;
    scene.optics.supersample = 4;
  }
  Renderer renderer;
  const std::string machine = DescribeMachine();
  log << fmt::format("bench detect: scene {}{} ({}x{} px camera), median of {} runs; {}\n", SceneSource(a.scene),
                     a.uniform_display ? " with a uniform display" : "", scene.camera.width,
                     scene.camera.height, a.runs, machine);
  log << fmt::format("{:<14} {:<30} {:>9} {:>9} {:>6} {:>17} {:>8} {:>8}  {}\n", "pattern", "detector",
                     "median ms", "min ms", "found", "mean px", "rms px", "max px", "failure/notes");
  std::vector<Result> results;
  std::vector<std::string> labels;
  const Eigen::Vector3d viewpoint = scene.screen_from_cam.translation;
  for (const std::string which : {"checkerboard", "square", "apriltag"}) {
    if (a.patterns.find(which) == std::string::npos) continue;
    PatternSpec spec;
    std::vector<Case> cases;
    const auto with = [](const std::string& label, const std::string& detector) {
      Case c{label, DetectOptions()};
      c.options.detector = ParseDetector(detector, "bench detect");
      return c;
    };
    if (which == "apriltag") {
      spec.kind = PatternKind::kAprilTag;
      for (int dec : {1, 2, 4}) {
        Case c = with(fmt::format("apriltag decimate {}", dec), "apriltag");
        c.options.apriltag_decimate = dec;
        cases.push_back(c);
        c.label += " unrefined";
        c.options.refine_tags = false;
        cases.push_back(c);
      }
      for (double sigma : {1.5, 3.0}) {
        Case c = with(fmt::format("apriltag decimate 2 smooth {:g}", sigma), "apriltag");
        c.options.prefilter_sigma_px = sigma;
        cases.push_back(c);
      }
      cases.push_back(with("auto", "auto"));
    } else {
      if (which == "square") {
        spec.cols = spec.rows = 11;
        cases.push_back(with("mrgingham", "mrgingham"));
      }
      cases.push_back(with("opencv-classic", "opencv-classic"));
      for (double sigma : {1.5, 3.0}) {
        Case c = with(fmt::format("opencv-classic smooth {:g}", sigma), "opencv-classic");
        c.options.prefilter_sigma_px = sigma;
        cases.push_back(c);
      }
      cases.push_back(with("opencv-sb", "opencv-sb"));
      cases.push_back(with("auto", "auto"));
    }
    const TrialDisplay display = RenderTrialDisplay(renderer, scene.monitor, viewpoint, spec);
    const Pattern& pattern = display.pattern;
    const SyntheticPhoto photo = RenderSyntheticPhoto(scene, display.image);
    const cv::Mat image = PhotoToMat(photo);
    const nlohmann::json truth_json = TruthJson(scene, pattern.features);
    std::map<std::string, Eigen::Vector2d> truth;
    for (size_t i = 0; i < pattern.features.size(); ++i) {
      const auto& t = truth_json["features"][i];
      if (t["visible"].get<bool>())
        truth[pattern.features[i].id] = {t["image_px"][0].get<double>(), t["image_px"][1].get<double>()};
    }
    PatternFile file;
    file.raw = PatternToJson(pattern, scene.monitor, viewpoint, {{"name", "exact"}});
    file.monitor = scene.monitor;
    file.viewpoint_in_screen = viewpoint;
    file.method = "exact";
    file.features = pattern.features;
    const std::string label = which == "apriltag" ? fmt::format("tags {}x{}", spec.tag_cols, spec.tag_rows)
                                                  : fmt::format("board {}x{}", spec.cols, spec.rows);
    labels.push_back(label);
    for (const Case& c : cases) {
      std::vector<double> times;
      Detection d;
      for (int r = 0; r < a.runs; ++r) {
        d = DetectFeatures(image, file, c.options);
        times.push_back(d.time_ms);
      }
      const double fastest = *std::min_element(times.begin(), times.end());
      Eigen::Vector2d mean = Eigen::Vector2d::Zero();
      double sum2 = 0, worst = 0;
      int n = 0;
      for (const DetectedFeature& f : d.features) {
        const auto it = truth.find(f.id);
        if (it == truth.end()) continue;
        const Eigen::Vector2d e = f.px - it->second;
        mean += e;
        sum2 += e.squaredNorm();
        worst = std::max(worst, e.norm());
        ++n;
      }
      if (n > 0) mean /= n;
      const double rms = n > 0 ? std::sqrt(sum2 / n) : 0;
      const double median = Median(times);
      std::string info = d.failure;
      if (info.empty() && c.options.detector == Detector::kAuto) info = "-> " + d.detector;
      for (const std::string& note : d.notes) {
        if (note.starts_with("display pixels"))
          info += (info.empty() ? "" : "; ") + note.substr(0, note.find(':'));
      }
      log << fmt::format("{:<14} {:<30} {:>9.1f} {:>9.1f} {:>6} {:>8.4f},{:>8.4f} {:>8.4f} {:>8.4f}  {}\n",
                         label, c.label, median, fastest, fmt::format("{}/{}", n, truth.size()), mean.x(),
                         mean.y(), rms, worst, info);
      Result res{label,
                 c.label,
                 d.failure,
                 median,
                 fastest,
                 n > 0 ? rms : NAN,
                 n > 0 ? worst : NAN,
                 mean,
                 n,
                 static_cast<int>(truth.size())};
      results.push_back(res);
    }
  }
  MarkParetoFronts(results);
  log << "Pareto front (per pattern: no other detector is both faster and more accurate):";
  for (const Result& r : results) {
    if (r.pareto)
      log << fmt::format(" [{}: {} {:.1f} ms, {:.4f} px]", r.pattern, r.detector, r.median_ms, r.rms_px);
  }
  log << "\n";
  std::string csv =
      fmt::format("# curvecheck bench detect, scene {}, {} runs; {}\n", a.scene, a.runs, machine);
  csv += "pattern,detector,median_ms,min_ms,found,visible,mean_x_px,mean_y_px,rms_px,max_px,failure,pareto\n";
  const auto num = [](double v) { return std::isfinite(v) ? fmt::format("{:.5f}", v) : std::string(); };
  for (const Result& r : results) {
    csv += fmt::format("{},{},{:.3f},{:.3f},{},{},{:.5f},{:.5f},{},{},\"{}\",{}\n", r.pattern, r.detector,
                       r.median_ms, r.min_ms, r.found, r.visible, r.mean.x(), r.mean.y(), num(r.rms_px),
                       num(r.max_px), r.failure, r.pareto ? 1 : 0);
  }
  WriteFileAtomic(dir / "detect_bench.csv", csv);
  const std::string title =
      fmt::format("detectors on a synthetic photo of {}: time vs corner error (median of {} runs)\n{}",
                  a.scene, a.runs, machine);
  WriteGnuplotChart(dir / "detect_bench.png", ChartScript(title, labels), {1400, 900});
  log << fmt::format("wrote {}, {} and {}\n", (dir / "detect_bench.csv").string(),
                     (dir / "detect_bench.png").string(), (dir / "detect_bench.gp").string());
}

}  // namespace curvecheck::experiments
