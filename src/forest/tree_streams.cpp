#include "tree_streams.h"

#include <zlib.h>

#include <tbb/parallel_for.h>
#include <array>
#include <cstring>
#include <string>

namespace relocalizer::detail {

namespace {

// Versions 1 to 4 stored each mode's descriptor whole, 3 and 4 each mode at
// full precision (LeafMode).
using WholeDescriptor = std::array<int8_t, kDescriptorSize>;

// Versions 1 and 2 stored leaves as an index into a range array and 92-byte
// modes with their descriptor, support and log-determinant inline.
namespace v1 {
struct LeafMode {
  float mean[3];
  float support;
  float information[6];
  float log_det_covariance;
  WholeDescriptor descriptor;
};
static_assert(sizeof(LeafMode) == 92, "version-1 mode layout");
}  // namespace v1

// A tree's arrays as version 2 stores them: each array byte plane by byte
// plane (byte 0 of every element, then byte 1, ...), so that the bytes that
// change little from one element to the next (float exponents, the high bytes
// of indices, the same descriptor coefficient of every mode) sit together,
// where deflate finds them; then deflated, one stream per tree.
void appendPlanes(std::vector<uint8_t>& out, const void* data, size_t count, size_t size) {
  const auto* bytes = static_cast<const uint8_t*>(data);
  const size_t base = out.size();
  out.resize(base + count * size);
  for (size_t b = 0; b < size; ++b)
    for (size_t i = 0; i < count; ++i) out[base + b * count + i] = bytes[i * size + b];
}

void readPlanes(const uint8_t* planes, void* data, size_t count, size_t size) {
  auto* bytes = static_cast<uint8_t*>(data);
  for (size_t b = 0; b < size; ++b)
    for (size_t i = 0; i < count; ++i) bytes[i * size + b] = planes[b * count + i];
}

// A tree's arrays in bytes, as format `version` stores them.
size_t treeBytes(size_t nodes, size_t modes, uint32_t version) {
  const size_t mode_bytes = version >= 5 ? sizeof(PackedMode) + sizeof(Descriptor)
                                         : sizeof(LeafMode) + sizeof(WholeDescriptor);
  return nodes * sizeof(SplitNode) + modes * mode_bytes;
}

// Writing ends train and every submap freeze: level 6 took 1.9 s of train's
// 31 s for a file 5 % smaller than level 1's (docs/benchmarks.md).
constexpr int kDeflateLevel = 1;

// The deflated stream of one tree: uint32 nodes, uint32 modes, its ModeGrid,
// uint64 stored size, then the stream.
constexpr size_t kTreeHeaderSize = 4 + 4 + sizeof(ModeGrid) + 8;

std::vector<uint8_t> packTreeStream(const Tree& t) {
  std::vector<uint8_t> raw;
  raw.reserve(treeBytes(t.nodes.size(), t.modes.size(), kModelFormatVersion));
  appendPlanes(raw, t.nodes.data(), t.nodes.size(), sizeof(SplitNode));
  appendPlanes(raw, t.modes.data(), t.modes.size(), sizeof(PackedMode));
  appendPlanes(raw, t.descriptors.data(), t.descriptors.size(), sizeof(Descriptor));
  uLongf stored = compressBound(static_cast<uLong>(raw.size()));
  std::vector<uint8_t> packed(kTreeHeaderSize + stored);
  if (compress2(packed.data() + kTreeHeaderSize, &stored, raw.data(),
                static_cast<uLong>(raw.size()), kDeflateLevel) != Z_OK)
    throw std::runtime_error("zlib could not deflate a tree");
  packed.resize(kTreeHeaderSize + stored);
  const uint32_t nodes = static_cast<uint32_t>(t.nodes.size()),
                 modes = static_cast<uint32_t>(t.modes.size());
  const uint64_t stored_size = stored;
  std::memcpy(packed.data(), &nodes, 4);
  std::memcpy(packed.data() + 4, &modes, 4);
  std::memcpy(packed.data() + 8, &t.grid, sizeof(ModeGrid));
  std::memcpy(packed.data() + 8 + sizeof(ModeGrid), &stored_size, 8);
  return packed;
}

// Structural checks, so a model that passed the checksum but was written by a
// buggy trainer cannot make prediction read out of bounds.
std::string validateTree(const Tree& t) {
  if (t.nodes.empty()) return "a tree has no nodes";
  if (t.descriptors.size() != t.modes.size()) return "modes and descriptors differ in number";
  const ModeGrid& g = t.grid;
  if (!std::all_of(g.origin.begin(), g.origin.end(), [](float x) { return std::isfinite(x); }) ||
      !(g.step > 0.0f && std::isfinite(g.step)))
    return "a tree's mode grid is not finite and positive";
  for (size_t i = 0; i < t.nodes.size(); ++i) {
    const SplitNode& n = t.nodes[i];
    if (n.isLeaf()) {
      const LeafRange range = n.leafModes();
      if (static_cast<uint64_t>(range.first_mode) + range.mode_count > t.modes.size())
        return "leaf mode range out of bounds";
      continue;
    }
    if (static_cast<size_t>(n.left) <= i || static_cast<size_t>(n.left) + 1 >= t.nodes.size())
      return "child index out of range";
    // evaluateFeature indexes BGR pixels with the channels unchecked.
    const PixelFeature& f = n.feature;
    if (f.type != FeatureType::Colour && f.type != FeatureType::Depth)
      return "unknown feature type " + std::to_string(static_cast<int>(f.type));
    if (f.channel_p > 2 || f.channel_q > 2) return "colour channel out of range";
  }
  return {};
}

bool readTreeCount(ByteReader& r, uint32_t& trees, std::string& why) {
  if (!r.value(trees)) return false;
  if (trees > kMaxTrees) {
    why = "forest has " + std::to_string(trees) + " trees, more than " + std::to_string(kMaxTrees);
    return false;
  }
  return true;
}

// The modes and descriptors of a version-3 or -4 tree (`planes` after its
// nodes), packed as version 5 keeps them.
void readWholeModes(const uint8_t* planes, uint32_t count, Tree& t) {
  std::vector<LeafMode> modes(count);
  std::vector<WholeDescriptor> descriptors(count);
  readPlanes(planes, modes.data(), count, sizeof(LeafMode));
  readPlanes(planes + count * sizeof(LeafMode), descriptors.data(), count, sizeof(WholeDescriptor));
  packModes(modes, t.grid, t.modes);
  t.descriptors.resize(count);
  for (uint32_t m = 0; m < count; ++m) t.descriptors[m] = keptCoefficients(descriptors[m]);
}

// Reads the tree streams of one forest of format `version` (3 and later; the
// counts and stored sizes first, so that the streams can be inflated in
// parallel).
bool readPlanedTrees(ByteReader& r, Forest& forest, uint32_t version, std::string& why) {
  uint32_t trees = 0;
  if (!readTreeCount(r, trees, why)) return false;
  struct Stream {
    uint32_t nodes = 0, modes = 0;
    ModeGrid grid;
    uint64_t stored = 0;
    const uint8_t* data = nullptr;
  };
  std::vector<Stream> streams(trees);
  for (Stream& s : streams) {
    if (!r.value(s.nodes) || !r.value(s.modes) || (version >= 5 && !r.value(s.grid)) ||
        !r.value(s.stored) || s.stored > r.remaining())
      return false;
    // Deflate expands at most 1032:1, so larger claimed sizes are corrupt (and
    // would make a small hostile file allocate gigabytes).
    if (treeBytes(s.nodes, s.modes, version) > 1032 * s.stored + 64) {
      why = "a tree's size does not match its compressed data";
      return false;
    }
    s.data = r.position();
    r.skip(s.stored);
  }
  forest.trees.assign(trees, Tree{});
  std::vector<std::string> errors(trees);
  tbb::parallel_for(size_t{0}, streams.size(), [&](size_t k) {
    const Stream& s = streams[k];
    Tree& t = forest.trees[k];
    std::vector<uint8_t> raw(treeBytes(s.nodes, s.modes, version));
    uLongf size = static_cast<uLongf>(raw.size());
    if (uncompress(raw.data(), &size, s.data, static_cast<uLong>(s.stored)) != Z_OK ||
        size != raw.size()) {
      errors[k] = "a tree's compressed data is corrupt";
      return;
    }
    t.nodes.resize(s.nodes);
    const uint8_t* planes = raw.data();
    readPlanes(planes, t.nodes.data(), s.nodes, sizeof(SplitNode));
    planes += s.nodes * sizeof(SplitNode);
    if (version >= 5) {
      t.grid = s.grid;
      t.modes.resize(s.modes);
      t.descriptors.resize(s.modes);
      readPlanes(planes, t.modes.data(), s.modes, sizeof(PackedMode));
      planes += s.modes * sizeof(PackedMode);
      readPlanes(planes, t.descriptors.data(), s.modes, sizeof(Descriptor));
    } else {
      readWholeModes(planes, s.modes, t);
    }
    errors[k] = validateTree(t);
  });
  for (const std::string& error : errors)
    if (!error.empty()) {
      why = error;
      return false;
    }
  return true;
}

// A version-1 or -2 forest, converted: each leaf's range moves into its node, each
// mode's descriptor into the descriptor array; support and log-determinant,
// which nothing reads, are dropped.
bool readTreesV1(ByteReader& r, Forest& forest, std::string& why) {
  uint32_t trees = 0;
  if (!readTreeCount(r, trees, why)) return false;
  forest.trees.resize(trees);
  std::vector<LeafRange> leaves;
  std::vector<v1::LeafMode> modes;
  for (Tree& t : forest.trees) {
    if (!r.array(t.nodes) || !r.array(leaves) || !r.array(modes)) return false;
    for (SplitNode& n : t.nodes) {
      if (!n.isLeaf()) continue;
      // -(left + 1) in 64 bits: left may be INT32_MIN.
      const int64_t leaf = -(static_cast<int64_t>(n.left) + 1);
      if (leaf >= static_cast<int64_t>(leaves.size())) {
        why = "leaf index out of range";
        return false;
      }
      n = SplitNode::leaf(leaves[leaf]);
    }
    std::vector<LeafMode> whole(modes.size());
    t.descriptors.resize(modes.size());
    for (size_t m = 0; m < modes.size(); ++m) {
      std::memcpy(whole[m].mean.data(), modes[m].mean, sizeof modes[m].mean);
      std::memcpy(whole[m].information.data(), modes[m].information, sizeof modes[m].information);
      t.descriptors[m] = keptCoefficients(modes[m].descriptor);
    }
    packModes(whole, t.grid, t.modes);
    why = validateTree(t);
    if (!why.empty()) return false;
  }
  return true;
}

}  // namespace

std::vector<uint8_t> packTree(const Tree& tree) { return packTreeStream(tree); }

bool readTrees(ByteReader& r, Forest& forest, uint32_t version, std::string& why) {
  return version <= 2 ? readTreesV1(r, forest, why) : readPlanedTrees(r, forest, version, why);
}

}  // namespace relocalizer::detail
