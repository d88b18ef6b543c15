// NoiseModel: the Gaussian noise of one measurement, kept as its upper-triangular square-root
// information matrix R (Ω = RᵀR = Σ⁻¹), which is what whitening needs: a whitened residual is
// R·e, and a whitened Jacobian is R·J, so that |R·e|² is the Mahalanobis distance eᵀΩe.
//
// One representation for every kind (isotropic, diagonal, full): R is small for a measurement
// (at most kMaxResidualDim rows), so a triangular product is as cheap as a diagonal scaling and
// there is no virtual call. The kind is kept only to describe the model (and to write files back
// in their own form).
//
// Construction validates the input and returns an error that says what is wrong (not square, not
// symmetric, not finite, not positive definite with its smallest eigenvalue, ill-conditioned).
#pragma once

#include <Eigen/Core>
#include <string>

#include "core/base/status.h"

namespace slamd::core {

// The largest residual dimension of a fixed-size factor (TypedFactor, factor.h): a 9-parameter
// calibration's prior. Factors whose size is known only at run time may be larger.
inline constexpr int kMaxResidualDim = 9;

class NoiseModel {
 public:
  enum class Kind { kIsotropic, kDiagonal, kGaussian };
  // R is sized exactly (allocated once, when the model is made).
  using Matrix = Eigen::MatrixXd;

  // Condition numbers (largest / smallest eigenvalue of Ω) above this are rejected: such a
  // matrix is numerically singular in double precision and would poison the solve.
  static constexpr double kMaxConditionNumber = 1e14;

  static Result<NoiseModel> Isotropic(int dim, double sigma);
  static Result<NoiseModel> Diagonal(const Eigen::VectorXd& sigmas);
  static Result<NoiseModel> FromCovariance(const Eigen::MatrixXd& covariance);
  static Result<NoiseModel> FromInformation(const Eigen::MatrixXd& information);
  // Any square R with Ω = RᵀR of full rank (need not be triangular; it is re-factored).
  static Result<NoiseModel> FromSqrtInformation(const Eigen::MatrixXd& sqrt_information);

  // A unit model (R = I): the identity whitening, for tests and already-whitened data.
  static NoiseModel Unit(int dim);

  int dim() const { return static_cast<int>(R_.rows()); }
  Kind kind() const { return kind_; }
  // Upper-triangular R with positive diagonal.
  const Matrix& sqrt_information() const { return R_; }
  Eigen::MatrixXd Information() const;
  Eigen::MatrixXd Covariance() const;
  // Standard deviations along the axes (sqrt of the covariance diagonal).
  Eigen::VectorXd Sigmas() const;

  // e ← R·e and each J ← R·J, for fixed-size residuals of dimension M == dim(). Through a
  // fixed-size copy of R (its strictly lower part is zero): Eigen unrolls a dense fixed-size
  // product, where a triangular product of a block of the dynamic R_ went through its general
  // kernel, whose set-up cost more than the arithmetic (a third of linearising a Pose3 factor).
  template <int M>
  void WhitenInPlace(Eigen::Matrix<double, M, 1>* e) const {
    const Eigen::Matrix<double, M, M> R = R_.template topLeftCorner<M, M>();
    *e = R * *e;
  }
  template <int M, int D>
  void WhitenInPlace(Eigen::Matrix<double, M, D>* J) const {
    const Eigen::Matrix<double, M, M> R = R_.template topLeftCorner<M, M>();
    *J = R * *J;
  }
  // |R·e|² for a residual e of dimension dim().
  double SquaredMahalanobis(const Eigen::Ref<const Eigen::VectorXd>& e) const;

  bool Equals(const NoiseModel& other, double tol = 1e-12) const;

 private:
  NoiseModel(Kind kind, const Matrix& R) : kind_(kind), R_(R) {}
  // Builds the model from an information matrix already checked to be square and finite.
  static Result<NoiseModel> FromCheckedInformation(Kind kind, const Eigen::MatrixXd& information,
                                                   const char* what);

  Kind kind_;
  Matrix R_;
};

}  // namespace slamd::core
