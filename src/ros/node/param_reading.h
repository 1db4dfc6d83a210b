#pragma once
// How the node reads a parameter from its private node handle, for every
// part's settings (*_settings.h): a parameter of the wrong type or out of
// range is an error that names it, its value and what is allowed. A typo must
// not silently keep a default on a robot, nor a huge duration abort the node
// inside ros::Duration. The node stops on the first error, so the reader keeps
// the first one and ignores the rest.

#include <ros/node_handle.h>

#include <string>

namespace relocalizer_ros {

class ParamReader {
 public:
  explicit ParamReader(const ros::NodeHandle& nh) : nh_(nh) {}

  // roscpp's param() falls back to the default when the stored value has
  // another type; a robot must not run on a default because of a quoting slip.
  template <typename T>
  void read(const std::string& key, T& value) {
    if (nh_.hasParam(key) && !nh_.getParam(key, value)) fail(wrongType(key));
  }
  // An integer from `min` to INT_MAX (XML-RPC's integers are 32-bit).
  void readInt(const std::string& key, int& value, int min);
  // A duration or rate from `min` to `max` `unit`; 0 is allowed too when
  // `zero` says what it means (off, no limit).
  void bound(const std::string& key, double value, double min, double max, const char* unit,
             const char* zero = nullptr);
  // Records `why` unless an error came first; "" is no error.
  void fail(std::string why);

  // The parameter's resolved name, quoted: '/relocalizer/tf_rate'.
  std::string quoted(const std::string& key) const { return "'" + nh_.resolveName(key) + "'"; }
  const ros::NodeHandle& handle() const { return nh_; }
  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }

 private:
  std::string wrongType(const std::string& key) const;

  const ros::NodeHandle& nh_;
  std::string error_;
};

}  // namespace relocalizer_ros
