// The method registry: every built-in method by its DESIGN section 4 name. A new method
// adds one line to each function. External methods (exec:CMD, plugin:PATH) are made by
// lib/external; solver_names() lists the built-in ones only.
#include "lib/external/external_methods.h"
#include "lib/iss/iss_solver.h"
#include "lib/plucker/plucker_solver.h"
#include "lib/raycast/brute.h"
#include "lib/raycast/embree_solver.h"
#include "lib/ssv/ssv_solver.h"
#include "lib/solver.h"

namespace visgate {

std::vector<std::string> solver_names() { return {"embree", "embree-robust", "brute", "iss", "ssv", "plucker-bsp"}; }

std::unique_ptr<Solver> make_solver(const std::string& name) {
  if (name == "embree") return std::make_unique<raycast::EmbreeSolver>(false);
  if (name == "embree-robust") return std::make_unique<raycast::EmbreeSolver>(true);
  if (name == "brute") return std::make_unique<raycast::BruteSolver>();
  if (name == "iss") return std::make_unique<iss::IssSolver>();
  if (name == "ssv") return std::make_unique<ssv::SsvSolver>();
  if (name == "plucker-bsp") return std::make_unique<plucker::PluckerSolver>();
  if (external::is_external_method(name)) return external::make_external_solver(name);
  return nullptr;
}

}  // namespace visgate
