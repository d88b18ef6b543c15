#include "core/factors/noise_model.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <sstream>

namespace slamd::core {
namespace {

Status CheckSquareFinite(const Eigen::MatrixXd& m, const char* what) {
  if (m.rows() != m.cols()) {
    return InvalidArgument(std::string(what) + " is " + std::to_string(m.rows()) + "x" +
                           std::to_string(m.cols()) + ", not square");
  }
  if (m.rows() < 1) return InvalidArgument(std::string(what) + " is empty");
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
  const Matrix R = llt.matrixU();
  return NoiseModel(kind, R);
}

Result<NoiseModel> NoiseModel::Isotropic(int dim, double sigma) {
  if (dim < 1) {
    return InvalidArgument("isotropic noise dimension " + std::to_string(dim) + " is not >= 1");
  }
  if (!(sigma > 0.0) || !std::isfinite(sigma)) {
    return InvalidArgument("isotropic sigma " + std::to_string(sigma) + " must be positive and finite");
  }
  return NoiseModel(Kind::kIsotropic, Matrix::Identity(dim, dim) / sigma);
}

Result<NoiseModel> NoiseModel::Diagonal(const Eigen::VectorXd& sigmas) {
  if (sigmas.size() < 1) return InvalidArgument("diagonal noise has no sigmas");
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
  Matrix R = Matrix::Zero(sigmas.size(), sigmas.size());
  R.diagonal() = sigmas.cwiseInverse();
  return NoiseModel(Kind::kDiagonal, R);
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
  return NoiseModel(Kind::kIsotropic, Matrix::Identity(dim, dim));
}

Eigen::MatrixXd NoiseModel::Information() const { return R_.transpose() * R_; }

Eigen::MatrixXd NoiseModel::Covariance() const {
  const Eigen::MatrixXd Rinv =
      R_.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(dim(), dim()));
  return Rinv * Rinv.transpose();
}

Eigen::VectorXd NoiseModel::Sigmas() const { return Covariance().diagonal().cwiseSqrt(); }

double NoiseModel::SquaredMahalanobis(const Eigen::Ref<const Eigen::VectorXd>& e) const {
  SLAMD_DCHECK(e.size() == dim());
  const Eigen::VectorXd w = R_.triangularView<Eigen::Upper>() * e;
  return w.squaredNorm();
}

bool NoiseModel::Equals(const NoiseModel& other, double tol) const {
  return dim() == other.dim() && (R_ - other.R_).cwiseAbs().maxCoeff() <= tol;
}

}  // namespace slamd::core
