#pragma once
// Pairing two timestamped streams (colour and depth images) by nearest stamp,
// as TUM's associate.py does. The TUM reader and the rosbag reader share it.

#include <cstddef>
#include <utility>
#include <vector>

namespace relocalizer {

// `first` and `second` hold stamps in seconds, each sorted ascending. Every
// pair at most `max_gap` apart is a candidate; candidates are taken smallest
// gap first (ties: lower first index, then lower second index), each item at
// most once. Returns (first index, second index) pairs in increasing first
// index.
std::vector<std::pair<size_t, size_t>> associateByStamp(const std::vector<double>& first,
                                                        const std::vector<double>& second,
                                                        double max_gap);

}  // namespace relocalizer
