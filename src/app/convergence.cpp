// Iterative methods on a scene, products against error (app/convergence.h).
#include "polyrad/app/convergence.h"

#include <cstdio>
#include <filesystem>
#include <sstream>

namespace polyrad {

std::vector<ConvergenceRow> convergence(const std::vector<std::string>& paths,
                                        const ConvergenceOptions& o) {
  std::vector<ConvergenceRow> rows;
  std::fprintf(stderr, "%-28s %7s %-13s %10s %12s\n", "scene", "a_max", "method", "products",
               "err@budget");
  for (const auto& path : paths) {
    auto sys = build_system(World::load(path, o.overrides, o.scene), o.system);
    const TransportOperator& t = sys->transport;
    const Field e = t.emission();
    if (!(t.max_albedo() < 1.0))
      throw NumericalError(path + ": no finite solution to converge to; " + t.divergence_hint());
    SolveOptions ref;
    ref.method = SolveMethod::kGmres;
    ref.tolerance = 1e-12;
    ref.max_iterations = o.max_products;
    const SolveResult reference = solve(t, e, ref);
    if (!reference.ok())
      throw NumericalError(path + ": the reference solve failed: " + reference.message);
    const std::string name = std::filesystem::path(path).stem().string();
    for (SolveMethod method : {SolveMethod::kJacobi, SolveMethod::kGaussSeidel,
                               SolveMethod::kChebyshev, SolveMethod::kGmres}) {
      ConvergenceRow row{
          name, t.max_albedo(), method,
          measure_convergence(t, e, reference.u, method, o.tolerance, o.budget, o.max_products)};
      std::fprintf(stderr, "%-28s %7.4f %-13s %10lld %12.3e\n", name.c_str(), row.max_albedo,
                   enum_name(method), row.measure.products, row.measure.error_at_budget);
      rows.push_back(row);
    }
  }
  return rows;
}

std::string convergence_csv(const std::vector<ConvergenceRow>& rows, const ConvergenceOptions& o) {
  std::ostringstream csv;
  csv.precision(9);
  csv << "scene,max_albedo,method,products_to_tolerance,seconds_to_tolerance,error_at_budget,"
         "budget,tolerance\n";
  for (const auto& r : rows)
    csv << r.scene << ',' << r.max_albedo << ',' << enum_name(r.method) << ',' << r.measure.products
        << ',' << r.measure.seconds << ',' << r.measure.error_at_budget << ',' << o.budget << ','
        << o.tolerance << '\n';
  return csv.str();
}

}  // namespace polyrad
