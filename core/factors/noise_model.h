// NoiseModel: the Gaussian noise of one measurement, kept as its upper-triangular square-root
// information matrix R (Ω = RᵀR = Σ⁻¹), which is what whitening needs: a whitened residual is
// R·e, and a whitened Jacobian is R·J, so that |R·e|² is the Mahalanobis distance eᵀΩe.
//
// One representation for every kind (isotropic, diagonal, full): R is small for a measurement
// (at most kMaxResidualDim rows), so a triangular product is as cheap as a diagonal scaling and
// there is no virtual call. The kind is kept only to describe the model (and to write files back
// in their own form). R's upper triangle is stored packed, inside the model up to dimension 3.
//
// Construction validates the input and returns an error that says what is wrong (not square, not
// symmetric, not finite, not positive definite with its smallest eigenvalue, ill-conditioned).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/base/check.h"
#include "core/base/status.h"

namespace slamd::core {

// The largest residual dimension of a fixed-size factor (TypedFactor, factor.h): a 9-parameter
// calibration's prior. Factors whose size is known only at run time may be larger.
inline constexpr int kMaxResidualDim = 9;

class NoiseModel {
 public:
  enum class Kind : std::uint8_t { kIsotropic, kDiagonal, kGaussian };

  // Condition numbers (largest / smallest eigenvalue of Ω) above this are rejected: such a
  // matrix is numerically singular in double precision and would poison the solve.
  static constexpr double kMaxConditionNumber = 1e14;
  // The largest dimension (the size of the count that holds it).
  static constexpr int kMaxDim = 65535;

  static Result<NoiseModel> Isotropic(int dim, double sigma);
  static Result<NoiseModel> Diagonal(const Eigen::VectorXd& sigmas);
  static Result<NoiseModel> FromCovariance(const Eigen::MatrixXd& covariance);
  static Result<NoiseModel> FromInformation(const Eigen::MatrixXd& information);
  // Any square R with Ω = RᵀR of full rank (need not be triangular; it is re-factored).
  static Result<NoiseModel> FromSqrtInformation(const Eigen::MatrixXd& sqrt_information);

  // A unit model (R = I): the identity whitening, for tests and already-whitened data.
  static NoiseModel Unit(int dim);

  NoiseModel(const NoiseModel& other);
  NoiseModel& operator=(const NoiseModel& other);
  NoiseModel(NoiseModel&& other) noexcept;
  NoiseModel& operator=(NoiseModel&& other) noexcept;
  ~NoiseModel() { Free(); }

  int dim() const { return dim_; }
  Kind kind() const { return kind_; }
  // Upper-triangular R with positive diagonal, as a dense matrix (allocates: for records, files
  // and tests; whitening uses Whiten and WhitenInPlace).
  Eigen::MatrixXd sqrt_information() const;
  Eigen::MatrixXd Information() const;
  Eigen::MatrixXd Covariance() const;
  // Standard deviations along the axes (sqrt of the covariance diagonal).
  Eigen::VectorXd Sigmas() const;

  // w ← R·e for dim() entries (w and e must not overlap).
  void Whiten(const double* e, double* w) const;
  // e ← R·e and each J ← R·J, for fixed-size residuals of dimension M == dim(). Through a
  // fixed-size copy of R: Eigen unrolls a dense fixed-size product, where a triangular product
  // of a dynamic R went through its general kernel, whose set-up cost more than the arithmetic
  // (a third of linearising a Pose3 factor).
  template <int M>
  void WhitenInPlace(Eigen::Matrix<double, M, 1>* e) const {
    *e = FixedR<M>() * *e;
  }
  template <int M, int D>
  void WhitenInPlace(Eigen::Matrix<double, M, D>* J) const {
    *J = FixedR<M>() * *J;
  }
  // |R·e|² for a residual e of dimension dim().
  double SquaredMahalanobis(const Eigen::Ref<const Eigen::VectorXd>& e) const;

  bool Equals(const NoiseModel& other, double tol = 1e-12) const;

 private:
  // R's upper triangle is kept packed, column by column (R(r, c) for r <= c at c(c+1)/2 + r);
  // up to this dimension inside the object: a 2D pose or point measurement's model allocates
  // nothing (a graph holds one model per factor).
  static constexpr int kInlineDim = 3;
  static constexpr int kInlineEntries = kInlineDim * (kInlineDim + 1) / 2;
  static constexpr std::size_t PackedSize(int dim) {
    return static_cast<std::size_t>(dim) * (dim + 1) / 2;
  }

  // `R` square with a zero strictly lower part; its dimension is at most kMaxDim (checked).
  NoiseModel(Kind kind, const Eigen::MatrixXd& R);
  // Sets the dimension and makes room for its packed entries (left unset).
  void Allocate(int dim);
  void Free();
  const double* packed() const { return dim_ > kInlineDim ? heap_ : inline_; }
  double* packed() { return dim_ > kInlineDim ? heap_ : inline_; }

  // R's upper triangle written into the dim() x dim() `R` (its strictly lower part untouched).
  template <typename Matrix>
  void UnpackInto(Matrix* R) const {
    const double* p = packed();
    for (int c = 0; c < dim_; ++c) {
      for (int r = 0; r <= c; ++r) (*R)(r, c) = *p++;
    }
  }
  template <int M>
  Eigen::Matrix<double, M, M> FixedR() const {
    SLAMD_DCHECK(M == dim_) << "whitening a " << M << "-vector with a " << dim_ << "-dim model";
    Eigen::Matrix<double, M, M> R = Eigen::Matrix<double, M, M>::Zero();
    UnpackInto(&R);
    return R;
  }

  // Builds the model from an information matrix already checked to be square and finite.
  static Result<NoiseModel> FromCheckedInformation(Kind kind, const Eigen::MatrixXd& information,
                                                   const char* what);

  union {
    double inline_[kInlineEntries];
    double* heap_;  // PackedSize(dim_) entries, when dim_ > kInlineDim
  };
  std::uint16_t dim_ = 0;
  Kind kind_ = Kind::kGaussian;
};

}  // namespace slamd::core
