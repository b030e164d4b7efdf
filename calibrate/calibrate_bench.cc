// Calibration speed (issue 5 item 7): wall time of detection (all photos, in parallel) and of optimization (every
// candidate lens model, with cross-validation) on a synthetic set of 24 MP photos of a flat monitor.
//
//   build/calibrate/calibrate_bench [--views 30] [--width 6000 --height 4000] [--dir DIR] [--runs 3]
//
// The photos are rendered once into DIR (kept: rendering is not what is measured) and read back from PNG by the
// detection, as `curvecheck calibrate` does. Prints the machine, each run, the median of `runs` runs of each
// stage and the candidate table. Timings on the shared 2-core machine depend on its load: quote them with it.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <thread>

#include "calibrate/calibrate.h"
#include "synth/synthetic_board.h"
#include "core/error.h"
#include "core/stats.h"
#include "core/stopwatch.h"

namespace {
namespace fs = std::filesystem;
using namespace curvecheck;

int Run(int argc, char** argv) {
  int views = 30, width = 6000, height = 4000, runs = 3;
  fs::path dir = fs::temp_directory_path() / "curvecheck-calibrate-bench";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--views") views = std::stoi(v);
    else if (k == "--width") width = std::stoi(v);
    else if (k == "--height") height = std::stoi(v);
    else if (k == "--runs") runs = std::stoi(v);
    else if (k == "--dir") dir = v;
    else throw Error(k, "unknown option", "use --views, --width, --height, --runs, --dir");
  }
  // The default 24 MP camera of the synthetic scenes (datasets/cameras/default-24mp-opencv8.cameramodel),
  // scaled to the requested imager.
  const double s = width / 6000.0;
  SyntheticBoardOptions o;
  o.camera.lensmodel = "LENSMODEL_OPENCV8";
  o.camera.width = width;
  o.camera.height = height;
  o.camera.intrinsics = {5000 * s, 5000 * s, (width - 1) / 2.0, (height - 1) / 2.0,
                         -0.05, 0.02, 0.0002, -0.0002, -0.005, 0.001, 0.001, -0.001};
  o.views = views;
  o.corners_x = 14;
  o.corners_y = 9;
  o.square_display_px = 64;
  o.blur_px = 1.0 * s;
  o.supersample = 1;
  fs::create_directories(dir);
  std::vector<fs::path> photos;
  for (int k = 0; k < views; ++k) photos.push_back(dir / fmt::format("view{:02d}.png", k));
  const bool cached = std::all_of(photos.begin(), photos.end(), [](const fs::path& p) { return fs::exists(p); });
  BoardSpec board;
  board.corners_x = o.corners_x;
  board.corners_y = o.corners_y;
  board.square_mm = o.square_display_px * o.pixel_pitch_mm;
  board.source = "bench";
  if (!cached) {
    std::cout << fmt::format("rendering {} synthetic {}x{} photos into {} (once)...\n", views, width, height, dir.string())
              << std::flush;
    const Stopwatch watch;
    const SyntheticBoardSet set = MakeSyntheticBoardSet(o);
    for (int k = 0; k < views; ++k) cv::imwrite(photos[static_cast<size_t>(k)].string(), set.views[static_cast<size_t>(k)].photo);
    std::cout << fmt::format("  rendered in {:.0f} s\n", watch.Seconds());
  }
  std::cout << fmt::format("machine: {} hardware threads; {} photos {}x{}, board {}x{}\n",
                           std::thread::hardware_concurrency(), views, width, height, board.corners_x, board.corners_y);
  std::vector<double> detect_s, optimize_s;
  CalibrationResult last;
  for (int run = 0; run < runs; ++run) {
    const Stopwatch watch;
    const CalibrationPhotos d = DetectCalibrationPhotos(photos, board, ChessboardOptions());  // as the command
    detect_s.push_back(watch.Seconds());
    int found = 0;
    for (const ChessboardDetection& x : d.detections) found += x.found ? 1 : 0;
    last = Calibrate(d, board, CalibrateOptions());
    optimize_s.push_back(last.optimize_s);
    std::cout << fmt::format("run {}: detection {:.2f} s ({} of {} found), optimization {:.2f} s\n", run + 1,
                             detect_s.back(), found, views, optimize_s.back())
              << std::flush;
  }
  std::cout << CandidateTable(last);
  std::cout << fmt::format("median of {} runs: detection {:.2f} s wall for {} photos (parallel), optimization {:.2f} s wall "
                           "(3 candidates x 3 solves incl. cross-validation, uncertainty, Python start)\n",
                           runs, Median(detect_s), views, Median(optimize_s));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "calibrate_bench: " << e.what() << "\n";
    return 1;
  }
}
