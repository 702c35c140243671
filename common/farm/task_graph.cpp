#include "farm/task_graph.h"

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace pd::farm {
namespace {

void require_at_least(const char* field, int value, int minimum) {
  if (value < minimum)
    throw std::invalid_argument(std::string("task graph: ") + field + " must be >= " + std::to_string(minimum) +
                                ", got " + std::to_string(value));
}

void validate(const GraphOptions& o, const std::vector<int>& seams) {
  require_at_least("frames", o.frames, 1);
  require_at_least("levels", o.levels, 1);
  require_at_least("subsets", o.subsets, 1);
  require_at_least("preview_chunk", o.preview_chunk, 0);
  require_at_least("stitch", o.stitch, 0);
  if (seams.empty()) return;
  const int subsets = std::min(o.subsets, o.frames);  // K is clamped to N
  if (static_cast<int>(seams.size()) + 1 != subsets)
    throw std::invalid_argument("task graph: " + std::to_string(seams.size()) + " seams for " +
                                std::to_string(subsets) + " subsets (expected subsets - 1, K clamped to N)");
  for (std::size_t k = 0; k < seams.size(); ++k)
    if (seams[k] <= (k == 0 ? 0 : seams[k - 1]) || seams[k] >= o.frames)
      throw std::invalid_argument("task graph: seams must increase strictly within (0, " + std::to_string(o.frames) +
                                  "), got " + std::to_string(seams[k]) + " at position " + std::to_string(k));
}

NewTask level_task(int level, int first, int last) {
  NewTask t;
  t.kind = protocol::TaskKind::level;
  t.level = level;
  t.first = first;
  t.last = last;
  t.after_hierarchy = true;
  return t;
}

void add_preview_chain(const GraphOptions& o, std::vector<NewTask>& out) {
  const int chunk = std::min(o.preview_chunk == 0 ? default_preview_chunk(o.frames) : o.preview_chunk, o.frames);
  for (int a = 0; a < o.frames; a += chunk) {
    NewTask t = level_task(0, a, std::min(a + chunk, o.frames));
    // Horizontal continuation: the chunk restarts from the previous chunk's last two frames.
    if (a > 0) t.needs = {FrameKey{0, a - 1}, FrameKey{0, a}};
    out.push_back(std::move(t));
  }
}

void add_refinement(const GraphOptions& o, const std::vector<int>& seams, std::vector<NewTask>& out) {
  const int K = std::min(o.subsets, o.frames);
  const int64_t N = o.frames;
  // b_k = round(k N / K); with K <= N consecutive boundaries differ by at least floor(N / K) >= 1.
  // 64-bit: k N overflows int for long jobs cut into many subsets.
  auto boundary = [&](int k) {
    if (!seams.empty()) return k == 0 ? 0 : k == K ? o.frames : seams[static_cast<std::size_t>(k - 1)];
    return static_cast<int>((k * N + K / 2) / K);
  };
  for (int level = 1; level < o.levels; ++level) {
    for (int k = 0; k < K; ++k) {
      const int a = boundary(k), b = boundary(k + 1);
      NewTask t = level_task(level, a, b);
      t.needs = subset_needs(level, a, b);
      std::optional<NewTask> stitch = a > 0 ? stitch_task(level, a, b, o.stitch) : std::nullopt;
      if (stitch) t.guides = stitch->last - stitch->first;
      out.push_back(std::move(t));
      if (stitch) out.push_back(std::move(*stitch));
    }
  }
}

}  // namespace

std::vector<FrameKey> subset_needs(int level, int first, int last) {
  const int a = first, b = last;
  // The first step reads level l-1's frames a and a-1 (frame -1 meaning frame 0); a vertical start
  // upsamples frame a and takes its velocity from frames a-1 and a.
  std::vector<FrameKey> needs = {FrameKey{level - 1, std::max(a - 1, 0)}};
  if (a > 0) needs.push_back(FrameKey{level - 1, a});
  // Level l >= 2, a > 0: also wait for level l-1's frame a + 1, i.e. for the task that feeds this
  // one to have started. Dispatched on frames a - 1 and a alone (the last ones of level l-1's
  // previous subset), it can take a worker before its feeder (a, b] of level l-1 is ready, then
  // hold that worker idle while the feeder waits for one: replays showed more workers making a
  // job up to 16% slower, and a subset of level 1 blocked until the preview ended. Level 1 needs
  // no such rule: level 0's chain is running from its frame 0 on. Cost: at most the task's
  // first step overlapping its feeder's first step. b = a + 1 is fed only stored frames.
  if (level >= 2 && a > 0 && b > a + 1) needs.push_back(FrameKey{level - 1, a + 1});
  return needs;
}

std::optional<NewTask> stitch_task(int level, int seam, int last, int stitch) {
  // The later subset keeps at least its last two frames: the next seam's stitch continues from them.
  // Were they stitched frames, each stitch would wait for the one before it: a chain through the
  // whole level (pd plan: flag-large-10s at K = 64, W = 16 on 64 workers, 4 397 s against 126 s).
  const int w = std::min(stitch, last - seam - 1);
  if (w < 2 || level < 1 || seam < 1) return std::nullopt;
  NewTask t = level_task(level, seam, seam + w - 1);
  t.stitch = true;
  // Its own level's frames s - 1 and s (a horizontal continuation), the level below as for any task
  // (s, s + w - 1], and the first of the later subset's frames s + 1 .. s + w - 1 it is guided toward:
  // the others are fed as the later subset solves them, so the stitch runs a step behind it. Waiting
  // for all of them made each level above wait for the later subset's first w frames and the stitch
  // after them in turn (drape-25k, 30 frames at K = 2: the levels ran in a chain).
  t.needs = subset_needs(level, seam, t.last);
  t.needs.push_back(FrameKey{level, seam - 1});
  t.needs.push_back(FrameKey{level, seam});
  t.guide_needs.push_back(FrameKey{level, seam + 1});
  return t;
}

// Chunks do not add parallelism (the chain is sequential) nor change the frames (a horizontal
// continuation repeats the single run bit for bit); they bound how long one task holds a worker and
// its lease, so that a lost worker, a cancel or a higher-priority job waits at most one chunk, and the
// scheduler's view of the job advances in task-sized steps. Each chunk costs one dispatch (scene,
// cached hierarchy, two frames: milliseconds), negligible against 50 preview steps, which at typical
// preview step times (0.05-1 s) make a chunk seconds to a minute long.
int default_preview_chunk(int frames) {
  require_at_least("frames", frames, 1);
  return std::min(50, frames);
}

std::vector<NewTask> job_tasks(const GraphOptions& options, const std::vector<int>& seams) {
  validate(options, seams);
  std::vector<NewTask> out;
  NewTask hierarchy;
  hierarchy.kind = protocol::TaskKind::hierarchy;
  hierarchy.level = 0;
  hierarchy.first = 0;
  hierarchy.last = 0;
  out.push_back(hierarchy);
  add_preview_chain(options, out);
  if (!options.preview_only) add_refinement(options, seams, out);
  return out;
}

std::vector<NewTask> refinement_tasks(const GraphOptions& options, const std::vector<int>& seams) {
  validate(options, seams);
  std::vector<NewTask> out;
  add_refinement(options, seams, out);
  return out;
}

std::optional<FrameRange> fed_frames(const NewTask& task) {
  if (task.kind != protocol::TaskKind::level) return std::nullopt;
  if (task.level < 0) throw std::invalid_argument("fed_frames: level must be >= 0, got " + std::to_string(task.level));
  if (task.first < 0) throw std::invalid_argument("fed_frames: first must be >= 0, got " + std::to_string(task.first));
  if (task.last <= task.first)
    throw std::invalid_argument("fed_frames: last must be > first, got (" + std::to_string(task.first) + ", " +
                                std::to_string(task.last) + "]");
  if (task.level == 0) return std::nullopt;
  return FrameRange{task.level - 1, std::max(task.first - 1, 0), task.last - 1};
}

std::optional<FrameRange> produced_frames(const NewTask& task) {
  if (task.kind != protocol::TaskKind::level) return std::nullopt;
  fed_frames(task);  // the same checks
  return FrameRange{task.level, task.first == 0 ? 0 : task.first + 1 + task.guides, task.last};
}

std::optional<FrameRange> guide_frames(const NewTask& task) {
  if (task.kind != protocol::TaskKind::level || task.guides <= 0) return std::nullopt;
  fed_frames(task);
  return FrameRange{task.level, task.first + 1, task.first + task.guides};
}

}  // namespace pd::farm
