// Stability sweeps (issue 7 items 3-4). One or two factors of the scene vary over a grid (sweep_factor.h); at
// each point the trial runs (trial.h): the pattern is rendered for the stated viewpoint by a correction
// method, the synthetic camera photographs the (true) monitor showing it, and the photo is analysed from
// pixels. Each point records success, the failure reason (trial_outcome.h), the verification p95 (display
// px), the cylinder radius against the truth with its sigma, and the time of each stage; per method a failure
// map and the boundaries as text.
//
// Determinism: point k of the grid (methods outermost, then factor 1, then factor 2) always uses noise seed
// `seed` + k, and nothing else is random, so a shard (the points k with k mod n = i - 1) computes exactly the
// rows of an unsharded run, and MergeSweeps puts them back together (shards.h: the same for `bench validity`).
//
// Parallelism: points run on `jobs` worker threads; the Vulkan renderer is one instance shared by the workers
// and serialised by a mutex (lavapipe itself uses every core for a frame), with the last few renders cached
// because most factors do not change the rendered image.
#pragma once

#include <cstdint>
#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

#include "experiments/shards.h"
#include "experiments/sweep_factor.h"

namespace curvecheck::experiments {

struct SweepOptions {
  std::vector<SweepFactor> factors;  // one or two, different (ParseFactor)
  std::vector<std::string> methods;  // correction method names (render/method.h), the outermost grid loop
  std::string scene = "default";     // scene file, or the name of an embedded scene (scene_lookup.h)
  double camera_scale = 0.25;  // imager scale of the scene's camera (ScaledCamera); 0.25: 1500 x 1000 px
  int jobs = 1;                // worker threads over the points
  int shard_index = 1, shard_count = 1;  // run the points k with k mod shard_count = shard_index - 1
  int64_t seed = 1;                      // noise seed of point 0; point k uses seed + k
  std::vector<std::string> models = {"flat", "cylinder"};  // screen models to fit
  int cols = 32, rows = 9;            // checkerboard squares (unless square_px varies them)
  double tolerance_display_px = 0.5;  // verification tolerance (p95)
  std::string command_line;           // provenance in sweep.json and sweep.txt

  // Throws Error naming the option for a camera scale outside (0, 1], jobs outside 1..256, a tolerance that is
  // not positive, a negative seed, cols or rows outside 2..1000, a shard outside 1..shard_count, or unknown
  // screen models.
  void Check() const;
};

// Runs this shard of the sweep and writes sweep.csv, sweep.json, sweep.txt and the charts
// (sweep-<method>.png, .gp, .dat) into `out`, an existing writable folder (scratch files go to
// out/.sweep-scratch-<i> and are removed). Progress lines and the summary go to `log`. Throws Error for an
// unknown scene.
void RunSweep(const SweepOptions& options, const std::filesystem::path& out, std::ostream& log);

// What a sweep's shard folder holds (shards.h): sweep.json, sweep.csv. For ShardDirs and ReadShards.
const ShardFiles& SweepShardFiles();

// Merges the shards in `dirs` (ShardDirs) into `out` as one sweep (the same outputs as RunSweep). Throws
// Error naming the file for an unreadable shard, shards of different sweeps, or overlapping shards.
void MergeSweeps(const std::vector<std::filesystem::path>& dirs, const std::filesystem::path& out,
                 const std::string& command_line, std::ostream& log);

}  // namespace curvecheck::experiments
