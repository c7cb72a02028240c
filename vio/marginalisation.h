#pragma once
// Marginalisation of the sliding window's oldest keyframe into a prior on what remains (Schur complement;
// Sibley et al. 2010, Leutenegger et al. "OKVIS" IJRR 2015, and VINS-Mono [52] §VI-D, whose form this
// follows): the residual blocks that touch the marginalised parameters are linearised at the current
// estimate, their normal equations reduced onto the other blocks they touch, and the reduced system
// H* δx = −b* factored as a linear residual r(x) = r₀ + J (x ⊟ x₀) over those blocks. ⊟ is PoseManifold's
// Minus for poses (tangent [δp, δθ]) and subtraction otherwise.

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <memory>
#include <vector>

namespace iapsim::vio {

/// One residual block as it was added to the problem (the cost function and loss are borrowed).
struct LinearisedBlock {
  const ceres::CostFunction* cost = nullptr;
  const ceres::LossFunction* loss = nullptr;  ///< may be null
  std::vector<double*> parameters;
};

/// A parameter block: its storage, and whether it is a pose (7 ambient, 6 tangent).
struct ParameterInfo {
  double* values = nullptr;
  int ambient_size = 0;
  bool is_pose = false;
  int TangentSize() const { return is_pose ? 6 : ambient_size; }
};

/// The prior left by a marginalisation: r(x) = r₀ + J (x ⊟ x₀) over the kept blocks, in their order.
struct MarginalPrior {
  std::vector<ParameterInfo> blocks;
  std::vector<std::vector<double>> linearisation_point;
  Eigen::MatrixXd J;
  Eigen::VectorXd r0;
};

/// Marginalises the blocks `marginalised` (values pointers) out of `residuals`. `parameters` describes every
/// block the residuals touch. Eigenvalues of the marginalised Hessian below `epsilon` are treated as zero
/// (unobserved directions), and so are those of the reduced Hessian. A robust loss enters through its first
/// derivative (residual and Jacobian scaled by √ρ′). Returns the prior over the touched blocks that remain.
MarginalPrior Marginalise(const std::vector<LinearisedBlock>& residuals,
                          const std::vector<ParameterInfo>& parameters,
                          const std::vector<double*>& marginalised, double epsilon = 1e-8);

/// The prior as a Ceres residual over its blocks (in MarginalPrior::blocks order), lifted pose Jacobians as
/// in factors.h.
class MarginalPriorFactor : public ceres::CostFunction {
 public:
  explicit MarginalPriorFactor(std::shared_ptr<const MarginalPrior> prior);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  std::shared_ptr<const MarginalPrior> prior_;
};

}  // namespace iapsim::vio
