#pragma once
// What every command-line tool shares: its options (declared with App,
// tokenized by Boost.Program_options), the checks on their values with errors
// that name the option and say what was expected, --help on stdout and one
// line for a bad argument. Boost and not a newer parser: every platform with
// ROS 1 packages it (roscpp itself needs it).

#include <tbb/global_control.h>

#include <algorithm>
#include <boost/program_options.hpp>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

namespace relocalizer::cli {

// How a step of a tool ends: the status for main to exit with (0 after
// --help, 2 for unusable arguments or input, 1 when the work failed), or none
// when the tool goes on.
using Exit = std::optional<int>;

inline std::string oneLine(std::string text) {
  std::replace(text.begin(), text.end(), '\n', ' ');
  while (!text.empty() && text.back() == ' ') text.pop_back();
  return text;
}

// One argument's text as T, or false. Numbers must be whole and finite.
inline bool convertText(const std::string& text, std::string& value) {
  value = text;
  return true;
}

template <typename T, typename = std::enable_if_t<std::is_integral_v<T>>>
bool convertText(const std::string& text, T& value) {
  const char* end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, value);
  return !text.empty() && error == std::errc() && stop == end;
}

inline bool convertText(const std::string& text, double& value) {
  // strtod and not from_chars: GCC 10 (Debian 11) has no floating-point from_chars.
  char* stop = nullptr;
  value = std::strtod(text.c_str(), &stop);
  return !text.empty() && stop == text.c_str() + text.size() && std::isfinite(value);
}

// The placeholder for T's value in --help.
template <typename T>
std::string valueName() {
  if constexpr (std::is_same_v<T, double>) return "FLOAT";
  if constexpr (std::is_integral_v<T> && std::is_unsigned_v<T>) return "UINT";
  if constexpr (std::is_integral_v<T>) return "INT";
  return "TEXT";
}

template <typename T>
std::string kindOf() {
  if constexpr (std::is_same_v<T, double>) return "a number";
  if constexpr (std::is_integral_v<T>) return "a whole number";
  return "text";
}

// A value as --help and the errors show it: 0.02, not 0.020000.
template <typename T>
std::string showValue(const T& value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

// One option as a tool declares it: its names, where its value goes and what
// the value must be. Built into Boost's description when the App parses.
class Option {
 public:
  // A flag takes no value; a repeated option takes one or more each time.
  enum class Arity { Flag, One, Repeated };
  // Stores one argument's text in the tool's variable; false when it is no T.
  using Assign = std::function<bool(const std::string&)>;

  Option(const std::string& names, std::string help, Arity arity, std::string value_name,
         std::string kind, Assign assign, std::function<std::string()> current)
      : help_(std::move(help)),
        value_name_(std::move(value_name)),
        kind_(std::move(kind)),
        assign_(std::move(assign)),
        current_(std::move(current)),
        arity_(arity) {
    // "-j,--threads" -> Boost's "threads,j".
    std::stringstream list(names);
    for (std::string name; std::getline(list, name, ',');) {
      const bool is_long = name.rfind("--", 0) == 0;
      (is_long ? long_ : short_) = name.substr(is_long ? 2 : 1);
    }
  }

  Option* required() {
    required_ = true;
    return this;
  }
  // Shows the value the option's variable has now (its default) in --help.
  Option* showDefault() {
    default_text_ = current_();
    return this;
  }
  template <typename N>
  Option* range(N low, N high) {
    return check(kind_ + " from " + showValue(low) + " to " + showValue(high),
                 [=](const std::string& text) {
                   const double value = std::strtod(text.c_str(), nullptr);
                   return value >= low && value <= high;
                 });
  }
  Option* positive() {
    return check(kind_ + " above 0",
                 [](const std::string& text) { return std::strtod(text.c_str(), nullptr) > 0; });
  }
  Option* oneOf(const std::vector<std::string>& choices) {
    std::string listed;
    for (const std::string& choice : choices) listed += (listed.empty() ? "" : ", ") + choice;
    return check("one of " + listed, [=](const std::string& text) {
      return std::find(choices.begin(), choices.end(), text) != choices.end();
    });
  }
  Option* existingFile() {
    return check("an existing file",
                 [](const std::string& text) { return std::filesystem::is_regular_file(text); });
  }
  Option* group(std::string name) {
    group_ = std::move(name);
    return this;
  }
  // Given only together with `other` / never together with it.
  Option* needs(const Option* other) {
    needs_.push_back(other);
    return this;
  }
  Option* excludes(const Option* other) {
    excludes_.push_back(other);
    return this;
  }

  // How many values the command line gave (0: not given).
  size_t count() const { return given_; }
  explicit operator bool() const { return given_ > 0; }
  std::string name() const { return long_.empty() ? "-" + short_ : "--" + long_; }

 private:
  friend class App;

  Option* check(std::string expected, std::function<bool(const std::string&)> accepts) {
    expected_ = std::move(expected);
    accepts_ = std::move(accepts);
    return this;
  }

  // The help with what the value must be and what the option goes with, as
  // the errors say it: "Test frames [a whole number from 0 to 1000000]".
  std::string helpText() const {
    std::vector<std::string> notes;
    if (required_) notes.push_back("required");
    if (!expected_.empty()) notes.push_back(expected_);
    for (const Option* other : needs_) notes.push_back("needs " + other->name());
    for (const Option* other : excludes_) notes.push_back("not with " + other->name());
    if (arity_ == Arity::Repeated) notes.push_back("repeatable");
    std::string text = help_;
    for (size_t i = 0; i < notes.size(); ++i) text += (i == 0 ? " [" : "; ") + notes[i];
    return notes.empty() ? text : text + "]";
  }

  std::string boostName() const { return long_ + (short_.empty() ? "" : "," + short_); }
  std::string key() const { return long_.empty() ? short_ : long_; }

  const boost::program_options::value_semantic* semantic() const {
    namespace po = boost::program_options;
    if (arity_ == Arity::Flag) return po::bool_switch();
    if (arity_ == Arity::Repeated) {
      auto* value = po::value<std::vector<std::string>>()->multitoken()->value_name(value_name_);
      return required_ ? value->required() : value;
    }
    auto* value = po::value<std::string>()->value_name(value_name_);
    if (!default_text_.empty()) value->default_value(default_text_);
    return required_ ? value->required() : value;
  }

  // Takes this option's values from `map`; an error naming the option, or "".
  std::string take(const boost::program_options::variables_map& map) {
    const auto found = map.find(key());
    if (found == map.end() || found->second.defaulted()) return {};
    std::vector<std::string> texts;
    if (arity_ == Arity::Flag)
      texts = {"true"};
    else if (arity_ == Arity::Repeated)
      texts = found->second.as<std::vector<std::string>>();
    else
      texts = {found->second.as<std::string>()};
    for (const std::string& text : texts) {
      // Checked before it is stored: a refused value never reaches the tool's variable.
      if ((accepts_ && !accepts_(text)) || !assign_(text))
        return name() + ": expected " + (expected_.empty() ? kind_ : expected_) + ", got '" + text +
               "'";
    }
    given_ = texts.size();
    return {};
  }

  std::string long_, short_, help_, value_name_, kind_, expected_, default_text_, group_;
  Assign assign_;
  std::function<std::string()> current_;
  std::function<bool(const std::string&)> accepts_;
  Arity arity_;
  bool required_ = false;
  std::vector<const Option*> needs_, excludes_;
  size_t given_ = 0;
};

// A tool's command line: its options, parsed by parse().
class App {
 public:
  App(std::string description, std::string name)
      : description_(std::move(description)), name_(std::move(name)) {}

  template <typename T>
  Option* addOption(const std::string& names, T& target, const std::string& help) {
    if constexpr (std::is_same_v<T, std::vector<std::string>>) {
      return add(names, help, Option::Arity::Repeated, "TEXT ...", "text",
                 [&target](const std::string& text) {
                   target.push_back(text);
                   return true;
                 },
                 {});
    } else {
      Option* option = add(
          names, help, Option::Arity::One, valueName<T>(), kindOf<T>(),
          [&target](const std::string& text) {
            T value;
            if (!convertText(text, value)) return false;
            target = value;
            return true;
          },
          [&target] { return showValue(target); });
      // An unsigned option says that it takes no sign: "-1" is refused, not wrapped round.
      if constexpr (std::is_unsigned_v<T>) option->range(T{0}, std::numeric_limits<T>::max());
      return option;
    }
  }

  Option* addFlag(const std::string& names, bool& target, const std::string& help) {
    return add(names, help, Option::Arity::Flag, "", "",
               [&target](const std::string&) { return target = true; }, {});
  }

  const std::string& name() const { return name_; }

  // Parses; the exit status is 0 after --help, 2 after a one-line error on
  // stderr; none when the arguments are good.
  Exit parse(int argc, char** argv) {
    namespace po = boost::program_options;
    try {
      const std::vector<po::options_description> groups = describe();
      po::options_description all;
      for (const po::options_description& group : groups) all.add(group);
      po::variables_map map;
      // No guessing: an abbreviated option is an error, not another option.
      const int style =
          po::command_line_style::default_style & ~po::command_line_style::allow_guessing;
      // No positional arguments: a stray word is an error, not silently dropped.
      const po::positional_options_description no_positionals;
      po::store(po::command_line_parser(argc, argv)
                    .options(all)
                    .positional(no_positionals)
                    .style(style)
                    .run(),
                map);
      if (map.count("help")) {
        // One print of all groups: their columns line up.
        std::cout << "Usage: " << name_ << " [OPTIONS]\n\n" << wrap(description_) << all;
        return 0;
      }
      po::notify(map);  // required options
      for (const auto& option : options_)
        if (std::string error = option->take(map); !error.empty()) return usageError(error);
      if (const std::string error = combinationError(); !error.empty()) return usageError(error);
    } catch (const po::error& e) {
      return usageError(e.what());
    }
    return std::nullopt;
  }

 private:
  Option* add(const std::string& names, const std::string& help, Option::Arity arity,
              const std::string& value_name, const std::string& kind, Option::Assign assign,
              std::function<std::string()> current) {
    options_.push_back(std::make_unique<Option>(names, help, arity, value_name, kind,
                                                std::move(assign), std::move(current)));
    return options_.back().get();
  }

  // Boost's descriptions: the ungrouped options (and --help), then each group in order.
  std::vector<boost::program_options::options_description> describe() const {
    namespace po = boost::program_options;
    std::vector<std::string> names = {""};
    for (const auto& option : options_)
      if (std::find(names.begin(), names.end(), option->group_) == names.end())
        names.push_back(option->group_);
    std::vector<po::options_description> groups;
    for (const std::string& name : names) groups.emplace_back(name.empty() ? "Options" : name);
    groups.front().add_options()("help,h", "Print this help message and exit");
    for (const auto& option : options_) {
      const size_t index = std::find(names.begin(), names.end(), option->group_) - names.begin();
      groups[index].add_options()(option->boostName().c_str(), option->semantic(),
                                  option->helpText().c_str());
    }
    return groups;
  }

  std::string combinationError() const {
    for (const auto& option : options_) {
      if (!*option) continue;
      for (const Option* other : option->needs_)
        if (!*other) return option->name() + " requires " + other->name();
      for (const Option* other : option->excludes_)
        if (*other) return option->name() + " excludes " + other->name();
    }
    return {};
  }

  int usageError(const std::string& reason) const {
    std::cerr << name_ << ": error: " << oneLine(reason) << " (see --help)" << std::endl;
    return 2;
  }

  // The description as lines of at most 80 characters.
  static std::string wrap(const std::string& text) {
    std::istringstream words(text);
    std::string out, line;
    for (std::string word; words >> word;) {
      if (!line.empty() && line.size() + 1 + word.size() > 80) {
        out += line + "\n";
        line.clear();
      }
      line += (line.empty() ? "" : " ") + word;
    }
    return out + line + "\n";
  }

  std::string description_, name_;
  std::vector<std::unique_ptr<Option>> options_;
};

// Prints "<tool>: error: <reason>" on one line and returns `code`: 2 for
// unusable arguments or input (the default), 1 when the work itself failed.
inline int fail(const App& app, const std::string& reason, int code = 2) {
  std::cerr << app.name() << ": error: " << oneLine(reason) << std::endl;
  return code;
}

// Thread count option shared by the heavy tools; 0 = every core.
inline int resolveThreads(int requested) {
  return requested > 0 ? requested : std::max(1u, std::thread::hardware_concurrency());
}

}  // namespace relocalizer::cli
