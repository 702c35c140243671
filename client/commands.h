#pragma once
// The pd subcommands. Each returns the process exit code; input errors are thrown as InputError
// and turned into a message and exit code 2 by main().
#include <cstdint>
#include <string>

#include "farm/task_graph.h"
#include "protocol/protocol.h"

namespace pd::cli {

struct SimulateArgs {
  std::string scene;
  std::string out;
  int frames = -1;     // override of the scene's frame count
  bool quiet = false;
  // "direct": plain implicit Euler; without `level` on the finest mesh as given, stored as level 0
  // with no hierarchy; with `level` on that hierarchy level's mesh, stored with the hierarchy.
  // "progressive": PD's preview then every refinement level. Empty: the scene's "mode" key.
  std::string mode;
  int level = -1;           // direct: the hierarchy level to simulate (0 = coarsest)
  int levels = -1;          // override of the scene's hierarchy.levels
  bool preview_only = false;  // progressive: stop after level 0
  // progressive: "auto", "galerkin", "lagged", "coarse" or "coarse-first" (progressive/level_system.h);
  // empty: not given (auto)
  std::string hessian;
  bool force = false;  // replace an existing `out` that is not a frame file
  // Steps that stop before convergence make pd simulate exit 3 (frames kept); with this, 0 and a
  // warning.
  bool allow_unconverged = false;
  int threads = 0;  // element-loop threads (util/parallel.h); 0: every core
};
int simulate(const SimulateArgs& args);

struct ExportArgs {
  std::string file;
  int level = -1;  // -1: not given (level 0)
  std::string format = "obj";  // "obj": one OBJ per frame; "pc2": a PC2 point cache and its rest OBJ
  std::string out_dir;
  bool rest = false;     // write every level's rest mesh as level_<l>.obj (instead of frames)
  bool prolong = false;  // write the frames of `level` prolonged to the finest mesh (P^level)
  std::string frames;    // "FIRST:LAST", inclusive frame numbers; empty: every stored frame
  bool per_object = false;  // one file (PC2: one cache and rest OBJ) per scene object
};
int export_frames(const ExportArgs& args);

struct HierarchyArgs {
  std::string scene;
  std::string out;    // frame file that receives the hierarchy (reused when its hash matches)
  bool json = false;  // print one JSON object instead of text lines
  bool force = false;  // replace an existing `out` that is not a frame file
};
int hierarchy(const HierarchyArgs& args);

struct CompareArgs {
  std::string file;   // the reference is this file's finest level that holds frames
  std::string other;  // optional second file (e.g. a direct run of the same scene)
  std::string csv;    // CSV output; empty: FILE.compare.csv
  bool json = false;  // print one JSON object on stdout (docs/progressive.md, "Error measures") instead of text
  std::string seams;  // "T1,T2,...": frames later time subsets start from; seam jitter of OTHER against FILE
  bool force = false;  // replace an existing `csv` that is not a pd compare CSV
};
int compare(const CompareArgs& args);

// ---------------------------------------------------------------------------------------------------
// Farm commands (farm_commands.cpp, run_command.cpp). `farm` is the scheduler's client endpoint from
// --farm; empty: $PD_FARM, else tcp://127.0.0.1:7401 (farm_client.h). `keys` are the CURVE key files
// of --server-key and --key. Numbers left at 0 mean "the scene's value" (levels, frames) or "the
// scheduler's default" (preview_chunk), as in SubmitJob.

// --server-key FILE (the scheduler's PREFIX.pub) and --key FILE (this client's pair, from pd keys):
// both or neither; a scheduler beyond loopback answers only clients with both (farm/curve.h).
struct FarmKeyFiles {
  std::string server_key;
  std::string key;
};

struct SubmitArgs {
  std::string farm;
  FarmKeyFiles keys;
  std::string scene;
  bool preview_only = false;
  int levels = 0;
  int subsets = 1;         // K time subsets per refinement level
  int priority = 0;        // higher runs first
  int frames = 0;
  int preview_chunk = 0;   // frames per preview task
  std::string hessian = "auto";
  int stitch = farm::kDefaultStitchFrames;  // W frames per seam stitch (farm/task_graph.h); 0: none
  bool json = false;       // print {"job": ID} instead of the bare id
};
int submit(const SubmitArgs& args);

struct StatusArgs {
  std::string farm;
  FarmKeyFiles keys;
  int64_t job = 0;         // 0: every job
  bool json = false;       // print protocol::to_json_text of the reply
  bool watch = false;      // redraw every `interval` until the shown jobs end
  bool wait = false;       // (needs job) block until it ends; exit 0 only when it is done
  double interval = 1.0;   // s
};
int status(const StatusArgs& args);

struct FetchArgs {
  std::string farm;
  FarmKeyFiles keys;
  int64_t job = 0;
  std::string out;
  bool json = false;       // print {"job", "file", "bytes"}
};
int fetch(const FetchArgs& args);

// pd cancel JOB, pd refine JOB [--subsets K] and pd requeue JOB.
struct JobActionArgs {
  std::string farm;
  FarmKeyFiles keys;
  int64_t job = 0;
  int subsets = 1;         // refine only
  int stitch = farm::kDefaultStitchFrames;  // refine only
  bool json = false;       // print {"job", "message"}
};
int cancel(const JobActionArgs& args);
int refine(const JobActionArgs& args);
int requeue(const JobActionArgs& args);

// pd workers (list), pd workers add --slurm N ..., pd workers remove --slurm ID.
struct WorkersArgs {
  std::string farm;
  FarmKeyFiles keys;
  bool json = false;
  enum class Action { list, add, remove } action = Action::list;
  protocol::AddSlurmWorkers add;        // add: --slurm (count), --partition, --time, --cpus, --mem, --keep
  protocol::RemoveSlurmWorkers remove;  // remove: --slurm (id), --now
};
int workers(const WorkersArgs& args);

// pd run: a scheduler and `workers` workers on this machine for one job (local_farm.h).
struct RunArgs {
  std::string scene;
  std::string out;
  int workers = 0;
  int subsets = 1;
  int stitch = farm::kDefaultStitchFrames;
  bool preview_only = false;
  int levels = 0;
  int frames = 0;
  std::string hessian = "auto";
  std::string keep_farm;   // farm folder to use and keep; empty: a temporary one, removed at the end
  int threads = 0;         // element-loop threads per worker; 0: this machine's cores / workers (>= 1)
};
int run(const RunArgs& args);

// pd keys PREFIX: writes a new CURVE key pair to PREFIX.key (mode 0600) and PREFIX.pub (keys_command.cpp).
struct KeysArgs {
  std::string prefix;
};
int keys(const KeysArgs& args);

}  // namespace pd::cli
