#pragma once
// ContactSettings in one expression, for contact term tests.
#include "physics/contact/barrier_potential.h"

namespace pd::test {

// dhat and offset in m, kappa in J/m^4; ccd_ratio stays the default.
inline ContactSettings contact_settings(double dhat, double offset, double kappa) {
  ContactSettings cs;
  cs.dhat = dhat;
  cs.offset = offset;
  cs.kappa = kappa;
  return cs;
}

}  // namespace pd::test
