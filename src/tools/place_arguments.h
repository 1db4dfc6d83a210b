#pragma once
// NAME=PATH arguments that name places (evaluate --model, places_benchmark
// --place and --test), parsed and checked the same way by every tool.

#include <string>
#include <utility>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/file_io.h"

namespace relocalizer::cli {

struct NamedPath {
  std::string name;
  std::string path;
};

// Each argument is NAME=PATH, or PATH alone, named by its file's stem. Names
// must be unique; `option` names the option in errors.
inline Expected<std::vector<NamedPath>> parseNamedPaths(const std::vector<std::string>& arguments,
                                                        const std::string& option) {
  std::vector<NamedPath> named;
  for (const std::string& argument : arguments) {
    const size_t equals = argument.find('=');
    NamedPath entry;
    entry.name = equals == std::string::npos ? pathStem(argument) : argument.substr(0, equals);
    entry.path = equals == std::string::npos ? argument : argument.substr(equals + 1);
    if (entry.name.empty() || entry.path.empty())
      return makeError(option + " " + argument + ": expected NAME=PATH with a name and a path");
    for (const NamedPath& other : named)
      if (other.name == entry.name)
        return makeError(option + " " + argument + ": the place name " + entry.name +
                         " is given twice (" + other.path + " and " + entry.path + ")");
    named.push_back(std::move(entry));
  }
  return named;
}

}  // namespace relocalizer::cli
