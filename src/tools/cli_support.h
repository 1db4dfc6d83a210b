#pragma once
// What every command-line tool shares: one-line failures and CLI11 parsing
// that answers --help on stdout and a bad argument with a single line.

#include <tbb/global_control.h>
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <string>
#include <thread>

namespace relocalizer::cli {

inline std::string oneLine(std::string text) {
  std::replace(text.begin(), text.end(), '\n', ' ');
  while (!text.empty() && text.back() == ' ') text.pop_back();
  return text;
}

// Prints "<tool>: error: <reason>" on one line and returns `code`: 2 for
// unusable arguments or input (the default), 1 when the work itself failed.
inline int fail(const CLI::App& app, const std::string& reason, int code = 2) {
  std::cerr << app.get_name() << ": error: " << oneLine(reason) << std::endl;
  return code;
}

// Parses; returns -1 to go on, otherwise the exit code to return.
inline int parse(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << app.get_name() << ": error: " << oneLine(e.what()) << " (see --help)" << std::endl;
    return 2;
  }
  return -1;
}

// Thread count option shared by the heavy tools; 0 = every core.
inline int resolveThreads(int requested) {
  return requested > 0 ? requested : std::max(1u, std::thread::hardware_concurrency());
}

}  // namespace relocalizer::cli
