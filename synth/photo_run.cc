// `curvecheck capture synth` once its options are parsed (photo_run.h).
#include "synth/photo_run.h"

#include <fmt/format.h>

#include <filesystem>
#include <ostream>

#include "core/camera_model.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/output_paths.h"
#include "core/path_check.h"
#include "pattern/pattern_json.h"
#include "synth/synthetic_camera.h"

namespace curvecheck {
namespace fs = std::filesystem;

void TakeSyntheticPhoto(const SynthPhotoRequest& a, std::ostream& log) {
  const fs::path out = a.output;
  if (out.extension() != ".png" && out.extension() != ".jpg") {
    throw Error("-o", fmt::format("'{}' does not end in .png or .jpg", a.output),
                "write e.g. -o photo.png (or photo.jpg: the realistic chain's JPEG itself)");
  }
  fs::path truth_path = fs::path(out).replace_extension(".truth.json");
  // The photo's camera model (mrcal format, the scene's lens at --scale): what `analyze --camera` needs next.
  const fs::path model_path = fs::path(out).replace_extension(".cameramodel");
  const fs::path pattern_json = fs::path(a.display).replace_extension(".json");
  SyntheticScene scene = LoadScene(a.scene, a.overrides);
  if (a.scale) scene.camera = ScaledCamera(scene.camera, *a.scale);
  RequireFile(a.display);  // before its pattern.json: a missing display or a link loop is named as itself
  // Every file read (the scene's camera model too) against every file written, and the outputs writable, before
  // the ray tracing. `--display X.truth.png -o X.png` names the display's pattern.json (X.truth.json) as the
  // photo's truth: the truth then takes the photo's whole file name, X.png.truth.json (said on stdout).
  std::vector<fs::path> inputs = {a.scene, a.display, pattern_json};
  if (!scene.camera_model_path.empty()) {
    const fs::path model = scene.camera_model_path;
    inputs.push_back(model.is_relative() ? fs::path(a.scene).parent_path() / model : model);
  }
  std::string truth_note;
  if (IsAnInput(truth_path, inputs)) {
    truth_note = fmt::format("note: {} is an input of this command, so the truth is written as {}\n",
                             truth_path.string(), out.string() + ".truth.json");
    truth_path = out.string() + ".truth.json";
  }
  const std::vector<NamedOutput> outputs = {
      {"-o", out}, {"the truth beside -o", truth_path}, {"the camera model beside -o", model_path}};
  CheckOutputs(outputs, inputs);
  for (const NamedOutput& o : outputs) CheckWritable(o.path);
  const PatternFile pattern = ReadPatternJson(pattern_json);
  if (pattern.monitor.width_px != scene.monitor.width_px || pattern.monitor.height_px != scene.monitor.height_px) {
    throw Error(pattern_json.string(),
                fmt::format("was rendered for {}x{} px but the scene's monitor is {}x{}", pattern.monitor.width_px,
                            pattern.monitor.height_px, scene.monitor.width_px, scene.monitor.height_px),
                "render the pattern for the scene's monitor");
  }
  const Image8 display = ReadImage8(a.display);
  if (display.width != scene.monitor.width_px || display.height != scene.monitor.height_px) {
    throw Error(a.display,
                fmt::format("is {}x{} px but the scene's monitor is {}x{} px", display.width, display.height,
                            scene.monitor.width_px, scene.monitor.height_px),
                "show the PNG that render wrote for this monitor");
  }
  CheckPatternBelongsToImage(pattern, pattern_json, a.display, display);
  const SyntheticPhoto photo = RenderSyntheticPhoto(scene, display, a.ray_grid_px);
  nlohmann::json truth = TruthJson(scene, pattern.features);
  truth["scene"] = a.scene;
  truth["display_image"] = a.display;
  truth["pattern_json"] = pattern_json.string();
  truth["photo"] = out.filename().string();
  truth["scene_overrides"] = a.overrides;
  truth["imager_scale"] = a.scale.value_or(1.0);
  truth["camera_model_file"] = model_path.filename().string();
  // The photo, its truth and its camera model as one set (core/file_io.h OutputSet): never a new photo beside an
  // old truth.
  OutputSet set;
  set.WriteWith(out, [&](const fs::path& staged) { WriteSyntheticPhoto(staged, photo); });
  set.Write(truth_path, truth.dump(1) + "\n");
  set.WriteWith(model_path, [&](const fs::path& staged) { WriteCameraModel(staged, scene.camera); });
  set.Publish();
  log << truth_note;
  int visible = 0;
  for (const auto& f : truth["features"]) visible += f["visible"].get<bool>() ? 1 : 0;
  const PhotoTiming& t = photo.timing;
  log << fmt::format(
      "{} x {} px, {} rays in {:.0f} ms ({:.1f} M rays/s traced; CPU {:.0f} ms on {} threads): rays {:.0f} ms, "
      "trace {:.0f} ms, optics {:.0f} ms, sensor {:.0f} ms\n{} of {} features visible\nwrote {}, {} and {} (the "
      "photo's camera model: give it to analyze --camera)\n",
      photo.width, photo.height, t.rays, t.total_ms(), t.rays / (t.trace_ms * 1e3), t.total_cpu_ms(), t.threads,
      t.rays_ms, t.trace_ms, t.optics_ms, t.sensor_ms, visible, truth["features"].size(), out.string(),
      truth_path.string(), model_path.string());
}

}  // namespace curvecheck
