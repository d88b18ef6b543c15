#include "core/inference/hessian_factor.h"

#include <algorithm>
#include <array>
#include <string>

#include "core/base/check.h"
#include "core/base/storage.h"
#include "core/inference/jacobian_factor.h"

namespace slamd::core {

Result<HessianFactor> HessianFactor::Create(std::span<const int> vars, std::span<const int> dims,
                                            const Eigen::MatrixXd& info) {
  if (dims.size() != vars.size()) {
    return InvalidArgument("HessianFactor: " + std::to_string(dims.size()) + " dims for " +
                           std::to_string(vars.size()) + " variables");
  }
  int total = 0;
  for (size_t k = 0; k < vars.size(); ++k) {
    if (vars[k] < 0) return InvalidArgument("HessianFactor: negative variable id");
    if (dims[k] < 1) {
      return InvalidArgument("HessianFactor: variable " + std::to_string(vars[k]) + " has dim " +
                             std::to_string(dims[k]));
    }
    for (size_t j = 0; j < k; ++j) {
      if (vars[j] == vars[k]) {
        return InvalidArgument("HessianFactor: variable " + std::to_string(vars[k]) +
                               " listed twice");
      }
    }
    total += dims[k];
  }
  if (info.rows() != total + 1 || info.cols() != total + 1) {
    return InvalidArgument("HessianFactor: info is " + std::to_string(info.rows()) + " x " +
                           std::to_string(info.cols()) + ", expected " + std::to_string(total + 1) +
                           " square");
  }
  if (!info.allFinite()) return InvalidArgument("HessianFactor: non-finite info");
  const double scale = info.cwiseAbs().maxCoeff();
  if ((info - info.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) {
    return InvalidArgument("HessianFactor: info is not symmetric");
  }
  HessianFactor h;
  h.Reset(vars, dims);
  h.Pack(info);
  h.SetReferenceToDiagonal();
  return h;
}

HessianFactor HessianFactor::FromJacobian(const JacobianFactor& jacobian) {
  std::vector<int> dims(jacobian.num_vars());
  for (int k = 0; k < jacobian.num_vars(); ++k) dims[k] = jacobian.dim(k);
  HessianFactor h;
  h.Reset(jacobian.vars(), dims);
  h.Pack(jacobian.Ab().transpose() * jacobian.Ab());
  h.SetReferenceToDiagonal();
  return h;
}

void HessianFactor::Pack(const Eigen::MatrixXd& info) {
  const int n = Dim() + 1;
  for (int j = 0; j < n; ++j) std::copy_n(&info(j, j), n - j, mutable_column(j));
}

Eigen::MatrixXd HessianFactor::Info() const {
  const int n = Dim() + 1;
  Eigen::MatrixXd info(n, n);
  for (int j = 0; j < n; ++j) {
    for (int i = j; i < n; ++i) info(i, j) = info(j, i) = column(j)[i - j];
  }
  return info;
}

void HessianFactor::Reset(std::span<const int> vars, std::span<const int> dims) {
  Reshape(vars, dims);
  std::fill(data_.begin(), data_.end(), 0.0);
}

void HessianFactor::Reshape(std::span<const int> vars, std::span<const int> dims) {
  SLAMD_DCHECK(vars.size() == dims.size()) << "HessianFactor::Reshape: size mismatch";
  num_vars_ = static_cast<int>(vars.size());
  index_.resize(2 * vars.size() + 1);
  int offset = 0;
  for (int k = 0; k < num_vars_; ++k) {
    SLAMD_DCHECK(vars[k] >= 0 && dims[k] >= 1) << "HessianFactor::Reshape: bad variable";
    index_[k] = vars[k];
    index_[num_vars_ + k] = offset;
    offset += dims[k];
  }
  index_[2 * num_vars_] = offset;
  ResizeReusingStorage(&data_, DataDoubles(offset));
}

void HessianFactor::SetReferenceToDiagonal() {
  for (int j = 0; j < Dim(); ++j) mutable_reference()[j] = column(j)[0];
}

double HessianFactor::Error(std::span<const int> var_offsets, const Eigen::VectorXd& delta) const {
  const int n = Dim();
  Eigen::VectorXd y(n + 1);
  for (int k = 0; k < num_vars_; ++k) {
    y.segment(offset(k), dim(k)) = delta.segment(var_offsets[var(k)], dim(k));
  }
  y(n) = 1.0;
  double error = 0.0;  // yᵀ info y from the lower triangle: diagonal once, the rest twice
  for (int j = 0; j <= n; ++j) {
    const double* c = column(j);
    double below = 0.0;
    for (int i = j + 1; i <= n; ++i) below += c[i - j] * y(i);
    error += y(j) * (c[0] * y(j) + 2.0 * below);
  }
  return error;
}

void HessianFactor::RenumberVariables(std::span<const int> new_id) {
  for (int k = 0; k < num_vars_; ++k) {
    const int v = new_id[index_[k]];
    SLAMD_CHECK(v >= 0) << "HessianFactor: variable " << index_[k] << " renumbered to " << v;
    index_[k] = v;
  }
}

}  // namespace slamd::core
