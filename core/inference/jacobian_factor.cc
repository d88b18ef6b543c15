#include "core/inference/jacobian_factor.h"

#include <string>

namespace slamd::core {

Result<JacobianFactor> JacobianFactor::Create(std::span<const int> vars,
                                              std::span<const Eigen::MatrixXd> blocks,
                                              const Eigen::VectorXd& b) {
  if (vars.size() != blocks.size()) {
    return InvalidArgument("JacobianFactor: " + std::to_string(vars.size()) + " variables but " +
                           std::to_string(blocks.size()) + " blocks");
  }
  std::array<int, kMaxVars> dims{};
  for (size_t k = 0; k < blocks.size() && k < dims.size(); ++k) {
    if (blocks[k].rows() != b.size()) {
      return InvalidArgument("JacobianFactor: block " + std::to_string(k) + " has " +
                             std::to_string(blocks[k].rows()) + " rows, b has " +
                             std::to_string(b.size()));
    }
    dims[k] = static_cast<int>(blocks[k].cols());
  }
  JacobianFactor f;
  SLAMD_RETURN_IF_ERROR(
      f.Reset(static_cast<int>(b.size()), vars, std::span<const int>(dims.data(), vars.size())));
  for (size_t k = 0; k < vars.size(); ++k) f.mutable_A(static_cast<int>(k)) = blocks[k];
  f.mutable_b() = b;
  if (!f.Ab().allFinite()) return InvalidArgument("JacobianFactor: non-finite entries");
  return f;
}

Status JacobianFactor::Reset(int rows, std::span<const int> vars, std::span<const int> dims) {
  if (rows < 1) return InvalidArgument("JacobianFactor: rows = " + std::to_string(rows) + " < 1");
  if (vars.empty() || vars.size() > static_cast<size_t>(kMaxVars)) {
    return InvalidArgument("JacobianFactor: " + std::to_string(vars.size()) +
                           " variables, expected 1.." + std::to_string(kMaxVars));
  }
  if (dims.size() != vars.size()) {
    return InvalidArgument("JacobianFactor: " + std::to_string(dims.size()) + " dims for " +
                           std::to_string(vars.size()) + " variables");
  }
  for (size_t k = 0; k < vars.size(); ++k) {
    if (vars[k] < 0) return InvalidArgument("JacobianFactor: negative variable id");
    if (dims[k] < 1) {
      return InvalidArgument("JacobianFactor: variable " + std::to_string(vars[k]) + " has dim " +
                             std::to_string(dims[k]));
    }
    for (size_t j = 0; j < k; ++j) {
      if (vars[j] == vars[k]) {
        return InvalidArgument("JacobianFactor: variable " + std::to_string(vars[k]) +
                               " listed twice");
      }
    }
  }
  rows_ = rows;
  num_vars_ = static_cast<int>(vars.size());
  offsets_[0] = 0;
  for (int k = 0; k < num_vars_; ++k) {
    vars_[k] = vars[k];
    offsets_[k + 1] = offsets_[k] + dims[k];
  }
  data_.assign(static_cast<size_t>(rows_) * (Dim() + 1), 0.0);
  return Status::Ok();
}

Status JacobianFactor::Assign(const LinearizedFactor& linearized, std::span<const int> ids) {
  if (static_cast<int>(ids.size()) != linearized.num_keys) {
    return InvalidArgument("JacobianFactor::Assign: " + std::to_string(ids.size()) +
                           " ids for a factor on " + std::to_string(linearized.num_keys) + " keys");
  }
  if (linearized.num_keys < 1 || linearized.num_keys > kMaxFactorKeys) {
    return InvalidArgument("JacobianFactor::Assign: num_keys = " +
                           std::to_string(linearized.num_keys));
  }
  std::array<int, kMaxVars> dims{};
  for (int k = 0; k < linearized.num_keys; ++k) {
    if (linearized.A[k].rows() != linearized.rows) {
      return InvalidArgument("JacobianFactor::Assign: block " + std::to_string(k) + " has " +
                             std::to_string(linearized.A[k].rows()) + " rows, expected " +
                             std::to_string(linearized.rows));
    }
    dims[k] = static_cast<int>(linearized.A[k].cols());
  }
  if (linearized.b.size() != linearized.rows) {
    return InvalidArgument("JacobianFactor::Assign: b has " + std::to_string(linearized.b.size()) +
                           " entries, expected " + std::to_string(linearized.rows));
  }
  SLAMD_RETURN_IF_ERROR(Reset(linearized.rows, ids, std::span<const int>(dims.data(), ids.size())));
  for (int k = 0; k < num_vars_; ++k) mutable_A(k) = linearized.A[k].topRows(rows_);
  mutable_b() = linearized.b.head(rows_);
  if (!Ab().allFinite()) return InvalidArgument("JacobianFactor::Assign: non-finite entries");
  return Status::Ok();
}

double JacobianFactor::Error(std::span<const int> var_offsets, const Eigen::VectorXd& delta) const {
  Eigen::VectorXd r = b();
  for (int k = 0; k < num_vars_; ++k)
    r.noalias() += A(k) * delta.segment(var_offsets[vars_[k]], dim(k));
  return r.squaredNorm();
}

}  // namespace slamd::core
