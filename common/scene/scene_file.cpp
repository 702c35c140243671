#include "scene/scene_file.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <sys/stat.h>

#include <Eigen/Geometry>

#include "geometry/obj_io.h"
#include "geometry/shapes.h"
#include "geometry/topology.h"
#include "physics/pressure.h"
#include "scene/scene_contact.h"
#include "scene/scene_hierarchy_config.h"
#include "scene/scene_json.h"
#include "scene/scene_animation.h"
#include "scene/scene_mesh.h"
#include "util/input_error.h"
#include "util/message_text.h"

namespace pd {
namespace {

namespace fs = std::filesystem;
using scene_json::Json;
using scene_json::JsonNode;
using scene_json::Range;
namespace limits = scene_json::limits;

constexpr long long kFormatVersion = 1;
constexpr long long kMaxFrames = 10000000;
constexpr double kPi = 3.14159265358979323846;

// Material presets: rows of Table 1 in the PSQ supplement (progressive-shell-quasistatics-2023),
// see docs/scene-format.md. The table lists E_bend = E_mem for these rows, so presets leave
// bending_youngs_modulus unset (it then follows youngs_modulus).
struct MaterialPreset {
  const char* name;
  double density, youngs_modulus, poisson_ratio, thickness;
};
constexpr MaterialPreset kPresets[] = {
    {"cotton", 472.6, 8.21e5, 0.243, 3.18e-4},   // "Hat on sphere" (the table's cloth rows)
    {"rubber", 920.0, 1.0e5, 0.45, 5.0e-5},      // "Monster" (inflatable shell)
    {"aluminum", 2710.0, 7.0e10, 0.33, 1.0e-5},  // "Soda can"
};

std::string format_vec(const Vec3& v) {
  return "[" + number_for_message(v.x()) + ", " + number_for_message(v.y()) + ", " + number_for_message(v.z()) + "]";
}

int as_int(long long v) { return static_cast<int>(v); }

// x -> R (scale x) + translation
struct Transform {
  double scale = 1.0;
  Mat3 rotation = Mat3::Identity();
  Vec3 translation = Vec3::Zero();

  void apply(Positions& V) const {
    for (Eigen::Index i = 0; i < V.rows(); ++i) {
      Vec3 x = V.row(i).transpose();
      V.row(i) = (rotation * (scale * x) + translation).transpose();
    }
  }
};

Transform read_transform(const JsonNode& node) {
  node.expect_keys({"scale", "rotation", "translation"});
  Transform t;
  if (auto s = node.optional("scale")) t.scale = s->in_range(limits::kScale);
  if (auto r = node.optional("rotation")) {
    r->expect_keys({"axis", "angle_deg"});
    const Vec3 axis = r->required("axis").direction();
    double angle = r->required("angle_deg").in_range(limits::kAngleDeg);
    t.rotation = Eigen::AngleAxisd(angle * kPi / 180.0, axis).toRotationMatrix();
  }
  if (auto tr = node.optional("translation")) t.translation = tr->vec3_in(limits::kPosition);
  return t;
}

Positions read_posed(const JsonNode& node, const TriMesh& rest, const std::string& rest_path,
                     const std::string& base_dir) {
  node.expect_keys({"obj"});
  JsonNode obj = node.required("obj");
  TriMesh posed = read_obj_at(obj, base_dir);
  const std::string same = "; initial_positions must have the same connectivity as the rest mesh " +
                           rest_path + " (same vertices and faces, in the same order)";
  if (posed.num_vertices() != rest.num_vertices()) {
    obj.fail("has " + std::to_string(posed.num_vertices()) + " vertices but the rest mesh has " +
             std::to_string(rest.num_vertices()) + same);
  }
  if (posed.num_faces() != rest.num_faces()) {
    obj.fail("has " + std::to_string(posed.num_faces()) + " faces but the rest mesh has " +
             std::to_string(rest.num_faces()) + same);
  }
  for (int f = 0; f < rest.num_faces(); ++f) {
    if (posed.F.row(f) != rest.F.row(f)) {
      obj.fail("face " + std::to_string(f) + " differs from the rest mesh's face " + std::to_string(f) + same);
    }
  }
  if (!posed.V.allFinite()) obj.fail("has non-finite vertex coordinates");
  return posed.V;
}

Material read_material(const JsonNode& node) {
  node.expect_keys(
      {"preset", "density", "youngs_modulus", "poisson_ratio", "thickness", "bending_youngs_modulus", "bending_model"});
  const MaterialPreset* preset = nullptr;
  if (auto p = node.optional("preset")) {
    std::string name = p->choice({"cotton", "rubber", "aluminum"}, "material preset");
    for (const MaterialPreset& candidate : kPresets) {
      if (name == candidate.name) preset = &candidate;
    }
  }
  // A core key: read and checked when given, else from the preset, else an error.
  auto core = [&](const char* key, double preset_value, auto check) -> double {
    if (auto v = node.optional(key)) return check(*v);
    if (preset) return preset_value;
    throw InputError(node.file() + ": " + node.child_path(key) +
                     ": required key is missing (give it, or a \"preset\")");
  };
  auto within = [](const Range& range) { return [range](const JsonNode& v) { return v.in_range(range); }; };
  Material m;
  m.density = core("density", preset ? preset->density : 0.0, within(limits::kDensity));
  m.youngs_modulus = core("youngs_modulus", preset ? preset->youngs_modulus : 0.0, within(limits::kYoungsModulus));
  m.poisson_ratio = core("poisson_ratio", preset ? preset->poisson_ratio : 0.0, [](const JsonNode& v) {
    double nu = v.number();
    if (!(nu >= 0.0 && nu < 0.5)) v.fail_got("must be >= 0 and < 0.5");
    return nu;
  });
  m.thickness = core("thickness", preset ? preset->thickness : 0.0, within(limits::kThickness));
  if (auto eb = node.optional("bending_youngs_modulus")) m.bending_youngs_modulus = eb->in_range(limits::kBendingModulus);
  if (auto b = node.optional("bending_model"))
    m.bending_model = b->choice({"midedge_fit", "hinge"}, "bending model") == "hinge" ? BendingModel::Hinge
                                                                                  : BendingModel::MidedgeFit;
  return m;
}

// "keyframes": [{"time", "translation", "rotation": {"axis", "angle_deg"}}, ...], times increasing.
std::vector<Keyframe> read_keyframes(const JsonNode& node) {
  std::vector<Keyframe> keys;
  for (const JsonNode& k : node.elements()) {
    k.expect_keys({"time", "translation", "rotation"});
    Keyframe key;
    JsonNode time = k.required("time");
    key.time = time.in_range(limits::kTime);
    if (!keys.empty() && !(key.time > keys.back().time))
      time.fail_got("must be later than the previous keyframe's time (" + number_for_message(keys.back().time) + ")");
    if (auto tr = k.optional("translation")) key.translation = tr->vec3_in(limits::kPosition);
    if (auto r = k.optional("rotation")) {
      r->expect_keys({"axis", "angle_deg"});
      const Vec3 axis = r->required("axis").direction();
      const double angle = r->required("angle_deg").in_range(limits::kAngleDeg);
      key.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(angle * kPi / 180.0, axis));
    }
    keys.push_back(key);
  }
  if (keys.empty()) node.fail_got("must list at least one keyframe");
  // The motion starts from the initial pose: an implicit identity keyframe at t = 0, and a first
  // keyframe at t = 0 must be the identity (anything else would teleport the vertices at t = 0).
  if (keys.front().time > 0.0) {
    keys.insert(keys.begin(), Keyframe{});
  } else if (!keys.front().translation.isZero(0.0) || !keys.front().rotation.coeffs().isApprox(Keyframe{}.rotation.coeffs(), 0.0)) {
    node.elements().front().fail("is at time 0 but not the initial pose (zero translation and rotation): the motion "
                                 "would jump at the first step");
  }
  return keys;
}

PinScript read_script(const JsonNode& node) {
  node.expect_keys({"velocity", "angular_velocity", "center", "start", "end", "keyframes"});
  PinScript s;
  if (auto k = node.optional("keyframes")) {
    for (const char* key : {"velocity", "angular_velocity", "center", "start", "end"})
      if (auto other = node.optional(key)) other->fail("cannot be combined with \"keyframes\"");
    s.keyframes = read_keyframes(*k);
    return s;
  }
  if (auto v = node.optional("velocity")) s.velocity = v->vec3_length_at_most(limits::kMaxSpeed, "m/s");
  if (auto w = node.optional("angular_velocity"))
    s.angular_velocity = w->vec3_length_at_most(limits::kMaxAngularSpeed, "rad/s");
  if (auto c = node.optional("center")) s.center = c->vec3_in(limits::kPosition);
  if (auto a = node.optional("start")) s.start = a->in_range(limits::kTime);
  if (auto b = node.optional("end")) {
    s.end = b->in_range(limits::kTime);
    if (!(s.end > s.start)) b->fail_got("must be > start (" + number_for_message(s.start) + ")");
  }
  return s;
}

std::vector<int> select_in_region(const JsonNode& region, const Positions& initial) {
  region.expect_keys({"min", "max"});
  Vec3 lo = region.required("min").vec3_in(limits::kRegion);
  Vec3 hi = region.required("max").vec3_in(limits::kRegion);
  if (!(lo.array() <= hi.array()).all()) {
    region.fail("min must be <= max on every axis, got min " + format_vec(lo) + " and max " + format_vec(hi));
  }
  std::vector<int> selected;
  for (Eigen::Index i = 0; i < initial.rows(); ++i) {
    Vec3 x = initial.row(i).transpose();
    if ((x.array() >= lo.array()).all() && (x.array() <= hi.array()).all()) selected.push_back(static_cast<int>(i));
  }
  if (selected.empty()) {
    Vec3 bmin = initial.colwise().minCoeff().transpose(), bmax = initial.colwise().maxCoeff().transpose();
    region.fail("selects no vertex: no initial vertex position lies in the box min " + format_vec(lo) + ", max " +
                format_vec(hi) + " (the object's initial positions span " + format_vec(bmin) + " to " +
                format_vec(bmax) + ", after its transform)");
  }
  return selected;
}

std::vector<PinGroup> read_pins(const JsonNode& node, const Positions& initial, const std::string& object_path) {
  std::vector<PinGroup> groups;
  const int n = static_cast<int>(initial.rows());
  std::vector<int> owner(n, -1);
  const std::vector<JsonNode> pins = node.elements();
  if (static_cast<long long>(pins.size()) > limits::kMaxPinGroups) {
    node.fail_got("lists more than " + std::to_string(limits::kMaxPinGroups) + " pin groups");
  }
  for (const JsonNode& pin : pins) {
    pin.expect_keys({"indices", "region", "script"});
    auto indices = pin.optional("indices");
    auto region = pin.optional("region");
    if (indices && region) pin.fail("give either \"indices\" or \"region\", not both");
    if (!indices && !region) pin.fail("needs \"indices\" or \"region\" to select vertices");
    PinGroup group;
    if (indices) {
      auto list = indices->elements();
      if (list.empty()) indices->fail_got("must list at least one vertex index");
      for (const JsonNode& e : list) {
        long long v = e.integer(LLONG_MIN / 2, LLONG_MAX / 2);
        if (v < 0 || v >= n) {
          e.fail_got("vertex index out of range: the mesh has " + std::to_string(n) + " vertices (0 to " +
                     std::to_string(n - 1) + ")");
        }
        group.vertices.push_back(static_cast<int>(v));
      }
      std::sort(group.vertices.begin(), group.vertices.end());
      group.vertices.erase(std::unique(group.vertices.begin(), group.vertices.end()), group.vertices.end());
    } else {
      group.vertices = select_in_region(*region, initial);
    }
    const int index = static_cast<int>(groups.size());
    for (int v : group.vertices) {
      if (owner[v] >= 0) {
        pin.fail("vertex " + std::to_string(v) + " is already pinned by " + object_path + ".pins[" +
                 std::to_string(owner[v]) + "] (a vertex may belong to one pin group only)");
      }
      owner[v] = index;
    }
    if (auto script = pin.optional("script")) {
      group.script = read_script(*script);
      scene_json::check_script_speed(*script, *group.script, initial, &group.vertices);
    }
    groups.push_back(std::move(group));
  }
  return groups;
}

Pressure read_pressure(const JsonNode& node, const TriMesh& rest, const Positions& initial) {
  node.expect_keys({"model", "pressure"});
  Pressure p;
  std::string model = node.required("model").choice({"constant", "ideal_gas"}, "pressure model");
  p.model = model == "constant" ? Pressure::Model::Constant : Pressure::Model::IdealGas;
  p.pressure = node.required("pressure").in_range(limits::kPressure);
  Topology topo = build_topology(rest);
  if (!topo.closed()) {
    int boundary = 0;
    for (int count : topo.edge_face_count) boundary += (count == 1);
    node.fail("needs a closed mesh, but the object's mesh has " + std::to_string(boundary) +
              " boundary edges (use a closed mesh: icosphere, box, capped cylinder, gear, or a closed OBJ)");
  }
  // The pressure potential needs outward normals (positive enclosed volume); an inward-oriented
  // OBJ would otherwise suck the shell in.
  for (const auto* shape : {&rest.V, &initial}) {
    const double volume = enclosed_volume(rest.F, stacked(*shape));
    if (!(volume > 0.0))
      node.fail(std::string("needs outward-oriented faces, but the ") + (shape == &rest.V ? "rest" : "initial") +
                " shape encloses a volume of " + number_for_message(volume) +
                " m^3 (faces wound inward: reverse their vertex order)");
  }
  return p;
}

bool valid_name_char(char c) { return static_cast<unsigned char>(c) >= 0x20 && c != '/' && c != 0x7f; }

// shot_end: frames x time_step (s), the time an obstacle's animation must last until.
SceneObject read_object(const JsonNode& node, int index, const std::string& base_dir, bool scene_has_wind,
                        const MeshBudget& budget, double shot_end) {
  node.expect_keys({"name", "mesh", "transform", "initial_positions", "initial_velocity", "material", "pins",
                    "pressure", "wind", "obstacle", "motion", "animation", "self_contact", "ground_contact",
                    "strain_limit", "hierarchy"});
  SceneObject obj;
  obj.name = "object_" + std::to_string(index);
  if (auto name = node.optional("name")) {
    obj.name = name->string(scene_json::kMaxNameBytes);
    if (obj.name.empty() || !std::all_of(obj.name.begin(), obj.name.end(), valid_name_char)) {
      name->fail_got("must be a non-empty name without '/' or control characters");
    }
  }
  JsonNode mesh_node = node.required("mesh");
  TriMesh mesh = read_mesh(mesh_node, base_dir, budget);
  obj.grid = generated_lattice(mesh_node, mesh);
  Transform transform;
  if (auto t = node.optional("transform")) transform = read_transform(*t);
  std::optional<Positions> posed;
  std::optional<JsonNode> posed_node = node.optional("initial_positions");
  if (posed_node) posed = read_posed(*posed_node, mesh, mesh_node.path(), base_dir);

  // An animated obstacle: its cache frames are placed like its mesh; read before the mesh moves.
  std::shared_ptr<const VertexAnimation> animation;
  if (auto a = node.optional("animation")) {
    if (!node.has("obstacle") || !node.required("obstacle").boolean())
      a->fail("applies to obstacles only (\"obstacle\": true)");
    for (const char* key : {"motion", "initial_positions"})
      if (auto k = node.optional(key)) k->fail("does not apply to an animated obstacle (the animation moves it)");
    animation = read_animation(*a, base_dir, mesh, [&](Positions& x) { transform.apply(x); }, shot_end);
  }

  transform.apply(mesh.V);
  scene_json::check_positions(mesh_node, mesh.V, "rest");
  validate_mesh(mesh, node.file() + ": " + mesh_node.path());
  obj.rest = std::move(mesh);
  if (posed) {
    transform.apply(*posed);
    scene_json::check_positions(posed_node->required("obj"), *posed, "initial");
    validate_pose(obj.rest, *posed, node.file() + ": " + posed_node->required("obj").path());
    obj.initial = std::move(*posed);
  } else if (animation) {
    obj.initial = animation->positions(0.0);
  } else {
    obj.initial = obj.rest.V;
  }

  if (auto o = node.optional("obstacle")) obj.obstacle = o->boolean();
  if (obj.obstacle) {
    // A collider moves as its script says; keys that give it dynamics would be silently ignored.
    for (const char* key : {"initial_velocity", "pins", "pressure", "wind", "self_contact", "ground_contact",
                            "strain_limit"})
      if (auto k = node.optional(key)) k->fail("does not apply to an obstacle (\"obstacle\": true)");
    if (auto m = node.optional("material")) obj.material = read_material(*m);
    if (auto m = node.optional("motion")) {
      obj.motion = read_script(*m);
      scene_json::check_script_speed(*m, *obj.motion, obj.initial, nullptr);
    }
    if (animation) {
      obj.motion.emplace();
      obj.motion->animation = std::move(animation);
    }
    // Obstacles never touch the ground: both are fixed, so the barrier between them could only
    // block the obstacle's motion.
    obj.wind = false;
    obj.ground_contact = false;
    return obj;
  }
  if (auto m = node.optional("motion"))
    m->fail("applies to obstacles only (to move part of a simulated object, use a pin with a \"script\")");
  if (auto v = node.optional("initial_velocity"))
    obj.initial_velocity = v->vec3_length_at_most(limits::kMaxSpeed, "m/s");
  obj.material = read_material(node.required("material"));
  if (auto pins = node.optional("pins")) obj.pins = read_pins(*pins, obj.initial, node.path());
  if (auto p = node.optional("pressure")) obj.pressure = read_pressure(*p, obj.rest, obj.initial);
  if (auto w = node.optional("wind")) {
    obj.wind = w->boolean();
    if (obj.wind && !scene_has_wind) w->fail("is true but the scene has no top-level \"wind\" section");
  }
  if (auto c = node.optional("self_contact")) obj.self_contact = c->boolean();
  if (auto g = node.optional("ground_contact")) obj.ground_contact = g->boolean();
  if (auto l = node.optional("strain_limit")) obj.strain_limit = read_strain_limit(*l);
  return obj;
}

Wind read_wind(const JsonNode& node) {
  node.expect_keys({"air_velocity", "air_density", "drag_coefficient", "gust_amplitude", "gust_frequency"});
  Wind w;
  w.air_velocity = node.required("air_velocity").vec3_length_at_most(limits::kMaxAirSpeed, "m/s");
  if (auto v = node.optional("air_density")) w.air_density = v->in_range(limits::kAirDensity);
  if (auto v = node.optional("drag_coefficient")) w.drag_coefficient = v->in_range(limits::kDragCoefficient);
  if (auto v = node.optional("gust_amplitude")) w.gust_amplitude = v->in_range(limits::kGustAmplitude);
  if (auto v = node.optional("gust_frequency")) w.gust_frequency = v->in_range(limits::kGustFrequency);
  // Gusts swing the speed up to (1 + amplitude) times the mean: the speed limit holds for the peak.
  const double peak = w.air_velocity.norm() * (1.0 + w.gust_amplitude);
  if (peak > limits::kMaxAirSpeed) {
    node.fail("gusts reach " + number_for_message(peak) + " m/s (|air_velocity| x (1 + gust_amplitude)), more than the "
              "limit of " + number_for_message(limits::kMaxAirSpeed) + " m/s");
  }
  return w;
}

SolverSettings read_solver(const JsonNode& node) {
  node.expect_keys({"tolerance", "max_newton_iterations", "hessian_projection", "friction_stopping"});
  SolverSettings s;
  if (auto v = node.optional("tolerance")) s.tolerance = v->in_range(limits::kTolerance);
  if (auto v = node.optional("max_newton_iterations")) s.max_newton_iterations = as_int(v->integer(1, 1000000));
  if (auto v = node.optional("hessian_projection")) {
    parse_hessian_projection(v->choice({"none", "clamp", "abs", "exact_first"}, "Hessian projection"), s.projection);
  }
  if (auto v = node.optional("friction_stopping")) {
    const std::string rule = v->choice({"contacts", "uniform"}, "friction stopping rule");
    s.friction_stopping = rule == "uniform" ? FrictionStopping::Uniform : FrictionStopping::Contacts;
  }
  return s;
}

// The top-level "contact" and "ground" sections, and the object keys that only mean something
// with them: without "contact", nothing collides, so asking for contact anywhere is an error rather
// than a silent no-op.
void read_contact_sections(const JsonNode& root, const std::vector<JsonNode>& objects, Scene& scene) {
  if (auto c = root.optional("contact")) scene.contact = read_contact(*c, scene.objects);
  if (auto g = root.optional("ground")) {
    if (!scene.contact) g->fail("needs a top-level \"contact\" section (the ground is a contact barrier)");
    scene.ground = read_ground(*g);
  }
  if (scene.contact) return;
  for (std::size_t i = 0; i < objects.size(); ++i) {
    for (const char* key : {"self_contact", "obstacle", "ground_contact"}) {
      if (auto k = objects[i].optional(key))
        if (k->boolean()) k->fail("is true but the scene has no top-level \"contact\" section");
    }
  }
}

void check_format_version(const JsonNode& root) {
  if (!root.json().is_object()) root.fail_got("a scene file must hold a JSON object {...}");
  const std::string expected = "this reader understands format_version " + std::to_string(kFormatVersion);
  auto v = root.optional("format_version");
  if (!v) throw InputError(root.file() + ": format_version: required key is missing (" + expected + ")");
  const Json& j = v->json();
  bool ok = (j.is_number_integer() && j.get<long long>() == kFormatVersion) ||
            (j.is_number_float() && j.get<double>() == static_cast<double>(kFormatVersion));
  if (!ok) v->fail_got("unsupported value (" + expected + ")");
}

}  // namespace

Scene parse_scene(const std::string& json_text, const std::string& path_for_messages, const std::string& base_dir) {
  const std::string& file = path_for_messages;
  const Json doc = scene_json::parse_json_text(json_text, file);
  const JsonNode root(doc, "", file);
  check_format_version(root);
  root.expect_keys({"format_version", "name", "description", "time_step", "frames", "gravity", "solver", "wind",
                    "contact", "ground", "hierarchy", "mode", "objects"});

  Scene scene;
  scene.source_path = path_for_messages;
  scene.json_text = json_text;
  scene.name = fs::path(path_for_messages).stem().string();
  if (scene.name.empty()) scene.name = "scene";
  if (auto name = root.optional("name")) {
    scene.name = name->string(scene_json::kMaxNameBytes);
    if (scene.name.empty()) name->fail_got("must be a non-empty string");
    if (!std::all_of(scene.name.begin(), scene.name.end(), [](char c) {
          return static_cast<unsigned char>(c) >= 0x20 && c != 0x7f;
        }))
      name->fail_got("must not contain control characters");
  }
  if (auto d = root.optional("description")) d->string();
  scene.time_step = root.required("time_step").in_range(limits::kTimeStep);
  scene.frames = as_int(root.required("frames").integer(1, kMaxFrames));
  if (auto g = root.optional("gravity")) scene.gravity = g->vec3_in(limits::kGravity);
  if (auto s = root.optional("solver")) scene.solver = read_solver(*s);
  if (auto w = root.optional("wind")) scene.wind = read_wind(*w);
  if (auto m = root.optional("mode")) scene.progressive = m->choice({"direct", "progressive"}, "mode") == "progressive";

  JsonNode objects = root.required("objects");
  std::vector<JsonNode> list = objects.elements();
  if (list.empty()) objects.fail_got("must list at least one object");
  if (static_cast<long long>(list.size()) > limits::kMaxObjects)
    objects.fail_got("lists more than " + std::to_string(limits::kMaxObjects) + " objects");
  std::map<std::string, std::size_t> names;  // name -> index, so 1000 objects cost no 10^6 comparisons
  MeshBudget budget;
  for (std::size_t i = 0; i < list.size(); ++i) {
    SceneObject obj = read_object(list[i], static_cast<int>(i), base_dir, scene.wind.has_value(), budget,
                                  scene.frames * scene.time_step);
    auto [it, added] = names.emplace(obj.name, i);
    if (!added) {
      JsonNode where = list[i].has("name") ? list[i].required("name") : list[i];
      where.fail("duplicate object name " + quoted_for_message(obj.name) + ", also used by " + list[it->second].path());
    }
    budget.vertices_before += obj.rest.num_vertices();
    scene.objects.push_back(std::move(obj));
  }
  read_contact_sections(root, list, scene);
  scene_json::read_hierarchy_sections(root, list, scene);
  return scene;
}

Scene load_scene(const std::string& path) {
  // stat first: opening a FIFO or a device would block or read forever, and the size limit is
  // checked before anything is read.
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) throw InputError(path + ": is a directory, not a scene file");
    if (!S_ISREG(st.st_mode)) throw InputError(path + ": is not a regular file (a FIFO, socket or device), not a scene file");
    if (static_cast<std::uintmax_t>(st.st_size) > scene_json::kMaxDocumentBytes) {
      throw InputError(path + ": the scene file has " + std::to_string(st.st_size) + " bytes, more than the limit of " +
                       std::to_string(scene_json::kMaxDocumentBytes) + " (16 MiB)");
    }
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open scene file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(path + ": cannot read scene file");
  return parse_scene(text.str(), path, fs::path(path).parent_path().string());
}

}  // namespace pd
