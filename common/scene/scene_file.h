#pragma once
// Reading scene files (JSON, format_version 1) into a validated Scene. docs/scene-format.md
// documents every key, its unit and its default.
//
// Every problem in a scene file is reported as one InputError whose message names the file and the
// JSON key path, e.g.
//   "scenes/flag.json: objects[0].material.thickness: must be > 0, got -0.001"
//   "scenes/flag.json:12:7: invalid JSON: syntax error while parsing object - unexpected '}'; ..."
// Nothing is defaulted silently: only the optional keys listed in the documentation have defaults,
// and unknown keys are errors (with a "did you mean" suggestion when a known key is close).
#include <string>

#include "scene/scene.h"

namespace pd {

// Reads and parses the scene file at `path`. Relative OBJ paths inside the scene resolve against the
// folder that holds the scene file. Throws InputError (also when the file cannot be read).
Scene load_scene(const std::string& path);

// Parses scene JSON text. `path_for_messages` names the file in error messages and becomes
// Scene::source_path; `base_dir` is the folder that relative OBJ paths resolve against ("" = the
// current directory). Throws InputError.
Scene parse_scene(const std::string& json_text, const std::string& path_for_messages,
                  const std::string& base_dir);

// Upper bound on the vertex count of any one object's mesh; larger requests are reported as errors
// before any memory is allocated (a typo such as "cells": [2000, 2000] would otherwise exhaust memory).
constexpr long long kMaxSceneMeshVertices = 2000000;
// The same for faces (a closed mesh has about 2 faces per vertex).
constexpr long long kMaxSceneMeshFaces = 4000000;
// Upper bound on the vertices of all objects together: the solver's memory grows with the total
// (about 1 KB per vertex of Hessian and factor, more with contact), so 4 000 000 is a few GB.
constexpr long long kMaxSceneVertices = 4000000;

}  // namespace pd
