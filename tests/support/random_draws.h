#pragma once
/// @file
/// Random 3-vectors for the tests and benchmarks, drawn coordinate by coordinate, in order.
///
/// The order in which a call's arguments are evaluated is unspecified: gcc evaluates
/// `Eigen::Vector3d(u(rng), u(rng), u(rng))` right to left, clang left to right, so the two
/// compilers drew different vectors and a randomised test checked different cases under each (a
/// bound that held under one failed under the other). These draw x, then y, then z (clang's
/// order, so CI's clang build checks the cases it always did).

#include <Eigen/Core>

namespace mlmap::test {

/// (dx(rng), dy(rng), dz(rng)), drawn in that order; the scalar type is the first draw's.
template <typename Dx, typename Dy, typename Dz, typename Rng>
auto draw3(Dx& dx, Dy& dy, Dz& dz, Rng& rng) {
  using Scalar = decltype(dx(rng));
  const Scalar x = dx(rng);
  const auto y = static_cast<Scalar>(dy(rng));
  const auto z = static_cast<Scalar>(dz(rng));
  return Eigen::Matrix<Scalar, 3, 1>(x, y, z);
}

/// Three draws of one distribution, in order.
template <typename D, typename Rng>
auto draw3(D& d, Rng& rng) {
  return draw3(d, d, d, rng);
}

}  // namespace mlmap::test
