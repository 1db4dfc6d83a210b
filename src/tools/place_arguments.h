#pragma once
// NAME=PATH arguments that name places (evaluate --model, places_benchmark
// --place and --test), parsed and checked the same way by every tool.

#include <string>
#include <utility>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/file_io.h"
#include "relocalizer/core/outside_text.h"

namespace relocalizer::cli {

struct NamedPath {
  std::string name;
  std::string path;
};

// Each argument is NAME=PATH, or PATH alone, named by its file's stem. Names
// must be unique and follow the package's one name rule (places.csv separates
// its columns by a space: a name with one would be ambiguous); `option` names
// the option in errors.
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
    const std::string what =
        equals == std::string::npos ? "the place name (the file's stem)" : "the place name";
    if (const std::string why = nameError(entry.name, what); !why.empty())
      return makeError(option + " " + argument + ": " + why);
    for (const NamedPath& other : named)
      if (other.name == entry.name)
        return makeError(option + " " + argument + ": the place name " + entry.name +
                         " is given twice (" + other.path + " and " + entry.path + ")");
    named.push_back(std::move(entry));
  }
  return named;
}

}  // namespace relocalizer::cli
