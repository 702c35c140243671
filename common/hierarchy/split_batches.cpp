#include "hierarchy/split_batches.h"

#include <algorithm>
#include <map>

namespace pd {

namespace {

// Vertices of a collapse's patch: every vertex of faces_before (they include both ends of the edge
// and every vertex of faces_after), sorted and unique.
std::vector<int> patch_vertices(const Collapse& c) {
  std::vector<int> v;
  v.reserve(3 * c.faces_before.size());
  for (const Tri& t : c.faces_before) v.insert(v.end(), t.begin(), t.end());
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  return v;
}

}  // namespace

std::vector<std::vector<int>> split_batches(const std::vector<Collapse>& collapses) {
  // Highest batch among the already processed (later) collapses touching each vertex; ordered map
  // keyed by vertex id (ids are the fine level's, possibly sparse).
  std::map<int, int> last_batch;
  std::vector<std::vector<int>> batches;
  for (int k = static_cast<int>(collapses.size()) - 1; k >= 0; --k) {
    const std::vector<int> patch = patch_vertices(collapses[static_cast<std::size_t>(k)]);
    int batch = 0;
    for (int v : patch) {
      const auto it = last_batch.find(v);
      if (it != last_batch.end()) batch = std::max(batch, it->second + 1);
    }
    for (int v : patch) {
      int& b = last_batch[v];
      b = std::max(b, batch);
    }
    if (batch >= static_cast<int>(batches.size())) batches.resize(static_cast<std::size_t>(batch) + 1);
    batches[static_cast<std::size_t>(batch)].push_back(k);
  }
  return batches;
}

}  // namespace pd
