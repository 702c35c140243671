#pragma once
// A character of our own for garment shots (issue 46 item 3): an articulated body of capsules (pelvis,
// torso, head, upper and lower arms and legs), animated by a few keyframe-free joint curves (the
// torso turns, the arms swing, the legs step in place while the body steps forward), and a skirt
// around its hips. No third-party assets: everything here is generated.
//
// Units metres and seconds; y up, the character faces +z, its feet at y = 0. The body is one mesh
// of closed capsules; capsules overlap at the joints and may pass through each other as the limbs
// move (an obstacle's own crossings are allowed, as in captured bodies). Each capsule follows its
// bone rigidly (rigid skinning). At t = 0 every joint is at rest and every joint speed is zero (the
// curves ease in), so a garment can start at rest.
#include <string>
#include <vector>

#include "geometry/mesh.h"

namespace pd::tools {

struct CharacterOptions {
  int segments = 12;         // vertices around each capsule (>= 4)
  int skirt_around = 64;     // skirt vertices around (>= 8)
  int skirt_down = 40;       // skirt rows of faces from waist to hem (>= 1)
  double seconds = 2.0;      // length of the animation, s
  double fps = 30.0;         // cache frames per second
};

struct Character {
  TriMesh body;                   // the rest pose (t = 0)
  std::vector<Positions> frames;  // the body's vertices at cache frames k / fps, k = 0 .. seconds * fps
  TriMesh skirt;                  // the garment's rest shape: an open cone frustum around the hips
};

Character make_character(const CharacterOptions& options);

// The body's vertices at time t (s): the rest mesh's vertices moved by their bones.
Positions body_at(const CharacterOptions& options, const TriMesh& body, double t);

// Writes a complete shot into `dir` (created): body_rest.obj, body.pc2 (the cache at options.fps),
// skirt.obj and <name>.json, a scene of the skirt (cotton, strain limit 1.1, self-contact, friction
// 0.5 against the body) on the walking body, `frames` frames of 1/100 s, `levels` hierarchy levels.
void write_shot(const Character& c, const CharacterOptions& options, const std::string& dir, const std::string& name,
                int frames, int levels);

}  // namespace pd::tools
