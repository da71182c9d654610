// External methods by name (see external_methods.h).
#include "lib/external/external_methods.h"

#include "lib/external/exec_method.h"
#include "lib/external/plugin_method.h"

namespace visgate::external {

bool is_external_method(const std::string& name) {
  return name.rfind("exec:", 0) == 0 || name.rfind("plugin:", 0) == 0;
}

std::unique_ptr<Solver> make_external_solver(const std::string& name, std::string* why) {
  auto set = [&](const std::string& w) {
    if (why) *why = w;
    return nullptr;
  };
  if (name.rfind("exec:", 0) == 0) {
    const std::string cmd = name.substr(5);
    if (cmd.find_first_not_of(" \t") == std::string::npos) return set(name + ": empty command");
    return std::make_unique<ExecSolver>(cmd);
  }
  if (name.rfind("plugin:", 0) == 0) {
    const std::string path = name.substr(7);
    if (path.empty()) return set(name + ": empty library path");
    try {
      return std::make_unique<PluginSolver>(path);
    } catch (const ExternalMethodError& e) {
      return set(e.what());
    }
  }
  return set(name + ": not an external method");
}

std::string describe_unknown_method(const std::string& name) {
  std::string why;
  if (is_external_method(name)) {
    make_external_solver(name, &why);
    return why;
  }
  std::string known;
  for (const auto& n : solver_names()) known += (known.empty() ? "" : ", ") + n;
  return name + ": unknown method (known: " + known + ", exec:CMD, plugin:PATH)";
}

}  // namespace visgate::external
