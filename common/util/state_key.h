#pragma once
// The state a cache was filled at, compared bit for bit.
//
// Why: Newton asks several questions at one state (the line search's value at the accepted trial,
// then the gradient and the Hessian there), and an energy term can keep what the first question
// computed per element (a hinge's angle, a triangle's stress) for the next. A result reused only
// while x is the same to the last bit is the result a recomputation would give, so frames do not
// change. Bits, not ==: -0.0 == 0.0 and NaN != NaN, and neither should decide whether to reuse.
// Not thread-safe, as the caches it guards (mutable members of const energy terms).
#include <cstring>

#include <Eigen/Core>

namespace pd {

class StateKey {
 public:
  // True when set() was last given a vector with the same size and bits as x, and clear() was not
  // called since.
  bool matches(const Eigen::VectorXd& x) const {
    return valid_ && x.size() == x_.size() &&
           (x.size() == 0 || std::memcmp(x.data(), x_.data(), sizeof(double) * static_cast<size_t>(x.size())) == 0);
  }
  // Call after the cache is filled for x (so that an exception while filling leaves it invalid).
  void set(const Eigen::VectorXd& x) {
    x_ = x;
    valid_ = true;
  }
  // Call before refilling the cache, or when what it depends on other than x changes.
  void clear() { valid_ = false; }

 private:
  Eigen::VectorXd x_;
  bool valid_ = false;
};

}  // namespace pd
