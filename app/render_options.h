// Command-line options shared by `render`, `pattern` and `bench render`: monitor, viewpoint, pattern, method
// (render/scene_args.h resolves them).
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>

#include "render/scene_args.h"

namespace curvecheck::app {

void AddSceneOptions(CLI::App& cmd, SceneArgs& args, const std::string& default_viewpoint_help);
// --distance-mm and --offset-mm beside a command's --viewpoint option (which they exclude): for every command
// that takes a viewpoint.
void AddDistanceOptions(CLI::App& cmd, CLI::Option* viewpoint, std::optional<double>& distance_mm,
                        std::optional<std::string>& offset_mm);
void AddMethodOptions(CLI::App& cmd, MethodArgs& args);

}  // namespace curvecheck::app
