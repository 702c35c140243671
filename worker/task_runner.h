#pragma once
// One attempt of a task, solved on its own thread while the worker's connection thread keeps
// talking to the scheduler (heartbeats, frames of the level below arriving). The connection thread
// owns the ZeroMQ socket; this thread never touches it: what it produces (encoded reports) goes to
// an outbox, and a write to `wake_fd` (an eventfd the connection thread polls) says there is mail.
//
// A level task (progressive/level_task.h) asks for level l-1's frames as it steps; `feed` delivers
// them as BelowFrame messages arrive, and the solver waits for a frame it needs that has not arrived
// yet. `cancel` makes that wait (and the next frame it would send) end the attempt quietly.
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <Eigen/Core>

#include "hierarchy/scene_hierarchy.h"
#include "protocol/protocol.h"

namespace pd::worker {

// Hierarchies this worker has, by hash (shared by attempts; filled by the solver thread).
class HierarchyCache {
 public:
  std::shared_ptr<const SceneHierarchy> find(const std::string& hash) const;
  void put(const std::string& hash, std::shared_ptr<const SceneHierarchy> h);
  bool has(const std::string& hash) const;

 private:
  mutable std::mutex mutex_;
  std::map<std::string, std::shared_ptr<const SceneHierarchy>> by_hash_;
};

class TaskRunner {
 public:
  // scratch_dir: where scene files and hierarchy blobs are written (created when missing).
  // Fault injection for tests: fail_level >= 0: every level task of that level fails at once;
  // refuse_vertical_starts: every vertical start fails as a refused safe upsampling;
  // refuse_vertical_starts_before > 0: only those at a frame before it do.
  // max_memory_bytes > 0: level tasks needing more are refused (WorkerOptions::max_memory_bytes).
  TaskRunner(int wake_fd, std::string scratch_dir, HierarchyCache& cache, int fail_level = -1,
             bool refuse_vertical_starts = false, int refuse_vertical_starts_before = 0,
             double max_memory_bytes = 0.0);
  ~TaskRunner();  // cancels and joins
  TaskRunner(const TaskRunner&) = delete;
  TaskRunner& operator=(const TaskRunner&) = delete;

  // Starts an attempt on a new thread; requires !busy().
  void start(protocol::AssignTask task);
  // A frame of the level below for the running attempt (ignored for another attempt).
  void feed(const protocol::BelowFrame& frame);
  // A guide frame of the running stitch (ignored for another attempt).
  void feed(const protocol::GuideFrame& frame);
  // Ends the running attempt without further reports; returns at once (the thread ends soon).
  void cancel();
  // The attempt being run, 0 when idle (a finished thread counts as idle once joined by poll()).
  int64_t attempt() const;
  bool busy() const;
  // Joins a finished thread; call from the connection loop.
  void poll();
  // Encoded reports waiting to be sent, in order.
  std::vector<protocol::Parts> take_outbox();

 private:
  void run(protocol::AssignTask task);
  protocol::Parts run_hierarchy(const protocol::AssignTask& task);  // returns its HierarchyDone
  void run_level(const protocol::AssignTask& task);
  Eigen::VectorXd wait_below(int t);
  // Blocks until the stitch's guide frame f is fed (or the attempt is cancelled: throws).
  Eigen::VectorXd wait_guide(int f);
  void post(protocol::Parts parts);
  void finish(protocol::Parts last);
  std::shared_ptr<const SceneHierarchy> hierarchy_for(const protocol::AssignTask& task, const std::string& job_dir);

  int wake_fd_;
  std::string scratch_dir_;
  HierarchyCache& cache_;
  int fail_level_ = -1;
  bool refuse_vertical_starts_ = false;
  int refuse_vertical_starts_before_ = 0;
  double max_memory_bytes_ = 0.0;
  mutable std::mutex mutex_;
  std::condition_variable frame_arrived_;
  std::map<int, Eigen::VectorXd> below_;  // frames of level l-1 fed to the running attempt
  std::map<int, Eigen::VectorXd> guides_;  // a stitch's guide frames fed to the running attempt
  std::vector<protocol::Parts> outbox_;
  int64_t attempt_ = 0;
  bool cancelled_ = false, finished_ = false;
  std::thread thread_;
};

}  // namespace pd::worker
