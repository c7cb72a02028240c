#pragma once
// Runs one of the project's matplotlib scripts (tools/plot_*.py) on an evaluation's CSV.

#include <string>
#include <vector>

namespace iapsim::tools {

/// Runs `/usr/bin/python3 SCRIPT ARGS...` (Debian's python, where install-deps puts matplotlib; a pyenv or
/// venv python3 on PATH may lack it) without a shell, so paths need no quoting. Returns false, after
/// printing why on stderr, when it could not start or did not exit 0: the metrics stay complete.
bool RunPlotScript(const std::string& script, const std::vector<std::string>& args);

}  // namespace iapsim::tools
