#include "core/inference/jacobian_factor.h"

#include <string>

#include "core/base/check.h"

namespace slamd::core {

Result<JacobianFactor> JacobianFactor::Create(std::span<const int> vars,
                                              std::span<const Eigen::MatrixXd> blocks,
                                              const Eigen::VectorXd& b) {
  if (vars.size() != blocks.size()) {
    return InvalidArgument("JacobianFactor: " + std::to_string(vars.size()) + " variables but " +
                           std::to_string(blocks.size()) + " blocks");
  }
  std::vector<int> dims(blocks.size());
  for (size_t k = 0; k < blocks.size() && k < vars.size(); ++k) {
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
  if (dims.size() != vars.size()) {
    return InvalidArgument("JacobianFactor: " + std::to_string(dims.size()) + " dims for " +
                           std::to_string(vars.size()) + " variables");
  }
  for (size_t k = 0; k < vars.size(); ++k) {
    if (dims[k] < 1) {
      return InvalidArgument("JacobianFactor: variable " + std::to_string(vars[k]) + " has dim " +
                             std::to_string(dims[k]));
    }
  }
  linear_.Reset(rows, dims);
  SLAMD_RETURN_IF_ERROR(SetVars(vars));
  linear_.MutableAb().setZero();
  return Status::Ok();
}

Status JacobianFactor::SetVars(std::span<const int> ids) {
  if (ids.empty()) return InvalidArgument("JacobianFactor: no variables");
  if (static_cast<int>(ids.size()) != linear_.num_keys()) {
    return InvalidArgument("JacobianFactor: " + std::to_string(ids.size()) +
                           " ids for a factor on " + std::to_string(linear_.num_keys()) + " keys");
  }
  for (size_t k = 0; k < ids.size(); ++k) {
    if (ids[k] < 0) return InvalidArgument("JacobianFactor: negative variable id");
    for (size_t j = 0; j < k; ++j) {
      if (ids[j] == ids[k]) {
        return InvalidArgument("JacobianFactor: variable " + std::to_string(ids[k]) +
                               " listed twice");
      }
    }
  }
  vars_.assign(ids);
  return Status::Ok();
}

Status JacobianFactor::Assign(const LinearizedFactor& linearized, std::span<const int> ids) {
  if (linearized.num_keys() < 1 || linearized.rows() < 1) {
    return InvalidArgument("JacobianFactor::Assign: an empty linearised factor");
  }
  linear_ = linearized;
  SLAMD_RETURN_IF_ERROR(SetVars(ids));
  if (!Ab().allFinite()) return InvalidArgument("JacobianFactor::Assign: non-finite entries");
  return Status::Ok();
}

Status JacobianFactor::Linearize(const Factor& factor, const Values& values,
                                 std::span<const int> ids) {
  factor.Linearize(values, &linear_);
  SLAMD_RETURN_IF_ERROR(SetVars(ids));
  if (!Ab().allFinite()) return InvalidArgument("non-finite entries");
  return Status::Ok();
}

double JacobianFactor::Error(std::span<const int> var_offsets, const Eigen::VectorXd& delta) const {
  Eigen::VectorXd r = b();
  for (int k = 0; k < num_vars(); ++k)
    r.noalias() += A(k) * delta.segment(var_offsets[vars_[k]], dim(k));
  return r.squaredNorm();
}

void JacobianFactor::RenumberVariables(std::span<const int> new_id) {
  for (std::size_t k = 0; k < vars_.size(); ++k) {
    const int v = new_id[vars_[k]];
    SLAMD_CHECK(v >= 0) << "JacobianFactor: variable " << vars_[k] << " renumbered to " << v;
    vars_[k] = v;
  }
}

}  // namespace slamd::core
