#pragma once
// Runs one of the project's matplotlib scripts (tools/plot_*.py) on an evaluation's CSV.

#include <sys/types.h>

#include <string>
#include <vector>

namespace iapsim::tools {

/// Runs SCRIPT with ARGS in Debian's /usr/bin/python3 (where install-deps puts matplotlib; a pyenv or venv
/// python3 on PATH may lack it), in one Python process per `iapsim` invocation that runs every script it is
/// given (tools/plot_server.py): a batch of plots imports matplotlib once. Returns false, after printing why
/// on stderr, when the script failed or Python could not start: the metrics stay complete.
bool RunPlotScript(const std::string& script, const std::vector<std::string>& args);

/// While it lives, the programs this one starts (the runs `iapsim regress` and `iapsim sweep` fly, each an
/// `iapsim run`) and this one plot through one Python of its own, over a unix socket named to them by
/// IAPSIM_PLOT_SOCKET (a path, or @ and a name in the abstract namespace: this one's, so nothing is left on
/// disk, and served to this user only), instead of each starting Python and importing matplotlib (0.5 s a
/// run); its plots are made one at a time. Where it cannot start, or dies, each program plots with its own as
/// before; where one is in place already (an enclosing one, or the starting program's), it does nothing.
class SharedPlotServer {
 public:
  SharedPlotServer();
  ~SharedPlotServer();
  SharedPlotServer(const SharedPlotServer&) = delete;
  SharedPlotServer& operator=(const SharedPlotServer&) = delete;

 private:
  pid_t pid_ = -1;
  int input_ = -1;  // its stdin: closed, it ends
};

}  // namespace iapsim::tools
