#pragma once
// One line describing a safe upsampling's report (hierarchy/safe_upsampling.h UpsamplingReport), as
// pd_bench_hierarchy and pd_bench_upsample_frame print it: counts, gaps (m), target distances (m),
// stretch, and the wall time split into its phases (s).
#include <string>

#include "hierarchy/safe_upsampling.h"

namespace pd::bench {

std::string describe_upsampling(const UpsamplingReport& r);

}  // namespace pd::bench
