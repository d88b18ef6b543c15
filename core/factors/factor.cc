#include "core/factors/factor.h"

namespace slamd::core {

double Factor::Chi2(const Values& values) const {
  const NoiseModel::Vector e = Error(values);
  NoiseModel::Vector w = noise_.sqrt_information().triangularView<Eigen::Upper>() * e;
  return w.squaredNorm();
}

}  // namespace slamd::core
