// Scenes by name or by file (issue 14): the embedded datasets (datasets/dataset_files.h) are read from the
// binary, never written out to be found, so that a command works from any folder and leaves nothing behind.
#pragma once

#include <string>
#include <vector>

#include "synth/synthetic_camera.h"

namespace curvecheck::experiments {

// The names of the embedded scenes ("default", "off-axis", ...: datasets/scenes/<name>.yaml), sorted.
std::vector<std::string> EmbeddedSceneNames();

// "a scene YAML, or an embedded scene: bulge-2mm, close, default, ...": what a --scene option takes, for its help.
std::string SceneOptionHelp();

// True when `name` is an embedded scene.
bool IsEmbeddedScene(const std::string& name);

// The embedded scene `name`, its camera model read from the embedded datasets at the path the scene names
// (relative to datasets/scenes/). Throws Error naming `option` when there is no such scene.
SyntheticScene LoadEmbeddedScene(const std::string& name, const std::string& option);

// `name_or_path`: a scene file when one exists at that path, else the name of an embedded scene. Throws Error
// naming `option` when it is neither (the message lists the embedded names), or what LoadScene throws for a
// bad file.
SyntheticScene FindScene(const std::string& name_or_path, const std::string& option);

// Where FindScene found a scene, for provenance: the path as given, or "embedded scene <name>".
std::string SceneSource(const std::string& name_or_path);

}  // namespace curvecheck::experiments
