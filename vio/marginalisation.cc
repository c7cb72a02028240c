#include "vio/marginalisation.h"

#include <map>
#include <stdexcept>

#include "vio/factors.h"
#include "vio/so3.h"

namespace iapsim::vio {
namespace {

// x ⊟ x₀ of one block, and the derivative of that difference with respect to x's tangent.
Eigen::VectorXd BoxMinus(const ParameterInfo& block, const double* x, const double* x0,
                         Eigen::MatrixXd* d_dx) {
  const int n = block.TangentSize();
  Eigen::VectorXd d(n);
  *d_dx = Eigen::MatrixXd::Identity(n, n);
  if (block.is_pose) {
    PoseManifold().Minus(x, x0, d.data());
    d_dx->bottomRightCorner<3, 3>() = RightJacobianInverse(d.tail<3>());
  } else {
    for (int k = 0; k < n; ++k) d(k) = x[k] - x0[k];
  }
  return d;
}

// The eigenvalues of a symmetric matrix at or below epsilon as zero: its pseudo-inverse, or its square root
// factor.
Eigen::MatrixXd PseudoInverse(const Eigen::MatrixXd& A, double epsilon) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(0.5 * (A + A.transpose()));
  const Eigen::VectorXd inverse =
      (eigen.eigenvalues().array() > epsilon).select(eigen.eigenvalues().array().inverse(), 0.0);
  return eigen.eigenvectors() * inverse.asDiagonal() * eigen.eigenvectors().transpose();
}

}  // namespace

MarginalPrior Marginalise(const std::vector<LinearisedBlock>& residuals,
                          const std::vector<ParameterInfo>& parameters,
                          const std::vector<double*>& marginalised, double epsilon) {
  // Order: the marginalised blocks first, then the kept ones, each at its tangent offset.
  std::map<const double*, ParameterInfo> info;
  for (const ParameterInfo& p : parameters) info[p.values] = p;
  std::vector<ParameterInfo> order;
  std::map<const double*, int> offset;
  int m = 0, n = 0;
  auto place = [&](double* values) {
    if (offset.count(values) != 0) return;
    const auto it = info.find(values);
    if (it == info.end()) throw std::invalid_argument("Marginalise: a residual touches an undescribed block");
    offset[values] = n;
    n += it->second.TangentSize();
    order.push_back(it->second);
  };
  for (double* values : marginalised) place(values);
  m = n;
  for (const LinearisedBlock& r : residuals) {
    for (double* values : r.parameters) place(values);
  }

  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(n);
  for (const LinearisedBlock& r : residuals) {
    const int rows = r.cost->num_residuals();
    const std::vector<int32_t>& sizes = r.cost->parameter_block_sizes();
    Eigen::VectorXd residual(rows);
    std::vector<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jacobians(
        sizes.size());
    std::vector<double*> jacobian_pointers;
    for (std::size_t k = 0; k < sizes.size(); ++k) {
      jacobians[k].resize(rows, sizes[k]);
      jacobian_pointers.push_back(jacobians[k].data());
    }
    std::vector<const double*> values(r.parameters.begin(), r.parameters.end());
    if (!r.cost->Evaluate(values.data(), residual.data(), jacobian_pointers.data())) {
      throw std::runtime_error("Marginalise: a residual block failed to evaluate");
    }
    double scale = 1.0;
    if (r.loss != nullptr) {
      double rho[3];
      r.loss->Evaluate(residual.squaredNorm(), rho);
      scale = std::sqrt(std::max(rho[1], 0.0));
    }
    residual *= scale;
    for (std::size_t a = 0; a < sizes.size(); ++a) {
      const ParameterInfo& pa = info[r.parameters[a]];
      const Eigen::MatrixXd Ja = scale * jacobians[a].leftCols(pa.TangentSize());
      b.segment(offset[r.parameters[a]], pa.TangentSize()) += Ja.transpose() * residual;
      for (std::size_t c = 0; c < sizes.size(); ++c) {
        const ParameterInfo& pc = info[r.parameters[c]];
        const Eigen::MatrixXd Jc = scale * jacobians[c].leftCols(pc.TangentSize());
        H.block(offset[r.parameters[a]], offset[r.parameters[c]], pa.TangentSize(), pc.TangentSize()) +=
            Ja.transpose() * Jc;
      }
    }
  }

  const int k = n - m;
  const Eigen::MatrixXd Hmm_inverse = PseudoInverse(H.topLeftCorner(m, m), epsilon);
  const Eigen::MatrixXd Hkm = H.bottomLeftCorner(k, m);
  const Eigen::MatrixXd S = H.bottomRightCorner(k, k) - Hkm * Hmm_inverse * Hkm.transpose();
  const Eigen::VectorXd bs = b.tail(k) - Hkm * Hmm_inverse * b.head(m);

  // S = V D Vᵀ: J = √D Vᵀ and r₀ = √D⁻¹ Vᵀ b*, so that Jᵀ J = S and Jᵀ r₀ = b*.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(0.5 * (S + S.transpose()));
  const Eigen::ArrayXd d = (eigen.eigenvalues().array() > epsilon).select(eigen.eigenvalues().array(), 0.0);
  const Eigen::ArrayXd d_inverse_sqrt = (d > 0.0).select(d.sqrt().inverse(), 0.0);
  MarginalPrior prior;
  prior.J = d.sqrt().matrix().asDiagonal() * eigen.eigenvectors().transpose();
  prior.r0 = d_inverse_sqrt.matrix().asDiagonal() * eigen.eigenvectors().transpose() * bs;
  for (std::size_t i = marginalised.size(); i < order.size(); ++i) {
    prior.blocks.push_back(order[i]);
    prior.linearisation_point.emplace_back(order[i].values, order[i].values + order[i].ambient_size);
  }
  return prior;
}

MarginalPriorFactor::MarginalPriorFactor(std::shared_ptr<const MarginalPrior> prior)
    : prior_(std::move(prior)) {
  set_num_residuals(static_cast<int>(prior_->r0.size()));
  for (const ParameterInfo& block : prior_->blocks)
    mutable_parameter_block_sizes()->push_back(block.ambient_size);
}

bool MarginalPriorFactor::Evaluate(double const* const* parameters, double* residuals,
                                   double** jacobians) const {
  const MarginalPrior& p = *prior_;
  Eigen::Map<Eigen::VectorXd> r(residuals, p.r0.size());
  r = p.r0;
  int offset = 0;
  for (std::size_t i = 0; i < p.blocks.size(); ++i) {
    const int n = p.blocks[i].TangentSize();
    Eigen::MatrixXd d_dx;
    const Eigen::VectorXd dx = BoxMinus(p.blocks[i], parameters[i], p.linearisation_point[i].data(), &d_dx);
    r += p.J.middleCols(offset, n) * dx;
    if (jacobians != nullptr && jacobians[i] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(
          jacobians[i], p.r0.size(), p.blocks[i].ambient_size);
      J.setZero();
      J.leftCols(n) = p.J.middleCols(offset, n) * d_dx;
    }
    offset += n;
  }
  return true;
}

}  // namespace iapsim::vio
