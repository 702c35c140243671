#pragma once
// Which refused worker reports become rows of farm.sqlite's events table (issue 47 item 3). Every
// refusal is still answered and still logged as a line on stderr; what is bounded is the table, which
// lives as long as the farm: a hostile peer sending 20 000 malformed reports added 20 000 rows. The
// first kRowsPerPeer refusals of a peer (socket identity) in a window of kWindowSeconds get a row
// each; the rest are counted, and when the window ends the count becomes one row
// ("report_refused_counted"). At most kMaxPeers peers are tracked at once (a peer reconnecting under
// new identities counts against that); refusals beyond it are counted under one shared entry.
// Not thread-safe: the scheduler's loop only.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace pd::scheduler {

class RefusalRows {
 public:
  static constexpr int kRowsPerPeer = 20;
  static constexpr double kWindowSeconds = 60.0;
  static constexpr std::size_t kMaxPeers = 4096;
  // The shared entry's identity (not a ZeroMQ routing id: those are 5 bytes starting with 0).
  static constexpr const char* kOtherPeers = "(other peers)";

  // Whether this refusal of `identity` at `now` (s) gets its own row; false: it is counted.
  bool admit(const std::string& identity, double now);

  struct Counted {
    std::string identity;  // as given to admit, or kOtherPeers
    int64_t refusals = 0;  // counted beyond the rows, in the window that ended
  };
  // The windows that ended by `now` and had refusals counted; those windows are forgotten (and so
  // are the ended ones with nothing counted).
  std::vector<Counted> closed(double now);

  std::size_t tracked() const { return windows_.size(); }

 private:
  struct Window {
    double start = 0.0;
    int rows = 0;
    int64_t counted = 0;
  };
  std::map<std::string, Window> windows_;
};

}  // namespace pd::scheduler
