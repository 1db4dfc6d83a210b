#include "param_reading.h"

#include <xmlrpcpp/XmlRpcValue.h>

#include <cmath>
#include <cstdio>
#include <limits>

namespace relocalizer_ros {

namespace {

// Whole numbers in full (99999999999, not 1e+11): the user typed them so.
std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.15g", value);
  return text;
}

}  // namespace

std::string ParamReader::wrongType(const std::string& key) const {
  return "parameter '" + nh_.resolveName(key) + "' has the wrong type";
}

void ParamReader::fail(std::string why) {
  if (error_.empty()) error_ = std::move(why);
}

// XML-RPC integers are 32-bit: roscpp stores `_key:=99999999999` as a double
// (rosparam and roslaunch refuse it), so a whole number that arrives as a
// double is read as an integer, and beyond int it is out of range, not a value
// of the wrong type.
void ParamReader::readInt(const std::string& key, int& value, int min) {
  if (!nh_.hasParam(key)) return;
  const std::string range = "; it must be an integer from " + std::to_string(min) + " to " +
                            std::to_string(std::numeric_limits<int>::max());
  XmlRpc::XmlRpcValue stored;
  nh_.getParam(key, stored);
  if (stored.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
    const double d = static_cast<double>(stored);
    if (!std::isfinite(d) || d != std::floor(d)) return fail(wrongType(key));
    if (d < std::numeric_limits<int>::min() || d > std::numeric_limits<int>::max())
      return fail("parameter '" + nh_.resolveName(key) + "' is " + number(d) + ", out of range" +
                  range);
    value = static_cast<int>(d);
  } else if (!nh_.getParam(key, value)) {
    return fail(wrongType(key));
  }
  if (value < min)
    fail("parameter '" + nh_.resolveName(key) + "' is " + std::to_string(value) + range);
}

void ParamReader::bound(const std::string& key, double value, double min, double max,
                        const char* unit, const char* zero) {
  if ((value >= min && value <= max) || (zero && value == 0.0)) return;
  const std::string with_unit = std::string(" ") + unit;
  fail("parameter '" + nh_.resolveName(key) + "' is " + number(value) + with_unit +
       "; it must be " + (zero ? "0 (" + std::string(zero) + ") or " : std::string()) + "from " +
       number(min) + " to " + number(max) + with_unit);
}

}  // namespace relocalizer_ros
