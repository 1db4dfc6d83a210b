// The BVH that rays traverse: a binary tree built by the surface-area
// heuristic, collapsed into four-wide nodes (synthetic_internal.h, WideNode).

#include <algorithm>
#include <array>
#include <numeric>
#include <vector>

#include "room_bvh.h"

namespace relocalizer {
namespace synthetic {

namespace {

// Binary BVH node, only used while building.
struct BvhNode {
  Vec3f lo = Vec3f::Zero(), hi = Vec3f::Zero();
  int first = 0;  // leaf: first box; inner: left child (right child is first + 1)
  int count = 0;  // boxes in a leaf; 0 for inner nodes
};

// Half the surface area of a box: the SAH's measure of how often rays enter it.
float area(const Vec3f& l, const Vec3f& h) {
  const Vec3f e = (h - l).cwiseMax(0.0f);
  return e.x() * e.y() + e.y() * e.z() + e.z() * e.x();
}

// Binary BVH over `boxes` by the binned surface-area heuristic; `order`
// receives the box indices in leaf order (leaves are ranges of it).
std::vector<BvhNode> buildBinaryBvh(const std::vector<Box>& boxes, std::vector<int>& order) {
  const int n = static_cast<int>(boxes.size());
  std::vector<Vec3f> box_lo(n), box_hi(n), centroid(n);
  for (int i = 0; i < n; ++i) {
    boxes[i].worldBounds(box_lo[i], box_hi[i]);
    centroid[i] = (box_lo[i] + box_hi[i]) * 0.5f;
  }
  order.resize(n);
  std::iota(order.begin(), order.end(), 0);
  std::vector<BvhNode> binary{BvhNode{}};
  binary.reserve(2 * static_cast<size_t>(n) + 1);
  // Binned surface-area heuristic: the room is many small boxes (books)
  // beside a few big ones, where median splits make poor trees.
  constexpr int kBins = 16;
  constexpr float kTraversalCost = 1.0f, kBoxCost = 1.5f;
  struct Task {
    int node, begin, end;
  };
  std::vector<Task> tasks{{0, 0, n}};
  while (!tasks.empty()) {
    const Task task = tasks.back();
    tasks.pop_back();
    const int count = task.end - task.begin;
    Vec3f node_lo = Vec3f::Constant(kInf), node_hi = Vec3f::Constant(-kInf);
    Vec3f c_lo = node_lo, c_hi = node_hi;
    for (int i = task.begin; i < task.end; ++i) {
      node_lo = node_lo.cwiseMin(box_lo[order[i]]);
      node_hi = node_hi.cwiseMax(box_hi[order[i]]);
      c_lo = c_lo.cwiseMin(centroid[order[i]]);
      c_hi = c_hi.cwiseMax(centroid[order[i]]);
    }
    BvhNode& node = binary[task.node];
    node.lo = node_lo;
    node.hi = node_hi;
    node.first = task.begin;
    node.count = count;
    if (count <= 1) continue;
    float best_cost = kBoxCost * count;  // cost of staying a leaf, in units of the node's area
    int best_axis = -1, best_bin = 0;
    for (int axis = 0; axis < 3; ++axis) {
      const float extent = c_hi[axis] - c_lo[axis];
      if (!(extent > 0.0f)) continue;
      std::array<int, kBins> bin_count{};
      std::array<Vec3f, kBins> bin_lo, bin_hi;
      bin_lo.fill(Vec3f::Constant(kInf));
      bin_hi.fill(Vec3f::Constant(-kInf));
      for (int i = task.begin; i < task.end; ++i) {
        const int b = std::min(
            kBins - 1, static_cast<int>(kBins * (centroid[order[i]][axis] - c_lo[axis]) / extent));
        ++bin_count[b];
        bin_lo[b] = bin_lo[b].cwiseMin(box_lo[order[i]]);
        bin_hi[b] = bin_hi[b].cwiseMax(box_hi[order[i]]);
      }
      std::array<float, kBins> right_area{};
      std::array<int, kBins> right_count{};
      Vec3f acc_lo = Vec3f::Constant(kInf), acc_hi = Vec3f::Constant(-kInf);
      int acc = 0;
      for (int b = kBins - 1; b > 0; --b) {
        acc_lo = acc_lo.cwiseMin(bin_lo[b]);
        acc_hi = acc_hi.cwiseMax(bin_hi[b]);
        acc += bin_count[b];
        right_area[b] = area(acc_lo, acc_hi);
        right_count[b] = acc;
      }
      acc_lo = Vec3f::Constant(kInf);
      acc_hi = Vec3f::Constant(-kInf);
      acc = 0;
      const float node_area = std::max(area(node_lo, node_hi), 1e-9f);
      for (int b = 0; b < kBins - 1; ++b) {
        acc_lo = acc_lo.cwiseMin(bin_lo[b]);
        acc_hi = acc_hi.cwiseMax(bin_hi[b]);
        acc += bin_count[b];
        if (acc == 0 || right_count[b + 1] == 0) continue;
        const float cost =
            kTraversalCost +
            kBoxCost * (acc * area(acc_lo, acc_hi) + right_count[b + 1] * right_area[b + 1]) /
                node_area;
        if (cost < best_cost) {
          best_cost = cost;
          best_axis = axis;
          best_bin = b;
        }
      }
    }
    int mid;
    if (best_axis >= 0) {
      const int axis = best_axis;
      const float extent = c_hi[axis] - c_lo[axis];
      const auto split =
          std::partition(order.begin() + task.begin, order.begin() + task.end, [&](int i) {
            return std::min(kBins - 1, static_cast<int>(kBins * (centroid[i][axis] - c_lo[axis]) /
                                                        extent)) <= best_bin;
          });
      mid = static_cast<int>(split - order.begin());
    } else if (count > 4) {
      // Too many for one leaf even if SAH prefers it (coincident centroids).
      mid = (task.begin + task.end) / 2;
    } else {
      continue;
    }
    const int left = static_cast<int>(binary.size());
    binary.emplace_back();
    binary.emplace_back();
    binary[task.node].first = left;
    binary[task.node].count = 0;
    tasks.push_back({left + 1, mid, task.end});
    tasks.push_back({left, task.begin, mid});
  }
  return binary;
}

// Collapses the binary tree into four-wide nodes: open the largest inner
// children until four slots are used.
struct Collapse {
  const std::vector<BvhNode>& binary;
  std::vector<WideNode>& wide;
  float (*area)(const Vec3f&, const Vec3f&);
  int operator()(int b) {
    std::vector<int> slots;
    if (binary[b].count > 0)
      slots.push_back(b);  // a leaf root
    else
      slots = {binary[b].first, binary[b].first + 1};
    while (slots.size() < 4) {
      int open = -1;
      float best = -1.0f;
      for (int i = 0; i < static_cast<int>(slots.size()); ++i) {
        const BvhNode& c = binary[slots[i]];
        if (c.count == 0 && area(c.lo, c.hi) > best) {
          best = area(c.lo, c.hi);
          open = i;
        }
      }
      if (open < 0) break;
      const int opened = slots[open];
      slots[open] = binary[opened].first;
      slots.insert(slots.begin() + open + 1, binary[opened].first + 1);
    }
    const int index = static_cast<int>(wide.size());
    wide.emplace_back();
    for (int k = 0; k < 4; ++k) {
      const bool used = k < static_cast<int>(slots.size());
      const BvhNode* c = used ? &binary[slots[k]] : nullptr;
      for (int axis = 0; axis < 3; ++axis) {
        wide[index].lo[axis][k] = used ? c->lo[axis] : kInf;
        wide[index].hi[axis][k] = used ? c->hi[axis] : -kInf;
      }
      wide[index].count[k] = used ? c->count : -1;
      wide[index].child[k] = used && c->count > 0 ? c->first : 0;
    }
    for (int k = 0; k < static_cast<int>(slots.size()); ++k)
      if (binary[slots[k]].count == 0) {
        const int child = (*this)(slots[k]);
        wide[index].child[k] = child;
      }
    return index;
  }
};

}  // namespace

std::vector<WideNode> buildBvh(std::vector<Box>& boxes) {
  const int n = static_cast<int>(boxes.size());
  std::vector<int> order;
  const std::vector<BvhNode> binary = buildBinaryBvh(boxes, order);
  std::vector<Box> sorted(n);
  for (int i = 0; i < n; ++i) sorted[i] = boxes[order[i]];
  boxes = std::move(sorted);
  std::vector<WideNode> nodes;
  if (n == 0) return nodes;
  Collapse collapse{binary, nodes, &area};
  collapse(0);
  return nodes;
}

}  // namespace synthetic
}  // namespace relocalizer
