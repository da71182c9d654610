// External methods by name (DESIGN section 4): `exec:CMD` (exec_method.h) and
// `plugin:PATH` (plugin_method.h). make_solver (lib/registry.cpp) answers these names
// through make_external_solver; the tools use describe_unknown_method for their message
// when make_solver returns nullptr.
#pragma once

#include <memory>
#include <string>

#include "lib/solver.h"

namespace visgate::external {

// True for names with the exec: or plugin: prefix.
bool is_external_method(const std::string& name);
// The solver of an exec:/plugin: name; nullptr (and *why set) when the name is malformed
// (empty command or path) or the plugin cannot be loaded.
std::unique_ptr<Solver> make_external_solver(const std::string& name, std::string* why = nullptr);
// One line saying why `name` names no method: the plugin's load error, or the list of
// known methods and the external forms.
std::string describe_unknown_method(const std::string& name);

}  // namespace visgate::external
