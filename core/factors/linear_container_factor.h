// LinearContainerFactor: a dense Gaussian factor |Σ_k A_k δ_k + b|² over any number of variables
// of any types, fixed at the linearisation point x₀ it was made at: what marginalising variables
// out leaves on their Markov blanket (Carlevaris-Bianco, Kaess, Eustice, "Generic Node Removal
// for Factor-Graph SLAM", T-RO 2014), or any linearised factor kept as it is.
//
// At other values it is re-linearised by the first-order rule (as GTSAM's LinearContainerFactor):
// e(x) = A·(x₀ ⊖ x) + b, with x₀ ⊖ x the stacked LocalCoordinates(x₀_k, x_k); its Jacobians are
// those of that error, A_k·J_k⁻¹ (J_k the chart's derivative at x_k, the identity at x₀), not A_k
// as GTSAM keeps them: far from x₀ (a map shard's summary on poses another shard placed
// differently) the kept A_k is not the error's slope, and Gauss-Newton climbed. A and b are already
// whitened: the noise model is the unit one and there is no robust kernel. Encoded as b then A
// (column-major); its keys' x₀ are its carried values.
//
// The root-relative form (generic linear constraints with a root shift, the same paper §IV-C):
// the last key is a root pose r (Pose2 or Pose3) and A has no columns for it; each other
// variable enters by its value in the root's frame, so moving all of them rigidly together
// changes nothing: a pose m by Local(r₀⁻¹m₀, r⁻¹m), a point l by R(r₀)·(r⁻¹l − r₀⁻¹l₀) (the
// offset in the root's frame at x₀, turned back to the world's, so that at x₀ the first-order
// rule's coordinates are the plain ones), any other kind by Local(x₀, x) as above. What
// node removal leaves on a blanket whose frame is free (chow_liu.h): a map corrected by a loop
// closure turns and shifts whole regions, and a summary in world coordinates would resist that
// where this one follows it. Encoded as the plain form; A's width tells them apart.
#pragma once

#include "core/factors/factor.h"

namespace slamd::core {

class LinearContainerFactor : public DynamicFactor {
 public:
  static const char* TypeName() { return "LinearContainer"; }

  // A is m x Σ TangentDim(x₀_k), its columns in key order; b has m entries. InvalidArgument on
  // no keys, repeated keys, a count or size that does not match, or non-finite entries.
  static Result<FactorPtr> Create(KeyVector keys, std::vector<Variable> linearization_point,
                                  Eigen::MatrixXd A, Eigen::VectorXd b);
  // The root-relative form: keys.back() is the root, a Pose2 or Pose3, and A is m x Σ
  // TangentDim(x₀_k) over the other keys. Also InvalidArgument on a root of another kind or a
  // point or pose of the other dimension than the root's.
  static Result<FactorPtr> CreateRootRelative(KeyVector keys,
                                              std::vector<Variable> linearization_point,
                                              Eigen::MatrixXd A, Eigen::VectorXd b);
  static Result<FactorPtr> Decode(const FactorRecord& r, NoiseModel noise);

  const char* Name() const override { return TypeName(); }
  const std::vector<Variable>& linearization_point() const { return x0_; }
  const Eigen::MatrixXd& A() const { return A_; }
  const Eigen::VectorXd& b() const { return b_; }
  bool root_relative() const { return root_relative_; }

  void EncodeMeasured(std::vector<double>* out) const override;
  std::vector<Variable> CarriedValues() const override { return x0_; }
  Eigen::VectorXd Evaluate(std::span<const Variable* const> x,
                           std::vector<Eigen::MatrixXd>* H) const override;

  // Use Create; public for std::make_shared.
  LinearContainerFactor(KeyVector keys, std::vector<VariableType> types,
                        std::vector<Variable> linearization_point, Eigen::MatrixXd A,
                        Eigen::VectorXd b, bool root_relative);

 private:
  Eigen::VectorXd EvaluateRootRelative(std::span<const Variable* const> x,
                                       std::vector<Eigen::MatrixXd>* H) const;
  static Result<FactorPtr> Make(KeyVector keys, std::vector<Variable> linearization_point,
                                Eigen::MatrixXd A, Eigen::VectorXd b, bool root_relative);

  std::vector<Variable> x0_;
  Eigen::MatrixXd A_;
  Eigen::VectorXd b_;
  bool root_relative_;
  std::vector<int> offsets_;  // column of each key's block in A (the root's: none)
};

}  // namespace slamd::core
