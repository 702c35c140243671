#include "scene/scene.h"

namespace pd {

double Material::bending_rigidity() const {
  const double e_bend = bending_youngs_modulus.value_or(youngs_modulus);
  return e_bend * thickness * thickness * thickness / (12.0 * (1.0 - poisson_ratio * poisson_ratio));
}

}  // namespace pd
