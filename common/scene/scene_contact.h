#pragma once
// Readers for the contact sections of a scene file (internal to common/scene): the top-level
// "contact" and "ground" sections and an object's "strain_limit". docs/scene-format.md lists the
// keys; every reader throws InputError naming the file and key path.
#include <vector>

#include "scene/scene.h"
#include "scene/scene_json.h"

namespace pd::scene_json {

// "contact": {dhat, offset, ccd_ratio, friction, eps_v, pair_friction, stiffness}. Object names in
// pair_friction must name entries of `objects`.
ContactConfig read_contact(const JsonNode& node, const std::vector<SceneObject>& objects);

// "ground": {height, normal, friction}.
Ground read_ground(const JsonNode& node);

// An object's "strain_limit": {limit, barrier_start, stiffness}.
StrainLimit read_strain_limit(const JsonNode& node);

}  // namespace pd::scene_json
