#include "support/slurm_cluster.h"

#include <arpa/inet.h>
#include <dirent.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace pd::test {

namespace {

// This machine's memory in MB (MemTotal of /proc/meminfo), 1024 when it cannot be read.
long memory_mb() {
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  long kb = 0;
  while (meminfo >> key >> kb) {
    if (key == "MemTotal:") return std::max(1024L, kb / 1024);
    meminfo.ignore(256, '\n');
  }
  return 1024;
}

}  // namespace
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

constexpr const char* kMunged = "/usr/sbin/munged";
constexpr const char* kSlurmctld = "/usr/sbin/slurmctld";
constexpr const char* kSlurmd = "/usr/sbin/slurmd";
constexpr const char* kSlurmstepd = "/usr/sbin/slurmstepd";  // slurmd's compiled-in path

constexpr auto kClientTimeout = 15s;   // one squeue/scancel/sinfo (MessageTimeout is 5 s)
constexpr auto kStartTimeout = 30s;    // constructor start to an idle node
constexpr auto kDrainTimeout = 15s;    // scancel to no job left (KillWait is 2 s)
constexpr auto kPollSlow = 200ms;      // between client commands while waiting
constexpr auto kDaemonGrace = 5s;      // SIGTERM to SIGKILL for each daemon (about 2 s measured)

// A Unix socket path must fit sockaddr_un::sun_path (108 bytes with its NUL); slurmstepd's socket
// is spool/<node>_<job id>.<step id>, both ids up to 10 digits.
constexpr std::size_t kSunPath = sizeof(sockaddr_un{}.sun_path);

bool executable(const std::string& path) { return access(path.c_str(), X_OK) == 0; }

std::string short_host_name() {
  char buf[256] = {};
  if (gethostname(buf, sizeof buf - 1) != 0) return "";
  std::string name = buf;
  return name.substr(0, name.find('.'));  // slurmctld compares SlurmctldHost with the short name
}

// Two distinct free TCP ports on 127.0.0.1: both sockets are held bound until both are chosen.
// A port could be taken by someone else between here and the daemon's bind; the daemon then fails
// to start and the constructor reports its log.
std::pair<int, int> two_free_ports() {
  int fds[2] = {-1, -1}, ports[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    fds[k] = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = 0;
    socklen_t len = sizeof a;
    if (fds[k] < 0 || bind(fds[k], reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        getsockname(fds[k], reinterpret_cast<sockaddr*>(&a), &len) != 0) {
      const std::string why = std::strerror(errno);
      for (int fd : fds)
        if (fd >= 0) close(fd);
      throw std::runtime_error("SlurmCluster: cannot find a free port: " + why);
    }
    ports[k] = ntohs(a.sin_port);
  }
  close(fds[0]);
  close(fds[1]);
  return {ports[0], ports[1]};
}

void write_text(const std::string& path, const std::string& text, mode_t mode) {
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << text;
    if (!out) throw std::runtime_error("SlurmCluster: cannot write " + path);
  }
  chmod(path.c_str(), mode);
}

// 1 KiB from the kernel's CSPRNG, readable by its owner (root) only, as munged insists.
void write_munge_key(const std::string& path) {
  std::ifstream in("/dev/urandom", std::ios::binary);
  std::string key(1024, '\0');
  if (!in.read(key.data(), static_cast<std::streamsize>(key.size())))
    throw std::runtime_error("SlurmCluster: cannot read /dev/urandom");
  write_text(path, key, 0400);
}

void make_dir(const std::string& path, mode_t mode) {
  fs::create_directories(path);
  chmod(path.c_str(), mode);
}

// /proc/<pid>/<what> with its NUL separators turned into `sep`; "" when unreadable (gone, zombie).
std::string proc_text(pid_t pid, const char* what, char sep) {
  std::string text = read_file_text("/proc/" + std::to_string(pid) + "/" + what);
  for (char& c : text)
    if (c == '\0') c = sep;
  return text;
}

// "munged", "slurmctld", "slurmd" or "slurmstepd" when `exe` (a /proc/<pid>/exe target) is that
// daemon's binary, else "". Debian installs them as /usr/sbin/slurmd -> /etc/alternatives/slurmd ->
// /usr/sbin/slurmd-wlm, so the executable's name alone is not the daemon's.
std::string daemon_of_exe(const fs::path& exe) {
  static const std::vector<std::pair<std::string, fs::path>> daemons = [] {
    std::vector<std::pair<std::string, fs::path>> out;
    for (const char* path : {kMunged, kSlurmctld, kSlurmd, kSlurmstepd}) {
      std::error_code ec;
      const fs::path real = fs::canonical(path, ec);
      out.emplace_back(fs::path(path).filename().string(), ec ? fs::path(path) : real);
    }
    return out;
  }();
  for (const auto& [name, real] : daemons)
    if (exe == real || exe.filename() == name) return name;
  return "";
}

struct ProcInfo {
  pid_t ppid = 0;
  char state = '?';
  std::string daemon;    // daemon_of_exe(/proc/<pid>/exe)
  std::string cmdline;   // arguments joined by spaces
};

// From /proc/<pid>/stat: the state and the parent after the command name's closing parenthesis.
bool read_proc_info(pid_t pid, ProcInfo& info) {
  const std::string stat = read_file_text("/proc/" + std::to_string(pid) + "/stat");
  const size_t close_paren = stat.rfind(')');
  if (close_paren == std::string::npos) return false;
  std::istringstream rest(stat.substr(close_paren + 1));
  rest >> info.state >> info.ppid;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/" + std::to_string(pid) + "/exe", ec);
  if (!ec) info.daemon = daemon_of_exe(exe);
  info.cmdline = proc_text(pid, "cmdline", ' ');
  return true;
}

bool has_open_file_under(pid_t pid, const std::string& dir) {
  std::error_code ec;
  for (fs::directory_iterator it("/proc/" + std::to_string(pid) + "/fd", ec), end; !ec && it != end;
       it.increment(ec)) {
    const fs::path target = fs::read_symlink(it->path(), ec);
    if (!ec && target.string().rfind(dir + "/", 0) == 0) return true;
  }
  return false;
}

std::map<pid_t, ProcInfo> live_processes() {
  std::map<pid_t, ProcInfo> out;
  std::error_code ec;
  for (fs::directory_iterator it("/proc", ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.empty() || name.find_first_not_of("0123456789") != std::string::npos) continue;
    const pid_t pid = static_cast<pid_t>(std::stol(name));
    ProcInfo info;
    if (read_proc_info(pid, info) && info.state != 'Z' && info.state != 'X') out[pid] = info;
  }
  return out;
}

// Every descendant of `roots` (not the roots themselves), from a parent-to-children map.
std::set<pid_t> descendants(const std::multimap<pid_t, pid_t>& children, std::vector<pid_t> roots) {
  std::set<pid_t> out;
  while (!roots.empty()) {
    const pid_t parent = roots.back();
    roots.pop_back();
    for (auto [it, end] = children.equal_range(parent); it != end; ++it)
      if (out.insert(it->second).second) roots.push_back(it->second);
  }
  return out;
}


}  // namespace

std::string SlurmCluster::unavailable_reason() {
  for (const char* path : {kMunged, kSlurmctld, kSlurmd, kSlurmstepd, "/usr/bin/sbatch", "/usr/bin/squeue",
                           "/usr/bin/scancel", "/usr/bin/sinfo", "/usr/bin/scontrol"})
    if (!executable(path)) return std::string(path) + " is missing (Debian packages munge, slurm-wlm)";
  if (geteuid() != 0)
    return "not root: slurmd starts every job step through setuid/setgroups and needs root "
           "(euid " + std::to_string(geteuid()) + ")";
  if (short_host_name().empty()) return "gethostname failed: slurmctld needs this host's name";
  return "";
}

SlurmCluster::SlurmCluster(const std::string& dir, int cpus)
    : dir_(fs::absolute(dir).lexically_normal().string()), node_(short_host_name()) {
  if (!dir_.empty() && dir_.back() == '/') dir_.pop_back();
  conf_ = dir_ + "/slurm.conf";
  cpus_ = cpus > 0 ? cpus : static_cast<int>(std::thread::hardware_concurrency());
  if (cpus_ <= 0) cpus_ = 1;
  env_ = {{"SLURM_CONF", conf_}};
  const auto t0 = Clock::now();
  try {
    start();
  } catch (...) {
    stop();
    throw;
  }
  startup_seconds_ = std::chrono::duration<double>(Clock::now() - t0).count();
}

SlurmCluster::~SlurmCluster() { stop(); }

void SlurmCluster::start() {
  if (const std::string why = unavailable_reason(); !why.empty()) throw std::runtime_error("SlurmCluster: " + why);
  if (!fs::is_directory(dir_)) throw std::runtime_error("SlurmCluster: no folder " + dir_);
  const std::size_t longest_socket = (dir_ + "/spool/" + node_ + "_4294967295.4294967295").size();
  if (longest_socket >= kSunPath)
    throw std::runtime_error("SlurmCluster: folder path too long for slurmstepd's Unix socket: " + dir_);
  make_dir(dir_ + "/munge", 0700);         // key, pid and seed: root only
  make_dir(dir_ + "/munge-socket", 0755);  // munged wants its socket's folder searchable by all
  make_dir(dir_ + "/state", 0700);
  make_dir(dir_ + "/spool", 0755);
  make_dir(dir_ + "/log", 0755);
  write_munge_key(dir_ + "/munge/munge.key");
  const auto [ctld_port, slurmd_port] = two_free_ports();
  write_config(ctld_port, slurmd_port);

  // --force: munged otherwise refuses to run when a folder on the way to its socket is not
  // searchable by all (seen with a 0700 mktemp folder); root owns every folder here.
  munged_.start({kMunged, "--foreground", "--force", "--key-file=" + dir_ + "/munge/munge.key",
                 "--socket=" + dir_ + "/munge-socket/munge.socket", "--pid-file=" + dir_ + "/munge/munged.pid",
                 "--seed-file=" + dir_ + "/munge/munged.seed", "--log-file=" + dir_ + "/log/munged.log"},
                env_, "", dir_ + "/log/munged.stderr");
  wait_for_munge_socket(10s);
  // -f and SLURM_CONF both: the daemons and everything they start read this folder's slurm.conf.
  slurmctld_.start({kSlurmctld, "-D", "-f", conf_}, env_, "", dir_ + "/log/slurmctld.stderr");
  slurmd_.start({kSlurmd, "-D", "-f", conf_, "-N", node_}, env_, "", dir_ + "/log/slurmd.stderr");
  wait_for_idle_node(kStartTimeout);
}

void SlurmCluster::write_config(int ctld_port, int slurmd_port) const {
  std::ostringstream c;
  c << "# Written by tests/support/slurm_cluster.cpp for one test; everything lives in " << dir_ << "\n"
    << "ClusterName=pdtest\n"
    << "SlurmctldHost=" << node_ << "(127.0.0.1)\n"
    << "SlurmctldPort=" << ctld_port << "\nSlurmdPort=" << slurmd_port << "\n"
    << "SlurmUser=root\nSlurmdUser=root\n"
    // Our munged only, for the authentication and the job credentials alike.
    << "AuthType=auth/munge\nCredType=cred/munge\n"
    << "AuthInfo=socket=" << dir_ << "/munge-socket/munge.socket\n"
    << "StateSaveLocation=" << dir_ << "/state\nSlurmdSpoolDir=" << dir_ << "/spool\n"
    << "SlurmctldPidFile=" << dir_ << "/log/slurmctld.pid\nSlurmdPidFile=" << dir_ << "/log/slurmd.pid\n"
    << "SlurmctldLogFile=" << dir_ << "/log/slurmctld.log\nSlurmdLogFile=" << dir_ << "/log/slurmd.log\n"
    << "SlurmctldDebug=info\nSlurmdDebug=info\n"
    << "PlugStackConfig=" << dir_ << "/plugstack.conf\n"
    << "MailProg=/bin/true\n"
    // No cgroups: a job's processes are tracked through their parent links in /proc.
    << "ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n"
    << "JobAcctGatherType=jobacct_gather/none\nAccountingStorageType=accounting_storage/none\n"
    << "JobCompType=jobcomp/none\nMpiDefault=none\n"
    // One core per CPU, cores consumable: two 1-CPU jobs run at once on a 2-CPU node.
    << "SelectType=select/cons_tres\nSelectTypeParameters=CR_Core\nSchedulerType=sched/backfill\n"
    // The configured CPUs count even when they differ from the hardware (a test's choice).
    << "SlurmdParameters=config_overrides\n"
    << "ReturnToService=2\n"
    // slurmd listens on its NodeAddr (127.0.0.1) only; slurmctld 22.05 listens on every address
    // whatever this says (seen with ss), and answers only munge credentials of our own key.
    << "CommunicationParameters=NoInAddrAny\n"
    // Seconds: SIGTERM to SIGKILL of a cancelled job; how long squeue still shows an ended job
    // (CANCELLED, TIMEOUT); how long a client or daemon waits for an answer; a silent slurmd
    // is marked down after SlurmdTimeout.
    << "KillWait=2\nMinJobAge=30\nMessageTimeout=5\nSlurmdTimeout=30\nInactiveLimit=0\n"
    << "NodeName=" << node_ << " NodeAddr=127.0.0.1 CPUs=" << cpus_ << " Sockets=1 CoresPerSocket=" << cpus_
    // RealMemory: the machine's, so that jobs asking for memory (--mem, the job script's default)
    // fit; memory is not a consumable here (CR_Core), only checked against this.
    << " ThreadsPerCore=1 RealMemory=" << memory_mb() << " State=UNKNOWN\n"
    << "PartitionName=" << partition() << " Nodes=" << node_ << " Default=YES MaxTime=INFINITE State=UP\n";
  write_text(conf_, c.str(), 0644);
  write_text(dir_ + "/plugstack.conf", "# empty: no SPANK plugin (not /etc/slurm/plugstack.conf)\n", 0644);
}

void SlurmCluster::wait_for_munge_socket(std::chrono::milliseconds timeout) {
  const std::string path = dir_ + "/munge-socket/munge.socket";
  const auto deadline = Clock::now() + timeout;
  for (;;) {
    const int fd = socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::strncpy(a.sun_path, path.c_str(), sizeof a.sun_path - 1);
    const bool ok = fd >= 0 && connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    if (fd >= 0) close(fd);
    if (ok) return;
    if (!munged_.running()) throw std::runtime_error("SlurmCluster: munged ended\n" + log_tails());
    if (Clock::now() >= deadline)
      throw std::runtime_error("SlurmCluster: no munge socket after " +
                               std::to_string(std::chrono::duration_cast<std::chrono::seconds>(timeout).count()) +
                               " s\n" + log_tails());
    std::this_thread::sleep_for(20ms);
  }
}

void SlurmCluster::throw_if_a_daemon_ended() {
  for (Process* p : {&munged_, &slurmctld_, &slurmd_})
    if (p->started() && !p->running())
      throw std::runtime_error("SlurmCluster: " + p->name() + " ended with exit code " +
                               std::to_string(p->exit_code().value_or(-1)) + "\n" + log_tails());
}

void SlurmCluster::wait_for_idle_node(std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  RunResult last;
  for (;;) {
    throw_if_a_daemon_ended();
    last = command({"sinfo", "-h", "-n", node_, "-o", "%t"}, kClientTimeout);
    // "idle" (or "idle*" while slurmd's registration is not in yet: keep waiting for that).
    if (last.exit_code == 0 && last.out == "idle\n") return;
    if (Clock::now() >= deadline)
      throw std::runtime_error("SlurmCluster: node " + node_ + " not idle after " +
                               std::to_string(std::chrono::duration_cast<std::chrono::seconds>(timeout).count()) +
                               " s; last " + last.describe() + "\n" + log_tails());
    std::this_thread::sleep_for(kPollSlow);
  }
}

RunResult SlurmCluster::command(std::vector<std::string> argv, std::chrono::milliseconds timeout) const {
  if (!argv.empty() && argv[0].find('/') == std::string::npos) {
    for (const char* d : {"/usr/bin/", "/usr/sbin/", "/bin/"})
      if (executable(d + argv[0])) {
        argv[0] = d + argv[0];
        break;
      }
  }
  return run(argv, timeout, env_);
}

void SlurmCluster::cancel_jobs_and_wait() {
  if (!slurmctld_.running()) return;
  // Every job of the partition, whoever submitted it (we are root); pending ones too.
  command({"scancel", "--partition=" + partition()}, kClientTimeout);
  const auto deadline = Clock::now() + kDrainTimeout;
  while (Clock::now() < deadline && slurmctld_.running()) {
    // squeue's default states: pending, running, completing..., not the ended ones.
    const RunResult q = command({"squeue", "-h", "-o", "%i"}, kClientTimeout);
    if (q.exit_code == 0 && q.out.empty()) break;
    std::this_thread::sleep_for(kPollSlow);
  }
  // A slurmstepd ends a moment after its job left squeue (it reports, then cleans its spool).
  while (Clock::now() < deadline) {
    bool stepd = false;
    for (const auto& [pid, info] : live_processes())
      if (info.daemon == "slurmstepd" && has_open_file_under(pid, dir_)) stepd = true;
    if (!stepd) break;
    std::this_thread::sleep_for(50ms);
  }
}

void SlurmCluster::stop() {
  if (stopped_) return;
  stopped_ = true;
  try {
    cancel_jobs_and_wait();
  } catch (...) {
    // A client that cannot be started changes nothing below: the leftovers are killed anyway.
  }
  // slurmd first, so that it does not launch anything more; munged last, as the others use it.
  slurmd_.terminate(kDaemonGrace);
  slurmctld_.terminate(kDaemonGrace);
  munged_.terminate(kDaemonGrace);
  const auto deadline = Clock::now() + 5s;
  std::set<pid_t> killed;
  for (;;) {
    std::vector<pid_t> left;
    try {
      left = cluster_processes(dir_);
    } catch (...) {
    }
    if (left.empty() || Clock::now() >= deadline) break;
    for (pid_t pid : left) {
      const std::string what = std::to_string(pid) + " " + proc_text(pid, "cmdline", ' ');
      if (kill(pid, SIGKILL) == 0 && killed.insert(pid).second) killed_at_stop_.push_back(what);
    }
    std::this_thread::sleep_for(50ms);
  }
}

std::string SlurmCluster::log_tails() const {
  std::string out;
  for (const char* name : {"munged.stderr", "munged.log", "slurmctld.log", "slurmctld.stderr", "slurmd.log",
                           "slurmd.stderr"}) {
    const std::string path = dir_ + "/log/" + name;
    if (!fs::exists(path)) continue;
    out += "--- " + path + ":\n" + file_tail(path, 30);
  }
  return out;
}

std::string SlurmCluster::daemon_name(pid_t pid) {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/" + std::to_string(pid) + "/exe", ec);
  return ec ? "" : daemon_of_exe(exe);
}

std::vector<pid_t> SlurmCluster::cluster_processes(const std::string& dir_in) {
  std::string dir = fs::absolute(dir_in).lexically_normal().string();
  if (!dir.empty() && dir.back() == '/') dir.pop_back();
  const std::map<pid_t, ProcInfo> procs = live_processes();
  const std::string conf_var = "SLURM_CONF=" + dir + "/slurm.conf";
  std::set<pid_t> ours, by_environment;
  for (const auto& [pid, info] : procs) {
    if (!info.daemon.empty() &&
        (info.cmdline.find(dir + "/") != std::string::npos || has_open_file_under(pid, dir))) {
      ours.insert(pid);
      continue;
    }
    // A job's environment: sbatch copies the submitter's (env()), slurmstepd adds SLURM_JOB_ID.
    const std::string env_text = "\n" + proc_text(pid, "environ", '\n');
    if (env_text.find("\nSLURM_JOB_ID=") != std::string::npos && env_text.find("\n" + conf_var + "\n") != std::string::npos)
      by_environment.insert(pid);
  }
  std::multimap<pid_t, pid_t> children;
  for (const auto& [pid, info] : procs) children.emplace(info.ppid, pid);
  // The caller's own children (a pd-scheduler started with env()) are never a job's, even when the
  // caller itself runs inside some other Slurm job (SLURM_JOB_ID in its environment).
  for (pid_t pid : descendants(children, {getpid()})) by_environment.erase(pid);
  by_environment.erase(getpid());
  // Descendants of this cluster's slurmstepd: also the job processes that cleared their environment.
  std::vector<pid_t> stepds;
  for (pid_t pid : ours)
    if (procs.at(pid).daemon == "slurmstepd") stepds.push_back(pid);
  for (pid_t pid : descendants(children, stepds)) ours.insert(pid);
  ours.insert(by_environment.begin(), by_environment.end());
  ours.erase(getpid());
  return {ours.begin(), ours.end()};
}

}  // namespace pd::test
