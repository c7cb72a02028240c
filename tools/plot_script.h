#pragma once
// Runs one of the project's matplotlib scripts (tools/plot_*.py) on an evaluation's CSV.

#include <string>
#include <vector>

namespace iapsim::tools {

/// Runs SCRIPT with ARGS in Debian's /usr/bin/python3 (where install-deps puts matplotlib; a pyenv or venv
/// python3 on PATH may lack it), in one Python process per `iapsim` invocation that runs every script it is
/// given (tools/plot_server.py): a batch of plots imports matplotlib once. Returns false, after printing why
/// on stderr, when the script failed or Python could not start: the metrics stay complete.
bool RunPlotScript(const std::string& script, const std::vector<std::string>& args);

}  // namespace iapsim::tools
