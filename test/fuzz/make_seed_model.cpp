// Writes small valid models for the fuzz_model seed corpus, so no binary model
// is committed: `make_seed_model <folder>`. The forests are built by hand (a
// split node with two leaves; a leaf-only tree) rather than trained, which
// keeps each file near 2 KB and the build quick.

#include <cstdio>
#include <string>

#include "relocalizer/forest/model_io.h"

using namespace relocalizer;

namespace {

void addMode(Tree& t, float x, float y, float z, int8_t d0) {
  LeafMode m;
  m.mean = Eigen::Vector3f(x, y, z);
  m.setCovariance(Eigen::Matrix3f::Identity() * 0.01f);
  // The tree's grid spans every mode: repacked with each one added.
  std::vector<LeafMode> modes;
  for (uint32_t i = 0; i < t.modes.size(); ++i) modes.push_back(t.mode(i));
  modes.push_back(m);
  packModes(modes, t.grid, t.modes);
  Descriptor d{};
  d[0] = d0;
  t.descriptors.push_back(d);
}

Tree splitTree(FeatureType type) {
  Tree t;
  SplitNode root;
  root.feature.offset_u = 40;
  root.feature.offset_v = -25;
  root.feature.type = type;
  root.feature.channel_p = 1;
  root.feature.channel_q = 2;
  root.threshold = type == FeatureType::Colour ? 3.0f : 0.05f;
  root.left = 1;
  t.nodes = {root, SplitNode::leaf({0, 2}), SplitNode::leaf({2, 1})};
  addMode(t, 0.1f, 0.2f, 1.5f, 100);
  addMode(t, -0.3f, 0.0f, 2.0f, -50);
  addMode(t, 1.0f, 1.0f, 1.0f, 7);
  return t;
}

Tree leafTree() {
  Tree t;
  t.nodes = {SplitNode::leaf({0, 1})};
  addMode(t, 0.5f, 0.5f, 0.5f, 1);
  return t;
}

Model baseModel() {
  Model m;
  m.summary.dataset = "seed";
  m.summary.format = "synthetic";
  m.summary.frames = "0-9";
  m.summary.images = 10;
  m.summary.seconds = 1.5;
  m.summary.threads = 1;
  m.summary.scene_min = Eigen::Vector3f(-1, -1, 0);
  m.summary.scene_max = Eigen::Vector3f(1, 1, 2);
  m.summary.software_version = "fuzz-seed";
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s <output folder>\n", argv[0]);
    return 2;
  }
  const std::string dir = argv[1];
  Model both = baseModel();
  both.points.trees = {splitTree(FeatureType::Colour), leafTree()};
  both.lines.trees = {splitTree(FeatureType::Depth)};
  Model points_only = baseModel();
  points_only.params.train_lines = false;
  points_only.points.trees = {leafTree()};
  for (const auto& [name, model] : {std::pair<const char*, const Model&>{"two_forests.model", both},
                                    {"points_only.model", points_only}}) {
    if (auto status = saveModel(model, dir + "/" + name); !status) {
      std::fprintf(stderr, "%s\n", status.error().c_str());
      return 1;
    }
    if (auto loaded = loadModel(dir + "/" + name); !loaded) {
      std::fprintf(stderr, "seed model does not load: %s\n", loaded.error().c_str());
      return 1;
    }
  }
  return 0;
}
