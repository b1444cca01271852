// GMRES on (I - T) u = e, matrix-free, one colour channel at a time (solve/krylov.h).
#include "polyrad/solve/krylov.h"

#include <unsupported/Eigen/IterativeSolvers>

namespace polyrad {
class ChannelSystem;
}

namespace Eigen::internal {
// The wrapper behaves like a sparse matrix for Eigen's iterative solvers.
template <>
struct traits<polyrad::ChannelSystem> : public traits<Eigen::SparseMatrix<double>> {};
}  // namespace Eigen::internal

namespace polyrad {

// I - T_c as an Eigen operator: only rows(), cols() and the product are needed.
class ChannelSystem : public Eigen::EigenBase<ChannelSystem> {
 public:
  using Scalar = double;
  using RealScalar = double;
  using StorageIndex = int;
  enum {
    ColsAtCompileTime = Eigen::Dynamic,
    MaxColsAtCompileTime = Eigen::Dynamic,
    IsRowMajor = false
  };

  ChannelSystem(const TransportOperator& t, int channel) : t_(t), channel_(channel) {}
  Eigen::Index rows() const { return t_.size(); }
  Eigen::Index cols() const { return t_.size(); }
  template <typename Rhs>
  Eigen::Product<ChannelSystem, Rhs, Eigen::AliasFreeProduct> operator*(
      const Eigen::MatrixBase<Rhs>& x) const {
    return Eigen::Product<ChannelSystem, Rhs, Eigen::AliasFreeProduct>(*this, x.derived());
  }
  // y = x - T_c x
  void apply(const Eigen::VectorXd& x, Eigen::VectorXd& y) const {
    y.resize(x.size());
    t_.apply_channel(x.data(), y.data(), channel_);
    y = x - y;
    ++products_;
  }
  long long products() const { return products_; }

 private:
  const TransportOperator& t_;
  int channel_;
  mutable long long products_ = 0;
};

}  // namespace polyrad

namespace Eigen::internal {
template <typename Rhs>
struct generic_product_impl<polyrad::ChannelSystem, Rhs, SparseShape, DenseShape, GemvProduct>
    : generic_product_impl_base<polyrad::ChannelSystem, Rhs,
                                generic_product_impl<polyrad::ChannelSystem, Rhs>> {
  using Scalar = typename Product<polyrad::ChannelSystem, Rhs>::Scalar;
  template <typename Dest>
  static void scaleAndAddTo(Dest& dst, const polyrad::ChannelSystem& lhs, const Rhs& rhs,
                            const Scalar& alpha) {
    Eigen::VectorXd x = rhs, y;
    lhs.apply(x, y);
    dst.noalias() += alpha * y;
  }
};
}  // namespace Eigen::internal

namespace polyrad {

bool gmres_solve(const TransportOperator& t, const Field& e, double tolerance, int max_products,
                 Field& u, long long& products, std::string& message) {
  bool ok = true;
  products = 0;
  u.resize(e.rows(), 3);
  for (int c = 0; c < 3; ++c) {
    ChannelSystem a(t, c);
    Eigen::GMRES<ChannelSystem, Eigen::IdentityPreconditioner> gmres;
    gmres.set_restart(50);
    gmres.setTolerance(tolerance);
    gmres.setMaxIterations(std::max(1, max_products / 3));
    gmres.compute(a);
    Eigen::VectorXd rhs = e.col(c);
    Eigen::VectorXd x = gmres.solveWithGuess(rhs, rhs);
    products += a.products();
    if (gmres.info() != Eigen::Success) {
      ok = false;
      message = "GMRES did not converge in channel " + std::to_string(c) + " (estimated error " +
                std::to_string(gmres.error()) + ")";
    }
    u.col(c) = x;
  }
  return ok;
}

}  // namespace polyrad
