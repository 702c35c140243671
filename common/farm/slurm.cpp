#include "farm/slurm.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <regex>
#include <sstream>

#include "util/input_error.h"

namespace pd::farm {

namespace {

bool all_of(const std::string& s, bool (*ok)(char)) { return std::all_of(s.begin(), s.end(), ok); }

bool partition_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '-'; }

// Slurm's --time formats (sbatch(1)): minutes, minutes:seconds, hours:minutes:seconds, days-hours,
// days-hours:minutes, days-hours:minutes:seconds. "UNLIMITED" is left to the site's limits.
const std::regex& time_format() {
  static const std::regex re(R"(^([0-9]{1,7}|[0-9]{1,7}:[0-9]{1,2}|[0-9]{1,5}:[0-9]{1,2}:[0-9]{1,2}|)"
                             R"([0-9]{1,4}-[0-9]{1,2}|[0-9]{1,4}-[0-9]{1,2}:[0-9]{1,2}|[0-9]{1,4}-[0-9]{1,2}:[0-9]{1,2}:[0-9]{1,2})$)");
  return re;
}

// "123_[2-5,7]" -> 123_2 .. 123_5, 123_7 (squeue folds a pending array's tasks that have not
// started); an id without brackets is returned as it is. A "%N" step limit ("[0-9%2]") is ignored.
std::vector<std::string> unfold(const std::string& id) {
  const auto open = id.find("_[");
  if (open == std::string::npos || id.back() != ']') return {id};
  const std::string job = id.substr(0, open);
  std::string list = id.substr(open + 2, id.size() - open - 3);
  list = list.substr(0, list.find('%'));
  std::vector<std::string> out;
  std::stringstream ranges(list);
  std::string range;
  while (std::getline(ranges, range, ',')) {
    const auto dash = range.find('-');
    try {
      const long first = std::stol(range.substr(0, dash));
      const long last = dash == std::string::npos ? first : std::stol(range.substr(dash + 1));
      for (long k = first; k <= last && out.size() < 100000; ++k) out.push_back(job + "_" + std::to_string(k));
    } catch (const std::exception&) {
      return {id};  // not a list we understand: kept whole, so it shows up instead of vanishing
    }
  }
  return out;
}

}  // namespace

void check_slurm_request(const protocol::AddSlurmWorkers& m) {
  if (m.count < 1 || m.count > kMaxSlurmWorkersPerRequest)
    throw InputError("--slurm: expected 1 to " + std::to_string(kMaxSlurmWorkersPerRequest) + " workers, got " +
                     std::to_string(m.count));
  if (!m.partition.empty() && (m.partition.size() > 64 || !all_of(m.partition, partition_char)))
    throw InputError("--partition: expected 1 to 64 letters, digits, '_', '.' or '-'");
  if (!m.time_limit.empty() && (m.time_limit.size() > 20 || !std::regex_match(m.time_limit, time_format())))
    throw InputError("--time: expected minutes, M:S, H:M:S, D-H, D-H:M or D-H:M:S (Slurm's formats), got '" +
                     m.time_limit.substr(0, 20) + "'");
  if (m.cpus < 0 || m.cpus > kMaxSlurmCpus)
    throw InputError("--cpus: expected 1 to " + std::to_string(kMaxSlurmCpus) + ", got " + std::to_string(m.cpus));
  static const std::regex memory(R"(^[0-9]{1,9}[KMGT]?$)");
  if (!m.memory.empty() && (m.memory.size() > 10 || !std::regex_match(m.memory, memory)))
    throw InputError("--mem: expected a number of megabytes or a number with K, M, G or T (e.g. 4G), got '" +
                     m.memory.substr(0, 10) + "'");
  if (m.keep < -1 || m.keep > kMaxSlurmWorkersPerRequest)
    throw InputError("--keep: expected 0 to " + std::to_string(kMaxSlurmWorkersPerRequest) + ", got " +
                     std::to_string(m.keep));
}

bool valid_slurm_job_id(const std::string& id) {
  static const std::regex re(R"(^[0-9]{1,18}(_[0-9]{1,9})?$)");
  return std::regex_match(id, re);
}

std::vector<std::string> sbatch_argv(const SbatchCall& call) {
  check_slurm_request(call.request);
  if (call.log_dir.find('%') != std::string::npos)
    throw InputError("Slurm log folder '" + call.log_dir + "': must not hold '%' (sbatch reads it as a pattern)");
  if (call.job_name.empty() || call.job_name.find('%') != std::string::npos ||
      call.job_name.find('|') != std::string::npos)
    throw InputError("Slurm job name '" + call.job_name + "': must be non-empty, without '%' or '|'");
  const protocol::AddSlurmWorkers& r = call.request;
  std::vector<std::string> argv = {"sbatch", "--parsable", "--array=0-" + std::to_string(r.count - 1),
                                   "--job-name=" + call.job_name,
                                   "--output=" + call.log_dir + "/" + call.job_name + "-%A_%a.log",
                                   // else the job starts in sbatch's folder, the scheduler's, which
                                   // a compute node may not have
                                   "--chdir=" + call.log_dir};
  if (!r.partition.empty()) argv.push_back("--partition=" + r.partition);
  if (!r.time_limit.empty()) argv.push_back("--time=" + r.time_limit);
  if (r.cpus > 0) argv.push_back("--cpus-per-task=" + std::to_string(r.cpus));
  if (!r.memory.empty()) argv.push_back("--mem=" + r.memory);
  argv.push_back(call.script);
  argv.insert(argv.end(), call.worker_command.begin(), call.worker_command.end());
  return argv;
}

std::string parse_sbatch_job_id(const std::string& output) {
  std::string first = output.substr(0, output.find('\n'));
  first = first.substr(0, first.find(';'));
  while (!first.empty() && std::isspace(static_cast<unsigned char>(first.back()))) first.pop_back();
  if (!valid_slurm_job_id(first) || first.find('_') != std::string::npos)
    throw InputError("sbatch printed no job id: '" + output.substr(0, 200) + "'");
  return first;
}

std::vector<std::string> array_task_ids(const std::string& job, int count) {
  std::vector<std::string> ids;
  for (int k = 0; k < count; ++k) ids.push_back(job + "_" + std::to_string(k));
  return ids;
}

std::vector<std::string> squeue_argv(const std::string& job_name) {
  return {"squeue", "--noheader", "--array", "--states=all", "--name=" + job_name, "--format=%i|%T|%r"};
}

std::vector<SlurmJobState> parse_squeue(const std::string& output) {
  std::vector<SlurmJobState> jobs;
  std::stringstream lines(output);
  std::string line;
  while (std::getline(lines, line)) {
    const auto a = line.find('|');
    const auto b = a == std::string::npos ? a : line.find('|', a + 1);
    if (b == std::string::npos) continue;
    std::string id = line.substr(0, a), state = line.substr(a + 1, b - a - 1), reason = line.substr(b + 1);
    auto trim = [](std::string& s) {
      while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
      while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.erase(s.begin());
    };
    trim(id);
    trim(state);
    trim(reason);
    if (id.empty() || state.empty()) continue;
    for (const std::string& task : unfold(id)) jobs.push_back({task, state, reason});
  }
  return jobs;
}

bool slurm_state_active(const std::string& state) {
  static const std::array<const char*, 11> kActive = {"PENDING",  "RUNNING",   "CONFIGURING", "SUSPENDED",
                                                      "REQUEUED", "REQUEUE_HOLD", "RESIZING", "SIGNALING",
                                                      "STAGE_OUT", "REQUEUE_FED", "SUBMITTED"};
  return std::find(kActive.begin(), kActive.end(), state) != kActive.end();
}

}  // namespace pd::farm
