#pragma once
// How every iapsim program answers an error on its command line (CLI11 reports --help as one too): the help
// of the command given and 0, or the error with a hint and 2, the code of a bad configuration.

#include <CLI/CLI.hpp>
#include <iostream>

namespace iapsim::bridge {

inline int AnswerParseError(const CLI::App& app, const CLI::ParseError& error) {
  if (error.get_exit_code() == 0) {
    std::cout << app.help();
    return 0;
  }
  std::cerr << app.get_name() << ": " << error.what() << "\nRun with --help for more information.\n";
  return 2;
}

}  // namespace iapsim::bridge
