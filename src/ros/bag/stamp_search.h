#pragma once
// Finding the samples around a stamp in a sorted stream (camera_info beside an
// image, TF or pose samples around a frame), shared by the rosbag readers.

#include <ros/time.h>

#include <algorithm>
#include <utility>

namespace relocalizer_ros {

// Index of the last item with stamp <= t and of the first with stamp >= t, or
// -1 for none; `get` reads an item's stamp, and `items` are sorted by it.
template <typename Items, typename Get>
std::pair<long, long> bracket(const Items& items, const ros::Time& t, Get get) {
  const auto it =
      std::lower_bound(items.begin(), items.end(), t,
                       [&](const auto& item, const ros::Time& x) { return get(item) < x; });
  long after = it == items.end() ? -1 : static_cast<long>(it - items.begin());
  long before = -1;
  if (after >= 0 && get(items[after]) == t)
    before = after;
  else if (it != items.begin())
    before = static_cast<long>(it - items.begin()) - 1;
  return {before, after};
}

// Whether samples at most `tolerance` s before (or at) and after (or at) t
// exist; if so, and asked, their indices.
template <typename Items, typename Get>
bool inTime(const Items& items, const ros::Time& t, double tolerance, Get get,
            long* before_out = nullptr, long* after_out = nullptr) {
  const auto [before, after] = bracket(items, t, get);
  if (before < 0 || after < 0) return false;
  if ((t - get(items[before])).toSec() > tolerance || (get(items[after]) - t).toSec() > tolerance)
    return false;
  if (before_out) *before_out = before;
  if (after_out) *after_out = after;
  return true;
}

}  // namespace relocalizer_ros
