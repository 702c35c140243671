// pd: the command-line client. Local commands (simulate, export, hierarchy, compare, keys) run in this process; the
// farm commands (submit, status, fetch, cancel, refine, workers) talk to a pd-scheduler, and pd run starts a farm of
// its own on this machine for one job.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <new>
#include <string>

#include <CLI/CLI.hpp>

#include "cli_text.h"
#include "commands.h"
#include "frame_file_guard.h"
#include "plan_command.h"
#include "progressive/level_stepper.h"
#include "progressive/level_system.h"
#include "util/input_error.h"
#include "util/memory_budget.h"
#include "util/process_setup.h"

namespace {

// The farm commands' arguments and subcommands, filled by add_farm_commands.
struct FarmCommands {
  pd::cli::SubmitArgs sub;
  pd::cli::StatusArgs st;
  pd::cli::FetchArgs fe;
  pd::cli::JobActionArgs ca, re, rq;
  pd::cli::WorkersArgs wo;
  pd::cli::RunArgs ru;
  CLI::App *submit = nullptr, *status = nullptr, *fetch = nullptr, *cancel = nullptr, *refine = nullptr,
           *requeue = nullptr, *workers = nullptr, *run = nullptr;

  // Runs the farm command that was given; -1 when the command given is not a farm command.
  int dispatch() const {
    if (*submit) return pd::cli::submit(sub);
    if (*status) return pd::cli::status(st);
    if (*fetch) return pd::cli::fetch(fe);
    if (*cancel) return pd::cli::cancel(ca);
    if (*refine) return pd::cli::refine(re);
    if (*requeue) return pd::cli::requeue(rq);
    if (*workers) return pd::cli::workers(wo);
    if (*run) return pd::cli::run(ru);
    return -1;
  }
};

// The validators of numeric options (cli_text.h): decimal only, a short stated range.
constexpr int64_t kIntMax = 2147483647;
CLI::Validator count_at_least_one() { return pd::cli::decimal_integer(1, kIntMax); }
CLI::Validator job_id() { return pd::cli::decimal_integer(1, INT64_MAX, "a positive integer (a job id)"); }
CLI::Validator frame_count() { return pd::cli::decimal_integer(1, pd::cli::kMaxFrames); }
CLI::Validator stitch_frames() { return pd::cli::decimal_integer(0, pd::farm::kMaxStitchFrames); }
const std::string stitch_help = "Frames each seam is stitched over, so that it does not pop (0: none; default " +
                                std::to_string(pd::farm::kDefaultStitchFrames) + ")";
CLI::Validator level_count() { return pd::cli::decimal_integer(1, pd::cli::kMaxLevels); }
CLI::Validator level_index() { return pd::cli::decimal_integer(0, pd::cli::kMaxLevels - 1); }
CLI::Validator positive_seconds() { return pd::cli::decimal_real(0.0, true, 1e9, "seconds, > 0 and <= 1e9"); }
CLI::Validator hessian_kind() { return pd::cli::one_of(pd::level_hessian_names()); }

// Ends the process after an error without the exit handlers: after a failed HDF5 write (disk full,
// file size limit) the frame file stays half-closed inside the HDF5 library, whose own exit handler
// (H5_term_library) then crashes with SIGSEGV while closing it again. Every file pd writes has been
// closed or removed by then (destructors ran while the exception unwound), so nothing is lost.
[[noreturn]] void exit_without_hdf5_cleanup(int code) {
  std::fflush(stdout);
  std::fflush(stderr);
  std::_Exit(code);
}

// How often `name` was given to `command`.
std::size_t f_count(const CLI::App* command, const std::string& name) { return command->get_option(name)->count(); }

// --farm, --server-key and --key of one farm command.
void add_farm_options(CLI::App* command, std::string& farm, pd::cli::FarmKeyFiles& keys) {
  command->add_option("--farm", farm, "Scheduler's client endpoint (default: $PD_FARM, else tcp://127.0.0.1:7401)")
      ->check(pd::cli::non_empty("$PD_FARM or tcp://127.0.0.1:7401"));
  command->add_option("--server-key", keys.server_key,
                      "The scheduler's public key file (PREFIX.pub); with --key, for a scheduler beyond loopback")
      ->check(pd::cli::non_empty("no encryption (loopback)"));
  command->add_option("--key", keys.key, "This client's key pair (PREFIX.key from pd keys); with --server-key")
      ->check(pd::cli::non_empty("no encryption (loopback)"));
}

// pd workers add --slurm N ... and pd workers remove --slurm ID (docs/deploy.md, "Slurm").
void add_slurm_commands(CLI::App* workers, pd::cli::WorkersArgs& w) {
  using Action = pd::cli::WorkersArgs::Action;
  CLI::App* add = workers->add_subcommand("add", "Start workers as a Slurm job array (the scheduler runs sbatch)");
  add->add_option("--slurm", w.add.count, "Number of Slurm workers (array tasks)")
      ->required()
      ->transform(count_at_least_one());
  add->add_option("--partition", w.add.partition, "Slurm partition (default: the cluster's default)");
  add->add_option("--time", w.add.time_limit, "Time limit per worker, Slurm's format (e.g. 2:00:00)");
  add->add_option("--cpus", w.add.cpus, "CPUs per worker (default: the job script's)")->transform(count_at_least_one());
  add->add_option("--mem", w.add.memory, "Memory per worker, e.g. 4G (default: the job script's)");
  add->add_option("--keep", w.add.keep,
                  "Keep this many Slurm workers running while work remains (a replacement when one ends); 0: none")
      ->transform(pd::cli::decimal_integer(0, 1000));
  add->add_flag("--json", w.json, "Print {\"slurm_job\", \"tasks\", \"message\"}");
  add->callback([&w] { w.action = Action::add; });
  add->fallthrough();  // --farm, --server-key, --key of pd workers may follow the subcommand
  CLI::App* remove = workers->add_subcommand(
      "remove", "Drain Slurm workers: cancel the idle ones now, the busy ones when their task ends (scancel)");
  remove->add_option("--slurm", w.remove.slurm_job, "Slurm job (123: the whole array) or array task (123_4)")
      ->required();
  remove->add_flag("--now", w.remove.now, "Cancel busy workers too, at once (their tasks go to other workers)");
  remove->add_flag("--json", w.json, "Print {\"slurm_job\", \"tasks\", \"message\"}");
  remove->callback([&w] { w.action = Action::remove; });
  remove->fallthrough();
}

void add_farm_commands(CLI::App& app, FarmCommands& f) {
  const std::string job_help = "Job id (as pd submit printed it)";

  f.submit = app.add_subcommand("submit", "Send a scene to the farm as a progressive job; prints the job id");
  f.submit->add_option("scene", f.sub.scene, "Scene file (JSON); checked here first, as pd simulate checks it")
      ->required();
  add_farm_options(f.submit, f.sub.farm, f.sub.keys);
  f.submit->add_flag("--preview-only", f.sub.preview_only,
                     "Only the preview (level 0); add the rest later with pd refine");
  f.submit->add_option("--levels", f.sub.levels, "Hierarchy levels instead of the scene's")->transform(level_count());
  f.submit->add_option("--subsets", f.sub.subsets, "Time subsets per refinement level (parallel tasks)")
      ->transform(count_at_least_one());
  f.submit->add_option("--stitch", f.sub.stitch, stitch_help)
      ->transform(stitch_frames());
  f.submit->add_option("--priority", f.sub.priority, "Higher runs first (default 0)")
      ->transform(pd::cli::decimal_integer(-kIntMax - 1, kIntMax));
  f.submit->add_option("--frames", f.sub.frames, "Frames instead of the scene's count")->transform(frame_count());
  f.submit->add_option("--preview-chunk", f.sub.preview_chunk, "Frames per preview task (default: the scheduler's)")
      ->transform(frame_count());
  f.submit->add_option("--hessian", f.sub.hessian, "Hessian of the prolonged elasticity")
      ->transform(hessian_kind());
  f.submit->add_flag("--json", f.sub.json, "Print {\"job\": ID} instead of the bare id");

  f.status = app.add_subcommand("status", "Progress of one job, or of every job");
  f.status->add_option("job", f.st.job, job_help + "; without it every job")->transform(job_id());
  add_farm_options(f.status, f.st.farm, f.st.keys);
  f.status->add_flag("--json", f.st.json, "Print the reply as JSON");
  f.status->add_flag("--watch", f.st.watch, "Redraw every --interval until the job(s) shown end");
  f.status->add_flag("--wait", f.st.wait, "Block until JOB ends, print it; exit 0 only when it is done");
  f.status->add_option("--interval", f.st.interval, "Seconds between polls of --watch and --wait (default 1)")
      ->transform(positive_seconds());

  f.fetch = app.add_subcommand("fetch", "Download a job's frame file (as stored so far)");
  f.fetch->add_option("job", f.fe.job, job_help)->required()->transform(job_id());
  f.fetch->add_option("--out,-o", f.fe.out, "Frame file to write (HDF5)")->required();
  add_farm_options(f.fetch, f.fe.farm, f.fe.keys);
  f.fetch->add_flag("--json", f.fe.json, "Print {\"job\", \"file\", \"bytes\"}");

  f.cancel = app.add_subcommand("cancel", "Cancel a job: its running tasks stop, no frame is added");
  f.cancel->add_option("job", f.ca.job, job_help)->required()->transform(job_id());
  add_farm_options(f.cancel, f.ca.farm, f.ca.keys);
  f.cancel->add_flag("--json", f.ca.json, "Print {\"job\", \"message\"}");

  f.refine = app.add_subcommand("refine", "Add the refinement levels to a preview-only job");
  f.refine->add_option("job", f.re.job, job_help)->required()->transform(job_id());
  f.refine->add_option("--subsets", f.re.subsets, "Time subsets per refinement level")->transform(count_at_least_one());
  f.refine->add_option("--stitch", f.re.stitch, stitch_help)
      ->transform(stitch_frames());
  add_farm_options(f.refine, f.re.farm, f.re.keys);
  f.refine->add_flag("--json", f.re.json, "Print {\"job\", \"message\"}");

  f.requeue = app.add_subcommand("requeue", "Retry a failed job: its failed and blocked tasks run again");
  f.requeue->add_option("job", f.rq.job, job_help)->required()->transform(job_id());
  add_farm_options(f.requeue, f.rq.farm, f.rq.keys);
  f.requeue->add_flag("--json", f.rq.json, "Print {\"job\", \"message\"}");

  f.workers = app.add_subcommand("workers", "The workers the scheduler knows, one line each, and its Slurm workers");
  add_farm_options(f.workers, f.wo.farm, f.wo.keys);
  f.workers->add_flag("--json", f.wo.json, "Print the reply as JSON");
  f.workers->require_subcommand(0, 1);
  add_slurm_commands(f.workers, f.wo);

  f.run = app.add_subcommand("run", "Run a scene as a job on a farm of N workers started on this machine");
  f.run->add_option("scene", f.ru.scene, "Scene file (JSON)")->required();
  f.run->add_option("--workers,-w", f.ru.workers, "Worker processes to start")
      ->required()
      ->transform(count_at_least_one());
  f.run->add_option("--out,-o", f.ru.out, "Frame file to write (HDF5) when the job is done")->required();
  f.run->add_option("--subsets", f.ru.subsets, "Time subsets per refinement level")->transform(count_at_least_one());
  f.run->add_option("--stitch", f.ru.stitch, stitch_help)
      ->transform(stitch_frames());
  f.run->add_flag("--preview-only", f.ru.preview_only, "Only the preview (level 0)");
  f.run->add_option("--levels", f.ru.levels, "Hierarchy levels instead of the scene's")->transform(level_count());
  f.run->add_option("--frames", f.ru.frames, "Frames instead of the scene's count")->transform(frame_count());
  f.run->add_option("--hessian", f.ru.hessian, "Hessian of the prolonged elasticity")
      ->transform(hessian_kind());
  f.run->add_option("--threads", f.ru.threads,
                    "Element-loop threads of each worker (default: this machine's cores / --workers, at least 1)")
      ->transform(count_at_least_one());
  f.run->add_option("--keep-farm", f.ru.keep_farm,
                    "Farm folder to use and keep (farm.sqlite, jobs/, logs); default: a temporary one, removed");
}

}  // namespace

int main(int argc, char** argv) {
  pd::configure_numerical_libraries(argv);
  CLI::App app{"pd: progressive cloth and shell animation"};
  app.require_subcommand(1);

  pd::cli::SimulateArgs sim;
  auto* simulate = app.add_subcommand("simulate", "Simulate a scene on this machine into an HDF5 frame file");
  simulate->add_option("scene", sim.scene, "Scene file (JSON, see docs/scene-format.md)")->required();
  simulate->add_option("--out,-o", sim.out,
                       "Frame file to create (HDF5, see docs/frame-format.md); written as OUT.partial, renamed at "
                       "the end (also after an error, when frames were stored); an existing OUT that is not a "
                       "frame file is refused unless --force")
      ->required();
  simulate->add_flag("--force", sim.force, "Replace an existing --out file even when it is not a frame file");
  simulate->add_option("--frames", sim.frames, "Simulate this many frames instead of the scene's count")
      ->transform(frame_count());
  simulate->add_flag("--quiet,-q", sim.quiet, "No progress output");
  simulate->add_flag("--allow-unconverged", sim.allow_unconverged,
                     "Exit 0 (with a warning) when steps stop before convergence; without it such a run exits 3");
  simulate->add_option("--mode", sim.mode,
                       "direct (plain implicit Euler) or progressive (preview, then refinement); default: the scene's \"mode\"")
      ->transform(pd::cli::one_of({"direct", "progressive"}));
  simulate->add_option("--level", sim.level, "direct only: simulate this hierarchy level's mesh (0 = coarsest)")
      ->transform(level_index());
  simulate->add_option("--levels", sim.levels, "Use this many hierarchy levels instead of the scene's")
      ->transform(level_count());
  simulate->add_flag("--preview-only", sim.preview_only, "progressive only: stop after the preview (level 0)");
  simulate->add_option("--hessian", sim.hessian,
                       "progressive only: Hessian of the prolonged elasticity (default auto: coarse-first for the preview, "
                       "lagged for the levels between)")
      ->transform(hessian_kind());
  simulate->add_option("--threads", sim.threads,
                       "Threads for the element loops (energies, Hessians, contact pairs; default: every core); "
                       "the frames are bit for bit the same for every count")
      ->transform(count_at_least_one());

  pd::cli::ExportArgs exp;
  // Hidden: the child process in which pd first opens a frame file it was handed (frame_file_guard.h).
  std::string check_file;
  auto* check_cmd = app.add_subcommand("check-frame-file", "")->group("");
  check_cmd->add_option("file", check_file)->required();
  auto* export_cmd = app.add_subcommand("export", "Write the frames of a frame file for other tools");
  export_cmd->add_option("file", exp.file, "Frame file (HDF5)")->required();
  export_cmd->add_option("--level", exp.level, "Resolution level (0 = coarsest)")->transform(level_index());
  export_cmd->add_option("--format", exp.format,
                         "obj (default): one OBJ per frame, frame_<t>.obj (5 digits); pc2: one PC2 point cache "
                         "level_<l>.pc2 (float32, start frame = the first frame, sample rate 1) with the rest mesh "
                         "in the same vertex order as level_<l>.obj (with --prolong level_<l>_prolonged.pc2/.obj, on "
                         "the finest mesh), for Blender's Mesh Cache modifier, Maya and 3ds Max")
      ->transform(pd::cli::one_of({"obj", "pc2"}));
  export_cmd->add_option("--frames", exp.frames,
                         "FIRST:LAST: export these frames only (inclusive; every one must be stored); default: every "
                         "stored frame (pc2: the contiguous stored run from the first stored frame, noted on stderr "
                         "when frames are left out)")
      ->check(pd::cli::non_empty("every stored frame"));
  export_cmd->add_flag("--per-object", exp.per_object,
                       "One file per scene object: <object>_frame_<t>.obj, or level_<l>_<object>.pc2/.obj (with "
                       "--prolong level_<l>_prolonged_<object>.pc2/.obj); in <object>, characters other than "
                       "letters, digits, '-', '_' and '.' become '_'");
  export_cmd->add_option("--out,-o", exp.out_dir,
                         "Output folder (created if missing, in an existing folder); the files are written to a "
                         "temporary folder and moved in at the end")
      ->required();
  export_cmd->add_flag("--rest", exp.rest,
                       "Write every level's rest mesh as level_<l>.obj (no frames; --level only with --prolong)");
  export_cmd->add_flag("--prolong", exp.prolong,
                       "Write the frames of --level prolonged to the finest mesh (needs a stored hierarchy, "
                       "see pd hierarchy)");

  pd::cli::HierarchyArgs hier;
  auto* hierarchy = app.add_subcommand("hierarchy", "Build (or reuse) a scene's level hierarchy into a frame file");
  hierarchy->add_option("scene", hier.scene, "Scene file (JSON, see docs/scene-format.md)")->required();
  hierarchy->add_option("--out,-o", hier.out,
                        "Frame file to create, or to reuse when its hierarchy matches; an existing OUT that is "
                        "not a frame file is refused unless --force")
      ->required();
  hierarchy->add_flag("--force", hier.force, "Replace an existing --out file even when it is not a frame file");
  hierarchy->add_flag("--json", hier.json, "Print one JSON object instead of text lines");

  pd::cli::CompareArgs cmp;
  auto* compare = app.add_subcommand(
      "compare", "Error measures between the levels of one or two frame files (prints or --json, writes CSV)");
  compare->add_option("file", cmp.file, "Frame file; its finest level with frames is the reference")->required();
  compare->add_option("other", cmp.other, "A second frame file of the same scene (e.g. a direct run)")
      ->check(pd::cli::non_empty("one frame file"));
  compare->add_option("--csv", cmp.csv,
                      "CSV file to write (default FILE.compare.csv); an existing file that is not a pd compare CSV "
                      "is refused unless --force")
      ->check(pd::cli::non_empty("FILE.compare.csv"));
  compare->add_flag("--force", cmp.force, "Replace an existing CSV file even when pd compare did not write it");
  compare->add_flag("--json", cmp.json, "Print one JSON object on stdout instead of the table");
  compare->add_option("--seams", cmp.seams,
                      "T1,T2,...: frames where later time subsets start (0: the level's start); adds each seam's pop, and "
                      "with OTHER (the run with subsets; FILE the K = 1 run) the baseline, the visible seams and the jitter");

  pd::cli::KeysArgs keys_args;
  auto* keys = app.add_subcommand(
      "keys", "Write a new CURVE key pair: PREFIX.key (--key of a worker or client; mode 0600) and PREFIX.pub");
  keys->add_option("prefix", keys_args.prefix, "Path prefix of the two files, e.g. keys/w1")->required();

  pd::cli::PlanArgs plan_args;
  CLI::App* plan = pd::cli::add_plan_subcommand(app, plan_args);

  FarmCommands farm;
  add_farm_commands(app, farm);

  // Options that do not apply together (those that depend on the scene's mode: simulate_command.cpp).
  const auto check_option_pairs = [&] {
    using pd::InputError;
    if (*export_cmd && exp.rest && !exp.prolong && exp.level >= 0)
      throw InputError("--level: does not apply to --rest alone (it writes every level); allowed: with --prolong");
    if (*farm.submit && f_count(farm.submit, "--subsets") && farm.sub.preview_only)
      throw InputError("--subsets: does not apply with --preview-only (give it to pd refine, which adds the "
                       "refinement levels)");
    if (*farm.run && farm.ru.preview_only && f_count(farm.run, "--subsets"))
      throw InputError("--subsets: does not apply with --preview-only (no refinement level is run)");
    if (*farm.status && f_count(farm.status, "--interval") && !farm.st.watch && !farm.st.wait)
      throw InputError("--interval: does not apply without --watch or --wait");
  };

  if (argc < 2) {  // bare `pd`: show what it can do, and fail (nothing was done)
    std::fputs(app.help().c_str(), stderr);
    return 2;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help
    // A bad command line is bad input like any other: same message prefix and exit code.
    // One line (see cli_text.h); --help lists the options.
    std::fprintf(stderr, "pd: error: %s\n", pd::cli::parse_error_text(e).c_str());
    return 2;
  }

  try {
    check_option_pairs();
    if (*check_cmd) return pd::cli::check_frame_file_here(check_file);
    pd::cli::set_frame_file_checker("/proc/self/exe");
    if (*simulate) return pd::cli::simulate(sim);
    if (*export_cmd) return pd::cli::export_frames(exp);
    if (*hierarchy) return pd::cli::hierarchy(hier);
    if (*compare) return pd::cli::compare(cmp);
    if (*plan) return pd::cli::plan(plan_args);
    if (*keys) return pd::cli::keys(keys_args);
    if (const int code = farm.dispatch(); code >= 0) return code;
  } catch (const pd::InputError& e) {
    std::fprintf(stderr, "pd: error: %s\n", pd::cli::one_line(e.what()).c_str());
    exit_without_hdf5_cleanup(2);
  } catch (const pd::StateDiverged& e) {
    // Not bad input (the scene was valid) nor a bug: the shot is beyond what the solver can do.
    std::fprintf(stderr, "pd: error: %s\n", pd::cli::one_line(e.what()).c_str());
    exit_without_hdf5_cleanup(3);
  } catch (const pd::OutOfMemory& e) {
    // Not a bug and not bad input: this machine (or its limits: ulimit -v, a cgroup) cannot hold what
    // was asked. pd simulate checks a scene's needs first (util/memory_budget.h); this is the rest.
    std::fprintf(stderr, "pd: error: %s\n", pd::cli::one_line(e.what()).c_str());
    exit_without_hdf5_cleanup(3);
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "pd: error: out of memory (an allocation failed)\n");
    exit_without_hdf5_cleanup(3);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pd: internal error: %s\n", pd::cli::one_line(e.what()).c_str());
    exit_without_hdf5_cleanup(1);
  }
  return 1;
}
