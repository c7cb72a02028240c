#pragma once
// How every iapsim program answers an error on its command line (CLI11 reports --help as one too): the help
// of the command given and 0, or the error with a hint and 2, the code of a bad configuration.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <iostream>
#include <string>
#include <vector>

#include "bridge/config.h"

namespace iapsim::bridge {

inline int AnswerParseError(const CLI::App& app, const CLI::ParseError& error) {
  if (dynamic_cast<const CLI::CallForVersion*>(&error) != nullptr) {
    std::cout << error.what() << "\n";
    return 0;
  }
  if (error.get_exit_code() == 0) {
    std::cout << app.help();
    return 0;
  }
  std::cerr << app.get_name() << ": " << error.what() << "\nRun with --help for more information.\n";
  return 2;
}

/// --help shows every option's default (always_capture_default) but where it says nothing (an empty list) or
/// where the description says it better (the 0 or -1 that stands for "the cores" or "until Ctrl-C").
inline void HideEmptyDefaults(CLI::App& app) {
  for (CLI::Option* option : app.get_options()) {
    const std::string shown = option->get_default_str();
    if (shown == "[]" || option->get_description().find("(default") != std::string::npos) {
      option->default_str("");
    }
  }
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) HideEmptyDefaults(*sub);
}

/// When `word`, the first argument of `program`, names no subcommand of `app` (a typo, say): says so on
/// stderr with the closest listed subcommands ("did you mean"), or all of them, and returns true: the caller
/// exits 2.
inline bool AnswerUnknownSubcommand(const CLI::App& app, const std::string& program,
                                    const std::string& word) {
  const auto listed = app.get_subcommands([](const CLI::App* sub) { return !sub->get_group().empty(); });
  std::vector<std::string> names, close;
  for (const CLI::App* sub : listed) {
    if (sub->get_name() == word) return false;
    names.push_back(sub->get_name());
  }
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
    if (sub->get_name() == word) return false;  // an unlisted one (what a Slurm task runs)
  }
  for (const std::string& name : names) {
    // a slip of a key or two, or the start of the name
    if (EditDistance(word, name) <= std::max<size_t>(1, std::min(word.size(), name.size()) / 3) ||
        (word.size() >= 2 && name.rfind(word, 0) == 0)) {
      close.push_back(name);
    }
  }
  const std::vector<std::string>& shown = close.empty() ? names : close;
  std::string list;
  for (size_t i = 0; i < shown.size(); ++i) {
    list += (i == 0 ? "" : i + 1 == shown.size() ? (close.empty() ? " and " : " or ") : ", ") + shown[i];
  }
  std::cerr << program << ": '" << word << "' is not a command; "
            << (close.empty() ? "the commands are " + list + "." : "did you mean " + list + "?")
            << "\nRun with --help for more information.\n";
  return true;
}

}  // namespace iapsim::bridge
