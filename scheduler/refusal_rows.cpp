#include "scheduler/refusal_rows.h"

namespace pd::scheduler {

bool RefusalRows::admit(const std::string& identity, double now) {
  auto it = windows_.find(identity);
  if (it == windows_.end()) {
    if (windows_.size() >= kMaxPeers) {
      Window& other = windows_[kOtherPeers];  // may take the map one past kMaxPeers, no further
      if (other.counted == 0 && other.rows == 0) other.start = now;
      ++other.counted;
      return false;
    }
    it = windows_.emplace(identity, Window{now, 0, 0}).first;
  }
  Window& w = it->second;
  if (w.rows < kRowsPerPeer) {
    ++w.rows;
    return true;
  }
  ++w.counted;
  return false;
}

std::vector<RefusalRows::Counted> RefusalRows::closed(double now) {
  std::vector<Counted> out;
  for (auto it = windows_.begin(); it != windows_.end();) {
    if (now - it->second.start < kWindowSeconds) {
      ++it;
      continue;
    }
    if (it->second.counted > 0) out.push_back({it->first, it->second.counted});
    it = windows_.erase(it);
  }
  return out;
}

}  // namespace pd::scheduler
