#pragma once
// The statistics stored with every frame (docs/frame-format.md, /levels/<l>/stats): Newton's work,
// timings, energies by term, contact figures, centres of mass. One place, so direct and progressive
// runs store the same keys.
#include "progressive/level_stepper.h"
#include "store/frame_store.h"

namespace pd {

FrameStats frame_stats(const FrameRecord& r);

}  // namespace pd
