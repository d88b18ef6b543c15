#include "core/factors/noise_model.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>

namespace slamd::core {
namespace {

Status CheckSquareFinite(const Eigen::MatrixXd& m, const char* what) {
  if (m.rows() != m.cols()) {
    return InvalidArgument(std::string(what) + " is " + std::to_string(m.rows()) + "x" +
                           std::to_string(m.cols()) + ", not square");
  }
  if (m.rows() < 1) return InvalidArgument(std::string(what) + " is empty");
  if (m.rows() > NoiseModel::kMaxDim) {
    return InvalidArgument(std::string(what) + " is " + std::to_string(m.rows()) + "x" +
                           std::to_string(m.cols()) + ", larger than a noise model's " +
                           std::to_string(NoiseModel::kMaxDim) + " dimensions");
  }
  if (!m.allFinite()) return InvalidArgument(std::string(what) + " has a NaN or infinite entry");
  return Status::Ok();
}

Status CheckSymmetric(const Eigen::MatrixXd& m, const char* what) {
  const double scale = std::max(1.0, m.cwiseAbs().maxCoeff());
  const double asym = (m - m.transpose()).cwiseAbs().maxCoeff();
  if (asym > 1e-9 * scale) {
    std::ostringstream msg;
    msg << what << " is not symmetric (largest |m - mᵀ| entry " << asym << ")";
    return InvalidArgument(msg.str());
  }
  return Status::Ok();
}

}  // namespace

Result<NoiseModel> NoiseModel::FromCheckedInformation(Kind kind, const Eigen::MatrixXd& information,
                                                      const char* what) {
  const Eigen::MatrixXd sym = 0.5 * (information + information.transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(sym, Eigen::EigenvaluesOnly);
  const double lo = eig.eigenvalues().minCoeff();
  const double hi = eig.eigenvalues().maxCoeff();
  if (!(lo > 0.0)) {
    std::ostringstream msg;
    msg << what << " is not positive definite (smallest eigenvalue of the information " << lo << ")";
    return InvalidArgument(msg.str());
  }
  if (hi / lo > kMaxConditionNumber) {
    std::ostringstream msg;
    msg << what << " is ill-conditioned (information eigenvalues " << lo << " .. " << hi
        << ", condition number " << hi / lo << " > " << kMaxConditionNumber << ")";
    return InvalidArgument(msg.str());
  }
  Eigen::LLT<Eigen::MatrixXd> llt(sym);  // Ω = L Lᵀ, so R = Lᵀ (upper, positive diagonal)
  if (llt.info() != Eigen::Success) {
    return InvalidArgument(std::string(what) + " is not positive definite (Cholesky failed)");
  }
  return NoiseModel(kind, llt.matrixU());
}

Result<NoiseModel> NoiseModel::Isotropic(int dim, double sigma) {
  if (dim < 1 || dim > kMaxDim) {
    return InvalidArgument("isotropic noise dimension " + std::to_string(dim) + " is not in 1.." +
                           std::to_string(kMaxDim));
  }
  if (!(sigma > 0.0) || !std::isfinite(sigma)) {
    return InvalidArgument("isotropic sigma " + std::to_string(sigma) + " must be positive and finite");
  }
  return NoiseModel(Kind::kIsotropic, Eigen::MatrixXd::Identity(dim, dim) / sigma);
}

Result<NoiseModel> NoiseModel::Diagonal(const Eigen::VectorXd& sigmas) {
  if (sigmas.size() < 1) return InvalidArgument("diagonal noise has no sigmas");
  if (sigmas.size() > kMaxDim) {
    return InvalidArgument("diagonal noise has " + std::to_string(sigmas.size()) +
                           " sigmas, more than a noise model's " + std::to_string(kMaxDim));
  }
  for (int i = 0; i < sigmas.size(); ++i) {
    if (!(sigmas[i] > 0.0) || !std::isfinite(sigmas[i])) {
      std::ostringstream msg;
      msg << "diagonal noise sigma[" << i << "] = " << sigmas[i] << " must be positive and finite";
      return InvalidArgument(msg.str());
    }
  }
  const double ratio = sigmas.maxCoeff() / sigmas.minCoeff();
  if (ratio * ratio > kMaxConditionNumber) {
    return InvalidArgument("diagonal noise sigmas span a ratio of " + std::to_string(ratio) +
                           ": the information matrix would be ill-conditioned");
  }
  return NoiseModel(Kind::kDiagonal, sigmas.cwiseInverse().asDiagonal().toDenseMatrix());
}

Result<NoiseModel> NoiseModel::FromCovariance(const Eigen::MatrixXd& covariance) {
  SLAMD_RETURN_IF_ERROR(CheckSquareFinite(covariance, "covariance"));
  SLAMD_RETURN_IF_ERROR(CheckSymmetric(covariance, "covariance"));
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(covariance, Eigen::EigenvaluesOnly);
  if (!(eig.eigenvalues().minCoeff() > 0.0)) {
    std::ostringstream msg;
    msg << "covariance is not positive definite (smallest eigenvalue " << eig.eigenvalues().minCoeff()
        << ")";
    return InvalidArgument(msg.str());
  }
  return FromCheckedInformation(Kind::kGaussian, covariance.inverse(), "covariance");
}

Result<NoiseModel> NoiseModel::FromInformation(const Eigen::MatrixXd& information) {
  SLAMD_RETURN_IF_ERROR(CheckSquareFinite(information, "information matrix"));
  SLAMD_RETURN_IF_ERROR(CheckSymmetric(information, "information matrix"));
  return FromCheckedInformation(Kind::kGaussian, information, "information matrix");
}

Result<NoiseModel> NoiseModel::FromSqrtInformation(const Eigen::MatrixXd& sqrt_information) {
  SLAMD_RETURN_IF_ERROR(CheckSquareFinite(sqrt_information, "square-root information"));
  return FromCheckedInformation(Kind::kGaussian, sqrt_information.transpose() * sqrt_information,
                                "square-root information");
}

NoiseModel NoiseModel::Unit(int dim) {
  SLAMD_CHECK(dim >= 1) << "unit noise dimension " << dim;
  return NoiseModel(Kind::kIsotropic, Eigen::MatrixXd::Identity(dim, dim));
}

NoiseModel::NoiseModel(Kind kind, const Eigen::MatrixXd& R) : kind_(kind) {
  SLAMD_CHECK(R.rows() == R.cols() && R.rows() <= kMaxDim)
      << "square-root information of " << R.rows() << "x" << R.cols();
  Allocate(static_cast<int>(R.rows()));
  double* p = packed();
  for (int c = 0; c < dim_; ++c) {
    for (int r = 0; r <= c; ++r) *p++ = R(r, c);
  }
}

NoiseModel::NoiseModel(const NoiseModel& other) { *this = other; }

NoiseModel& NoiseModel::operator=(const NoiseModel& other) {
  if (this != &other) {
    if (other.dim_ != dim_) {
      Free();
      Allocate(other.dim_);
    }
    std::copy_n(other.packed(), PackedSize(dim_), packed());
    kind_ = other.kind_;
  }
  return *this;
}

NoiseModel::NoiseModel(NoiseModel&& other) noexcept { *this = std::move(other); }

NoiseModel& NoiseModel::operator=(NoiseModel&& other) noexcept {
  if (this != &other) {
    Free();
    if (other.dim_ > kInlineDim) {
      heap_ = std::exchange(other.heap_, nullptr);
    } else {
      std::copy_n(other.inline_, PackedSize(other.dim_), inline_);
    }
    dim_ = std::exchange(other.dim_, std::uint16_t{0});
    kind_ = other.kind_;
  }
  return *this;
}

void NoiseModel::Allocate(int dim) {
  dim_ = static_cast<std::uint16_t>(dim);
  if (dim_ > kInlineDim) heap_ = new double[PackedSize(dim_)];
}

void NoiseModel::Free() {
  if (dim_ > kInlineDim) delete[] heap_;
  dim_ = 0;
}

Eigen::MatrixXd NoiseModel::sqrt_information() const {
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(dim_, dim_);
  UnpackInto(&R);
  return R;
}

Eigen::MatrixXd NoiseModel::Information() const {
  const Eigen::MatrixXd R = sqrt_information();
  return R.transpose() * R;
}

Eigen::MatrixXd NoiseModel::Covariance() const {
  const Eigen::MatrixXd Rinv = sqrt_information().triangularView<Eigen::Upper>().solve(
      Eigen::MatrixXd::Identity(dim(), dim()));
  return Rinv * Rinv.transpose();
}

Eigen::VectorXd NoiseModel::Sigmas() const { return Covariance().diagonal().cwiseSqrt(); }

void NoiseModel::Whiten(const double* e, double* w) const {
  std::fill_n(w, dim_, 0.0);
  const double* p = packed();
  for (int c = 0; c < dim_; ++c) {
    for (int r = 0; r <= c; ++r) w[r] += *p++ * e[c];
  }
}

double NoiseModel::SquaredMahalanobis(const Eigen::Ref<const Eigen::VectorXd>& e) const {
  SLAMD_DCHECK(e.size() == dim());
  if (dim_ <= kMaxResidualDim) {  // the common case: no heap
    double w[kMaxResidualDim];
    Whiten(e.data(), w);
    return Eigen::Map<const Eigen::VectorXd>(w, dim_).squaredNorm();
  }
  Eigen::VectorXd w(dim_);
  Whiten(e.data(), w.data());
  return w.squaredNorm();
}

bool NoiseModel::Equals(const NoiseModel& other, double tol) const {
  if (dim_ != other.dim_) return false;
  const double* a = packed();
  const double* b = other.packed();
  for (std::size_t i = 0; i < PackedSize(dim_); ++i) {
    if (!(std::abs(a[i] - b[i]) <= tol)) return false;
  }
  return true;
}

}  // namespace slamd::core
