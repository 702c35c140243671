#pragma once
// Vertex-split batches for safe upsampling (PSQ 4.4, "colour batches precomputed from the collapse
// dependency graph"). Going from level l to level l+1 undoes level l's collapses as vertex splits,
// last collapse first. Two splits can run at the same time when their patches (every vertex of the
// collapse's faces_before) share no vertex: neither changes a face or a position the other reads.
// A split must wait for every later collapse whose patch overlaps its own, since those collapses
// changed faces of its patch after it happened.
//
// Batch numbers: processing collapses from last to first,
//   batch(k) = 1 + max { batch(j) : j > k, patch(j) and patch(k) share a vertex }   (0 if none).
// Splits then run batch 0, 1, 2, ...; within a batch the patches are pairwise vertex-disjoint (two
// overlapping collapses j > k get batch(k) > batch(j)), and every split's prerequisites sit in
// earlier batches. Cost O(total patch size).
#include <vector>

#include "hierarchy/decimation.h"

namespace pd {

// Indices into `collapses` (the order they were performed), grouped by batch: result[b] lists the
// collapses whose splits form batch b, in decreasing collapse index (the order a sequential undo
// would take them).
std::vector<std::vector<int>> split_batches(const std::vector<Collapse>& collapses);

}  // namespace pd
