#include "physics/hessian_projection.h"

namespace pd {

bool parse_hessian_projection(const std::string& text, HessianProjection& out) {
  if (text == "none") { out = HessianProjection::None; return true; }
  if (text == "clamp") { out = HessianProjection::Clamp; return true; }
  if (text == "abs") { out = HessianProjection::Abs; return true; }
  if (text == "exact_first") { out = HessianProjection::ExactFirst; return true; }
  return false;
}

const char* to_string(HessianProjection p) {
  switch (p) {
    case HessianProjection::None: return "none";
    case HessianProjection::Clamp: return "clamp";
    case HessianProjection::Abs: return "abs";
    case HessianProjection::ExactFirst: return "exact_first";
  }
  return "?";
}

}  // namespace pd
