#pragma once
// Reading numbers out of parameter JSON with range checks (private to the core).
// nlohmann's get<int>() truncates 99999999999 and turns -1e300 into undefined
// behaviour; parameters from files and model headers must instead fail with a
// message naming the key.

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace relocalizer::detail {

using nlohmann::json;

// A value as a message may quote it: ASCII (so never invalid UTF-8) and short
// (a field that should be a number may be an array of a million).
inline std::string quoted(const json& v) {
  constexpr size_t kLongest = 40;
  std::string text = v.dump(-1, ' ', true);
  if (text.size() > kLongest) text = text.substr(0, kLongest) + "...";
  return text;
}

// Why a reader of JSON threw, in our words: nlohmann's messages quote the
// bytes it read (a file's, perhaps not UTF-8); our own (Field paths, checked
// numbers) are kept.
inline std::string jsonErrorReason(const std::exception& e) {
  if (const auto* parse = dynamic_cast<const json::parse_error*>(&e))
    return "JSON that does not parse (at byte " + std::to_string(parse->byte) + ")";
  if (dynamic_cast<const json::exception*>(&e)) return "a field missing or of the wrong type";
  if (dynamic_cast<const std::runtime_error*>(&e) || dynamic_cast<const std::out_of_range*>(&e))
    return e.what();
  return "cannot be read (out of memory, or a size in it out of range)";
}

template <typename T>
T checkedNumber(const json& v, const std::string& name) {
  if constexpr (std::is_same_v<T, bool>) {
    if (!v.is_boolean())
      throw std::out_of_range("'" + name + "' must be true or false, got " + quoted(v));
    return v.get<bool>();
  } else if constexpr (std::is_integral_v<T>) {
    using Limits = std::numeric_limits<T>;
    bool fits = false;
    if (v.is_number_unsigned())
      fits = v.get<uint64_t>() <= static_cast<uint64_t>(Limits::max());
    else if (v.is_number_integer())
      fits = v.get<int64_t>() >= static_cast<int64_t>(Limits::min()) &&
             (v.get<int64_t>() < 0 ||
              static_cast<uint64_t>(v.get<int64_t>()) <= static_cast<uint64_t>(Limits::max()));
    if (!fits)
      throw std::out_of_range("'" + name + "' must be an integer from " +
                              std::to_string(Limits::min()) + " to " +
                              std::to_string(Limits::max()) + ", got " + quoted(v));
    return v.is_number_unsigned() ? static_cast<T>(v.get<uint64_t>())
                                  : static_cast<T>(v.get<int64_t>());
  } else {
    static_assert(std::is_floating_point_v<T>);
    const double d = v.is_number() ? v.get<double>() : std::numeric_limits<double>::quiet_NaN();
    if (!std::isfinite(d) || std::abs(d) > static_cast<double>(std::numeric_limits<T>::max()))
      throw std::out_of_range("'" + name + "' must be a finite number, got " + quoted(v));
    return static_cast<T>(d);
  }
}

template <typename T>
void readField(const json& j, const std::string& prefix, const char* key, T& out) {
  out = checkedNumber<T>(j.at(key), prefix + key);
}

}  // namespace relocalizer::detail
