#pragma once
// Scenes from YAML (configs/scenes/*.yaml; the keys are in render/README.md). Strict like every iapsim
// config: unknown keys, wrong types and values out of range are bridge::ConfigError with file, line and key.

#include <string>

#include "bridge/config.h"
#include "render/scene.h"

namespace iapsim::render {

/// Reads a scene description from `map` (a scene file's root, or a section of another file). Mesh and
/// texture files are relative to the map's file. A mesh or texture that cannot be read fails naming the
/// YAML file, line and key and the file itself.
Scene ReadScene(bridge::YamlMap& map);

/// Loads a scene file.
Scene LoadScene(const std::string& path);

}  // namespace iapsim::render
