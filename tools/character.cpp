#include "tools/character.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "geometry/obj_io.h"
#include "geometry/pc2_writer.h"
#include "physics/pressure.h"

namespace pd::tools {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The bones, parents before children.
enum Bone { Root, Pelvis, Torso, UpperArmL, ForearmL, UpperArmR, ForearmR, ThighL, ShinL, ThighR, ShinR, kBones };

struct Capsule {
  Vec3 a, b;     // segment ends in the rest pose, m
  double radius;  // m
  Bone bone;
};

// The rest pose. Left is +x. Arms hang slightly away from the body and the legs stand apart, so a
// skirt around the hips clears both.
const std::vector<Capsule>& capsules() {
  static const std::vector<Capsule> list = {
      {{-0.06, 0.95, 0}, {0.06, 0.95, 0}, 0.13, Pelvis},
      {{0, 1.08, 0}, {0, 1.32, 0}, 0.12, Torso},
      {{0, 1.53, 0}, {0, 1.57, 0}, 0.09, Torso},  // the head
      {{0.21, 1.36, 0}, {0.29, 1.10, 0}, 0.045, UpperArmL},
      {{0.29, 1.10, 0}, {0.35, 0.86, 0}, 0.04, ForearmL},
      {{-0.21, 1.36, 0}, {-0.29, 1.10, 0}, 0.045, UpperArmR},
      {{-0.29, 1.10, 0}, {-0.35, 0.86, 0}, 0.04, ForearmR},
      {{0.09, 0.90, 0}, {0.10, 0.52, 0}, 0.07, ThighL},
      {{0.10, 0.52, 0}, {0.10, 0.10, 0}, 0.055, ShinL},
      {{-0.09, 0.90, 0}, {-0.10, 0.52, 0}, 0.07, ThighR},
      {{-0.10, 0.52, 0}, {-0.10, 0.10, 0}, 0.055, ShinR},
  };
  return list;
}

// Quintic ease 0 -> 1 over [0, 1] with zero velocity and acceleration at both ends.
double smootherstep(double s) {
  s = std::clamp(s, 0.0, 1.0);
  return s * s * s * (s * (6 * s - 15) + 10);
}

Eigen::Isometry3d turn_about(const Vec3& pivot, const Vec3& axis, double angle) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translate(pivot);
  t.rotate(Eigen::AngleAxisd(angle, axis));
  t.translate(-pivot);
  return t;
}

// Every bone's placement at time t relative to the rest pose (world = pose * rest).
std::array<Eigen::Isometry3d, kBones> pose(double t, double seconds) {
  const double deg = kPi / 180.0;
  const double ease = smootherstep(t / 0.4);         // every joint curve eases in over 0.4 s
  const double phase = 2.0 * kPi * t / seconds;       // one swing cycle over the shot
  const double swing = std::sin(2.0 * phase) * ease;  // two steps in place over the shot
  const double turn = std::sin(phase) * ease;
  std::array<Eigen::Isometry3d, kBones> p;
  // A step forward of 0.2 m over the middle half of the shot.
  p[Root] = Eigen::Isometry3d::Identity();
  p[Root].translate(Vec3(0, 0, 0.2 * smootherstep((t - 0.25 * seconds) / (0.5 * seconds))));
  const Vec3 up(0, 1, 0), side(1, 0, 0);
  p[Pelvis] = p[Root] * turn_about(Vec3(0, 0.95, 0), up, 8 * deg * turn);
  p[Torso] = p[Pelvis] * turn_about(Vec3(0, 1.05, 0), up, 14 * deg * turn);
  // Arms swing against the legs; a negative angle about +x carries a hanging limb forward (+z).
  p[UpperArmL] = p[Torso] * turn_about(Vec3(0.21, 1.36, 0), side, 25 * deg * swing);
  p[ForearmL] = p[UpperArmL] * turn_about(Vec3(0.29, 1.10, 0), side, -20 * deg * ease);
  p[UpperArmR] = p[Torso] * turn_about(Vec3(-0.21, 1.36, 0), side, -25 * deg * swing);
  p[ForearmR] = p[UpperArmR] * turn_about(Vec3(-0.29, 1.10, 0), side, -20 * deg * ease);
  p[ThighL] = p[Pelvis] * turn_about(Vec3(0.09, 0.90, 0), side, -20 * deg * swing);
  p[ShinL] = p[ThighL] * turn_about(Vec3(0.10, 0.52, 0), side, 30 * deg * std::max(0.0, swing));
  p[ThighR] = p[Pelvis] * turn_about(Vec3(-0.09, 0.90, 0), side, 20 * deg * swing);
  p[ShinR] = p[ThighR] * turn_about(Vec3(-0.10, 0.52, 0), side, 30 * deg * std::max(0.0, -swing));
  return p;
}

// A closed capsule mesh around segment a-b: a pole, `rings` latitude rings of `segments` vertices
// each over both hemispheres, the other pole. Faces wound outward.
void add_capsule(const Capsule& c, int segments, TriMesh& mesh, std::vector<int>& bone_of) {
  const Vec3 u = (c.b - c.a).normalized();
  Vec3 e1 = u.unitOrthogonal(), e2 = u.cross(e1);
  const int half = std::max(2, segments / 4);  // latitude rings per hemisphere, equator included
  std::vector<Vec3> points = {c.a - c.radius * u};
  for (int i = 1; i <= half; ++i) {  // from pole a to the equator at a
    const double phi = 0.5 * kPi * i / half;
    for (int k = 0; k < segments; ++k) {
      const double th = 2.0 * kPi * k / segments;
      points.push_back(c.a - c.radius * std::cos(phi) * u + c.radius * std::sin(phi) * (std::cos(th) * e1 + std::sin(th) * e2));
    }
  }
  for (int i = 0; i < half; ++i) {  // from the equator at b to pole b
    const double psi = 0.5 * kPi * i / half;
    for (int k = 0; k < segments; ++k) {
      const double th = 2.0 * kPi * k / segments;
      points.push_back(c.b + c.radius * std::sin(psi) * u + c.radius * std::cos(psi) * (std::cos(th) * e1 + std::sin(th) * e2));
    }
  }
  points.push_back(c.b + c.radius * u);
  const int first = static_cast<int>(mesh.V.rows()), rings = 2 * half;
  const int pole_b = static_cast<int>(points.size()) - 1;
  std::vector<std::array<int, 3>> faces;
  const auto ring = [&](int r, int k) { return 1 + r * segments + (k % segments); };
  for (int k = 0; k < segments; ++k) faces.push_back({0, ring(0, k + 1), ring(0, k)});
  for (int r = 0; r + 1 < rings; ++r)
    for (int k = 0; k < segments; ++k) {
      faces.push_back({ring(r, k), ring(r, k + 1), ring(r + 1, k + 1)});
      faces.push_back({ring(r, k), ring(r + 1, k + 1), ring(r + 1, k)});
    }
  for (int k = 0; k < segments; ++k) faces.push_back({pole_b, ring(rings - 1, k), ring(rings - 1, k + 1)});
  // Wind outward: the orientation e1, e2 give may be either way round.
  Eigen::VectorXd x(3 * static_cast<Eigen::Index>(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i) x.segment<3>(3 * static_cast<Eigen::Index>(i)) = points[i];
  Faces F(static_cast<Eigen::Index>(faces.size()), 3);
  for (std::size_t f = 0; f < faces.size(); ++f) F.row(static_cast<Eigen::Index>(f)) << faces[f][0], faces[f][1], faces[f][2];
  if (enclosed_volume(F, x) < 0) F.col(1).swap(F.col(2));
  mesh.V.conservativeResize(first + static_cast<Eigen::Index>(points.size()), 3);
  for (std::size_t i = 0; i < points.size(); ++i) mesh.V.row(first + static_cast<Eigen::Index>(i)) = points[i].transpose();
  const Eigen::Index f0 = mesh.F.rows();
  mesh.F.conservativeResize(f0 + F.rows(), 3);
  mesh.F.bottomRows(F.rows()) = F.array() + first;
  bone_of.insert(bone_of.end(), points.size(), c.bone);
}

// The skirt: an A-line cone frustum from the waist (y = 1.07 m, radius 0.15 m: 3 cm clear of the torso
// and the pelvis) to the hem (y = 0.62 m, radius 0.43 m: 3.5 cm clear of the hips' sides, room for
// the coarser levels' chords, which cut inside the cone), quads split along alternating diagonals;
// normals point outward. Its waistband (0.94 m round) is 12 % shorter than the hips' widest girth
// (1.06 m), so it settles on the hips a few centimetres lower and cannot slip over them without
// stretching that much.
TriMesh make_skirt(int around, int down) {
  TriMesh m;
  m.V.resize(static_cast<Eigen::Index>(around) * (down + 1), 3);
  for (int j = 0; j <= down; ++j) {
    const double s = static_cast<double>(j) / down;
    const double y = 1.07 - 0.45 * s, r = 0.15 + 0.28 * s;
    for (int i = 0; i < around; ++i) {
      const double th = 2.0 * kPi * i / around;
      m.V.row(j * around + i) << r * std::sin(th), y, r * std::cos(th);
    }
  }
  m.F.resize(2 * static_cast<Eigen::Index>(around) * down, 3);
  Eigen::Index f = 0;
  for (int j = 0; j < down; ++j)
    for (int i = 0; i < around; ++i) {
      const int a = j * around + i, b = j * around + (i + 1) % around, c = a + around, d = b + around;
      if ((i + j) % 2 == 0) {
        m.F.row(f++) << a, c, d;
        m.F.row(f++) << a, d, b;
      } else {
        m.F.row(f++) << a, c, b;
        m.F.row(f++) << b, c, d;
      }
    }
  return m;
}

std::vector<int> body_bones(const CharacterOptions& o) {
  TriMesh scratch;
  scratch.V.resize(0, 3);
  scratch.F.resize(0, 3);
  std::vector<int> bones;
  for (const Capsule& c : capsules()) add_capsule(c, o.segments, scratch, bones);
  return bones;
}

// The body's vertices at time t: vertex i moved by its bone bones[i].
Positions posed(const std::vector<int>& bones, const TriMesh& body, double t, double seconds) {
  const std::array<Eigen::Isometry3d, kBones> p = pose(t, seconds);
  Positions x(body.V.rows(), 3);
  for (Eigen::Index i = 0; i < x.rows(); ++i)
    x.row(i) = (p[static_cast<std::size_t>(bones[static_cast<std::size_t>(i)])] * Vec3(body.V.row(i).transpose())).transpose();
  return x;
}

}  // namespace

Positions body_at(const CharacterOptions& options, const TriMesh& body, double t) {
  const std::vector<int> bones = body_bones(options);
  if (static_cast<Eigen::Index>(bones.size()) != body.V.rows())
    throw std::invalid_argument("body_at: the mesh is not the character's at these options");
  return posed(bones, body, t, options.seconds);
}

Character make_character(const CharacterOptions& o) {
  if (o.segments < 4 || o.skirt_around < 8 || o.skirt_down < 1 || !(o.seconds > 0) || !(o.fps > 0))
    throw std::invalid_argument("make_character: segments >= 4, skirt_around >= 8, skirt_down >= 1, seconds and fps > 0");
  Character c;
  c.body.V.resize(0, 3);
  c.body.F.resize(0, 3);
  std::vector<int> bones;
  for (const Capsule& cap : capsules()) add_capsule(cap, o.segments, c.body, bones);
  const int count = static_cast<int>(std::lround(o.seconds * o.fps));
  for (int k = 0; k <= count; ++k) c.frames.push_back(posed(bones, c.body, k / o.fps, o.seconds));
  c.skirt = make_skirt(o.skirt_around, o.skirt_down);
  return c;
}

void write_shot(const Character& c, const CharacterOptions& o, const std::string& dir, const std::string& name,
                int frames, int levels) {
  std::filesystem::create_directories(dir);
  write_obj(dir + "/body_rest.obj", c.body.V, c.body.F);
  write_obj(dir + "/skirt.obj", c.skirt.V, c.skirt.F);
  Pc2Writer cache(dir + "/body.pc2", static_cast<int>(c.body.V.rows()), 0.0f, 1.0f, static_cast<int>(c.frames.size()));
  for (std::size_t k = 0; k < c.frames.size(); ++k) cache.add_sample(c.frames[k], 0, "frame " + std::to_string(k));
  cache.close();
  const nlohmann::json scene = {
      {"format_version", 1},
      {"name", name},
      {"description", "A cotton skirt (" + std::to_string(c.skirt.V.rows()) + " vertices) on a generated character (" +
                          std::to_string(c.body.V.rows()) + " vertices, tools/make_character) that turns its torso, "
                          "swings its arms and steps forward; strain limit 1.1, self-contact, friction 0.5. Generated by pd_make_character."},
      {"time_step", 0.01},
      {"frames", frames},
      {"contact", {{"dhat", 1e-3}, {"friction", 0.5}}},
      {"hierarchy", {{"levels", levels}}},
      {"objects",
       {{{"name", "skirt"},
         {"mesh", {{"type", "obj"}, {"path", "skirt.obj"}}},
         {"material", {{"preset", "cotton"}}},
         {"strain_limit", {{"limit", 1.1}}},  // woven cotton stretches little: the waistband holds on the hips
         {"self_contact", true}},
        {{"name", "body"},
         {"obstacle", true},
         {"mesh", {{"type", "obj"}, {"path", "body_rest.obj"}}},
         {"animation", {{"pc2", "body.pc2"}, {"fps", o.fps}, {"interpolation", "smooth"}}}}}}};
  std::ofstream(dir + "/" + name + ".json") << scene.dump(2) << "\n";
}

}  // namespace pd::tools
