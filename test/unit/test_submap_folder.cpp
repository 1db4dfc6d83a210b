// A learned set of submaps saved as one folder and continued from it
// (online/submap_folder.h, SubmapLearner::save and resume), on the generated
// room the submap learner is tested on: what a resumed set answers is what
// the saved one answered, bit for bit; a damaged submap file costs that
// submap only; frozen files are written once; a continued run covers what the
// saved one learned and numbers its new submaps after the saved ones.

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "relocalizer/core/file_io.h"
#include "relocalizer/core/outside_text.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/online/learned_places.h"
#include "relocalizer/online/place_files.h"
#include "relocalizer/online/submap_folder.h"
#include "relocalizer/online/submap_learner.h"
#include "support.h"

using namespace relocalizer;
namespace fs = std::filesystem;

namespace {

constexpr int kCap = 6;

SubmapParams rule() {
  SubmapParams p;
  p.overlap = 2;
  return p;
}

std::unique_ptr<SubmapLearner> makeLearner() {
  LearningParams learning = relocalizer::testing::onlineRoomLearning();
  learning.max_keyframes = kCap;
  return std::make_unique<SubmapLearner>(learning, rule(),
                                         relocalizer::testing::onlineRoomRelocalizer());
}

ino_t inode(const fs::path& path) {
  struct stat st = {};
  return ::stat(path.c_str(), &st) == 0 ? st.st_ino : 0;
}

bool mentions(const std::vector<std::string>& warnings, const std::string& text) {
  for (const std::string& w : warnings)
    if (w.find(text) != std::string::npos) return true;
  return false;
}

// The whole walk learned once (20 key frames, cap 6, overlap 2: 5 submaps, the
// last active) and saved into saved_; each test copies the folder it changes.
class SubmapFolder : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    relocalizer::testing::RoomWalk walk = relocalizer::testing::submapRoomWalk();
    learn_ = std::move(walk.learn);
    test_ = std::move(walk.test);
    dir_ = new relocalizer::testing::TempDir("submap_folder");
    learner_ = makeLearner().release();
    for (const RgbdFrame& frame : learn_)
      ASSERT_TRUE(learner_->addKeyFrame(frame, *frame.ground_truth).ok());
    ASSERT_TRUE(learner_->drain());
    ASSERT_TRUE(learner_->save(saved()));
  }
  static void TearDownTestSuite() {
    delete learner_;
    delete dir_;
    learn_.clear();
    test_.clear();
  }
  static std::string saved() { return (dir_->path() / "saved").string(); }
  // A copy of the saved folder to damage.
  static std::string copyOfSaved(const std::string& name) {
    const fs::path copy = dir_->path() / name;
    fs::copy(saved(), copy, fs::copy_options::recursive);
    return copy.string();
  }

  static std::vector<RgbdFrame> learn_, test_;
  static relocalizer::testing::TempDir* dir_;
  static SubmapLearner* learner_;
};
std::vector<RgbdFrame> SubmapFolder::learn_, SubmapFolder::test_;
relocalizer::testing::TempDir* SubmapFolder::dir_ = nullptr;
SubmapLearner* SubmapFolder::learner_ = nullptr;

}  // namespace

TEST(PlaceNames, AFolderIsNamedAfterItselfWithOrWithoutATrailingSlash) {
  EXPECT_EQ(pathStem("/maps/learned/"), "learned");
  EXPECT_EQ(pathStem("/maps/learned//"), "learned");
  EXPECT_EQ(pathStem("/maps/learned"), "learned");
  EXPECT_EQ(pathStem("maps/kitchen.model"), "kitchen");
  EXPECT_EQ(pathStem("kitchen.model"), "kitchen");
}

TEST_F(SubmapFolder, AResumedSetAnswersBitForBitAsTheSavedOne) {
  const std::vector<SubmapModel> before = learner_->models();
  ASSERT_EQ(before.size(), 5u);
  // The manifest names every submap's pair, the last one active.
  const nlohmann::json manifest =
      nlohmann::json::parse(relocalizer::testing::readBytes(submapManifestPath(saved())));
  EXPECT_EQ(manifest.at("format_version"), 1);
  EXPECT_EQ(manifest.at("active"), 4);
  ASSERT_EQ(manifest.at("submaps").size(), 5u);
  for (int s = 0; s < 5; ++s) {
    const nlohmann::json& entry = manifest.at("submaps").at(s);
    EXPECT_EQ(entry.at("name"), "learned/" + std::to_string(s));
    EXPECT_EQ(entry.at("state"), s == 4 ? "active" : "frozen");
    EXPECT_EQ(entry.at("model"), submapFileName(s));
    EXPECT_TRUE(fs::exists(fs::path(saved()) / submapFileName(s)));
    EXPECT_TRUE(fs::exists(fs::path(saved()) / keyFramesPath(submapFileName(s))));
  }

  auto resumed = makeLearner();
  auto warnings = resumed->resume(saved());
  ASSERT_TRUE(warnings.ok()) << warnings.error();
  EXPECT_TRUE(warnings->empty()) << warnings->front();
  const std::vector<SubmapModel> after = resumed->models();
  ASSERT_EQ(after.size(), before.size());
  for (size_t s = 0; s < before.size(); ++s) {
    EXPECT_EQ(after[s].index, before[s].index);
    EXPECT_EQ(after[s].frozen, before[s].frozen);
    EXPECT_EQ(serializeModel(after[s].relocalizer->model()),
              serializeModel(before[s].relocalizer->model()))
        << "submap " << s;
    // The coverage index comes back from the manifest alone.
    const auto& saved_frames = learner_->index().keyFrames(before[s].index);
    const auto& resumed_frames = resumed->index().keyFrames(after[s].index);
    ASSERT_EQ(resumed_frames.size(), saved_frames.size());
    for (size_t k = 0; k < saved_frames.size(); ++k) {
      EXPECT_EQ(resumed_frames[k].id, saved_frames[k].id);
      EXPECT_TRUE(resumed_frames[k].pose.matrix() == saved_frames[k].pose.matrix());
    }
  }
  EXPECT_EQ(resumed->index().active(), 4);
  EXPECT_FALSE(resumed->resume(saved()).ok());  // once, before any key frame
  // Every fourth test frame on every submap: the same answer, bit for bit.
  int answered = 0;
  for (size_t f = 0; f < test_.size(); f += 4)
    for (size_t s = 0; s < before.size(); ++s) {
      const Relocalization a = before[s].relocalizer->relocalize(test_[f]);
      const Relocalization b = after[s].relocalizer->relocalize(test_[f]);
      ASSERT_EQ(a.success, b.success) << "frame " << f << ", submap " << s;
      EXPECT_TRUE(a.pose.matrix() == b.pose.matrix()) << "frame " << f << ", submap " << s;
      answered += relocalizer::testing::correctPose(b, test_[f]);
    }
  EXPECT_GT(answered, 0);
}

TEST_F(SubmapFolder, FrozenFilesAreWrittenOnceAndCopiedToAnotherFolder) {
  // The first save made `saved` the working folder; saving there again
  // rewrites the active submap and the manifest only.
  ASSERT_EQ(learner_->workingFolder(), saved());
  const fs::path folder = saved();
  const ino_t frozen_model = inode(folder / submapFileName(0));
  const ino_t frozen_keyframes = inode(folder / keyFramesPath(submapFileName(3)));
  const ino_t active_model = inode(folder / submapFileName(4));
  ASSERT_TRUE(learner_->save(saved()));
  EXPECT_EQ(inode(folder / submapFileName(0)), frozen_model);
  EXPECT_EQ(inode(folder / keyFramesPath(submapFileName(3))), frozen_keyframes);
  EXPECT_NE(inode(folder / submapFileName(4)), active_model);

  // Another folder gets every file, the frozen ones copied byte for byte.
  const std::string other = (dir_->path() / "other").string();
  ASSERT_TRUE(learner_->save(other));
  EXPECT_EQ(learner_->workingFolder(), saved());
  for (int s = 0; s < 4; ++s)
    for (const std::string& name : {submapFileName(s), keyFramesPath(submapFileName(s))})
      EXPECT_EQ(relocalizer::testing::readBytes(fs::path(other) / name),
                relocalizer::testing::readBytes(folder / name))
          << name;
  auto resumed = makeLearner();
  ASSERT_TRUE(resumed->resume(other).ok());
  EXPECT_EQ(resumed->models().size(), 5u);
}

TEST_F(SubmapFolder, ADamagedSubmapIsSkippedWithAWarningNamingItAndTheRestAnswers) {
  const std::string folder = copyOfSaved("damaged");
  const fs::path model = fs::path(folder) / submapFileName(1);
  fs::resize_file(model, fs::file_size(model) / 2);
  // A frozen submap without its key-frame file still answers.
  fs::remove(fs::path(folder) / keyFramesPath(submapFileName(2)));

  auto resumed = makeLearner();
  auto warnings = resumed->resume(folder);
  ASSERT_TRUE(warnings.ok()) << warnings.error();
  ASSERT_EQ(warnings->size(), 2u);
  EXPECT_TRUE(mentions(*warnings, submapFileName(1))) << (*warnings)[0];
  // Cut short: found from its preamble, before its CRC is computed.
  EXPECT_TRUE(mentions(*warnings, "truncated model file")) << (*warnings)[0];
  EXPECT_TRUE(mentions(*warnings, keyFramesPath(submapFileName(2)) + " is missing"))
      << (*warnings)[1];
  EXPECT_EQ(resumed->warnings(), *warnings);
  std::vector<int> indices;
  for (const SubmapModel& m : resumed->models()) indices.push_back(m.index);
  EXPECT_EQ(indices, (std::vector<int>{0, 2, 3, 4}));
  // Its area is no longer covered: learned again when the camera returns.
  EXPECT_TRUE(resumed->index().keyFrames(1).empty());
  int answered = 0;
  for (const RgbdFrame& frame : test_)
    for (const SubmapModel& m : resumed->models())
      if (relocalizer::testing::correctPose(m.relocalizer->relocalize(frame), frame)) {
        ++answered;
        break;
      }
  EXPECT_GE(answered, static_cast<int>(test_.size()) / 2);

  // Saved again, the skipped submap is no longer named; its number is not reused.
  ASSERT_TRUE(resumed->save(folder));
  auto again = makeLearner();
  auto later = again->resume(folder);
  ASSERT_TRUE(later.ok()) << later.error();
  EXPECT_TRUE(mentions(*later, submapFileName(1) + " is not named by manifest.json: ignored"));
  EXPECT_EQ(again->models().size(), 4u);
  EXPECT_EQ(again->index().submapCount(), 5);
}

TEST_F(SubmapFolder, AMissingOrBadManifestIsAnErrorNamingIt) {
  const std::string folder = copyOfSaved("manifests");
  const std::string manifest = submapManifestPath(folder);
  const std::string good = relocalizer::testing::readBytes(manifest);

  std::string bad = good;
  const std::string count = "\"keyframe_count\": 6";
  ASSERT_NE(bad.find(count), std::string::npos);
  bad.replace(bad.find(count), count.size(), "\"keyframe_count\": 7");
  std::ofstream(manifest) << bad;
  auto wrong_count = makeLearner()->resume(folder);
  ASSERT_FALSE(wrong_count.ok());
  EXPECT_NE(wrong_count.error().find("manifest.json"), std::string::npos) << wrong_count.error();
  EXPECT_NE(wrong_count.error().find("submaps[0].keyframe_count"), std::string::npos)
      << wrong_count.error();

  // Not JSON, and a pose that is not a pose: each an error naming the file (and the field).
  std::ofstream(manifest) << good.substr(0, good.size() / 2);
  auto cut = makeLearner()->resume(folder);
  ASSERT_FALSE(cut.ok());
  EXPECT_NE(cut.error().find(manifest), std::string::npos) << cut.error();
  bad = good;
  const std::string pose = "\"pose\": [";
  bad.replace(bad.find(pose), pose.size(), "\"pose\": [\"x\", ");
  std::ofstream(manifest) << bad;
  auto not_a_pose = makeLearner()->resume(folder);
  ASSERT_FALSE(not_a_pose.ok());
  EXPECT_NE(not_a_pose.error().find("submaps[0].keyframe_poses[0].pose"), std::string::npos)
      << not_a_pose.error();

  fs::remove(manifest);
  auto missing = makeLearner()->resume(folder);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().find(manifest), std::string::npos) << missing.error();

  // Someone else's manifest.json is not overwritten, and no submap is written beside it.
  const std::string foreign = (dir_->path() / "foreign").string();
  fs::create_directories(foreign);
  std::ofstream(submapManifestPath(foreign)) << "{\"mine\": true}\n";
  EXPECT_FALSE(learner_->save(foreign));
  EXPECT_EQ(relocalizer::testing::readBytes(submapManifestPath(foreign)), "{\"mine\": true}\n");
  EXPECT_FALSE(fs::exists(fs::path(foreign) / submapFileName(0)));
}

TEST_F(SubmapFolder, AContinuedRunCoversWhatWasLearnedAndNumbersNewSubmapsAfter) {
  // The first 10 key frames: submap 0 frozen (6), submap 1 active (2 seeds + 4).
  const std::string folder = (dir_->path() / "continued").string();
  {
    auto first = makeLearner();
    for (size_t i = 0; i < 10; ++i)
      ASSERT_TRUE(first->addKeyFrame(learn_[i], *learn_[i].ground_truth).ok());
    ASSERT_TRUE(first->drain());
    // Naming the working folder writes the frozen submap held so far, and a
    // manifest that names it alone (the active is written by saves).
    ASSERT_TRUE(first->useFolder(folder));
    const SubmapManifest named = *readSubmapManifest(folder);
    EXPECT_EQ(named.active, -1);
    ASSERT_EQ(named.submaps.size(), 1u);
    EXPECT_TRUE(named.submaps[0].frozen);
    ASSERT_TRUE(first->save(folder));
    ASSERT_EQ(first->index().submapCount(), 2);
  }
  const ino_t frozen_model = inode(fs::path(folder) / submapFileName(0));
  auto resumed = makeLearner();
  ASSERT_TRUE(resumed->resume(folder).ok());
  ASSERT_EQ(resumed->active()->keyFrames().size(), 6u);
  // The walk again from its start: submap 0's key frames are covered, not stored again.
  int covered = 0;
  for (size_t i = 0; i < learn_.size(); ++i) {
    auto placed = resumed->place(learn_[i], *learn_[i].ground_truth);
    ASSERT_TRUE(placed.ok()) << placed.error();
    if (i < 6) {
      EXPECT_EQ(placed->decision, SubmapDecision::Covered) << "key frame " << i;
      EXPECT_EQ(placed->submap, -1);
    }
    covered += placed->decision == SubmapDecision::Covered;
  }
  EXPECT_GE(covered, 6);
  ASSERT_TRUE(resumed->drain());
  const int submaps = resumed->index().submapCount();
  EXPECT_GT(submaps, 2);
  // Each freeze wrote its submap into the resumed folder at once.
  const SubmapManifest at_freeze = *readSubmapManifest(folder);
  EXPECT_EQ(at_freeze.active, -1);
  EXPECT_EQ(static_cast<int>(at_freeze.submaps.size()), submaps - 1);
  // The working folder is the resumed one: frozen at the freeze, saved now.
  ASSERT_TRUE(resumed->save(folder));
  const SubmapManifest manifest = *readSubmapManifest(folder);
  ASSERT_EQ(static_cast<int>(manifest.submaps.size()), submaps);
  EXPECT_EQ(manifest.active, submaps - 1);
  for (int s = 2; s < submaps; ++s)
    EXPECT_TRUE(fs::exists(fs::path(folder) / submapFileName(s))) << s;
  EXPECT_EQ(inode(fs::path(folder) / submapFileName(0)), frozen_model);
}

TEST_F(SubmapFolder, SavesOnAnotherThreadWhileLearningLeaveAResumableFolder) {
  // As the node does: its save service beside the learning thread.
  const std::string folder = (dir_->path() / "threads").string();
  auto learner = makeLearner();
  ASSERT_TRUE(learner->addKeyFrame(learn_[0], *learn_[0].ground_truth).ok());
  ASSERT_TRUE(learner->addKeyFrame(learn_[1], *learn_[1].ground_truth).ok());
  ASSERT_TRUE(learner->drain());
  std::atomic<bool> done{false};
  std::atomic<int> saves{0};
  std::string failure;
  std::thread saver([&] {
    while (!done) {
      if (Status saved = learner->save(folder); !saved) failure = saved.error();
      ++saves;
    }
  });
  for (size_t i = 2; i < 14; ++i)
    ASSERT_TRUE(learner->addKeyFrame(learn_[i], *learn_[i].ground_truth).ok());
  ASSERT_TRUE(learner->drain());
  done = true;
  saver.join();
  EXPECT_EQ(failure, "");
  EXPECT_GT(saves.load(), 0);
  ASSERT_TRUE(learner->save(folder));
  auto resumed = makeLearner();
  auto warnings = resumed->resume(folder);
  ASSERT_TRUE(warnings.ok()) << warnings.error();
  EXPECT_TRUE(warnings->empty()) << warnings->front();
  ASSERT_EQ(resumed->models().size(), learner->models().size());
  for (size_t s = 0; s < learner->models().size(); ++s)
    EXPECT_EQ(serializeModel(resumed->models()[s].relocalizer->model()),
              serializeModel(learner->models()[s].relocalizer->model()));
}

// Issue 38, files on disk: a manifest, model or key-frame file is checked
// before it is believed (sizes, indices, links), and a folder a peer names
// gets one answer whatever is there.
namespace {

// `folder`'s manifest with its last submap (and the active, when that is
// the one) renumbered to `index`; `frozen`: that submap made a frozen one
// (so that no active names the index).
void renumberLast(const std::string& folder, long long index, bool frozen = false) {
  const std::string path = submapManifestPath(folder);
  nlohmann::ordered_json json =
      nlohmann::ordered_json::parse(relocalizer::testing::readBytes(path));
  auto& last = json["submaps"].back();
  if (json["active"] == last["index"]) json["active"] = frozen ? -1LL : index;
  if (frozen) last["state"] = "frozen";
  last["index"] = index;
  std::ofstream(path, std::ios::trunc) << json.dump(2) << "\n";
}

void writeFile(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

}  // namespace

TEST_F(SubmapFolder, AHugeSubmapIndexIsAnErrorNamingItAndNothingIsSizedByIt) {
  // 2147483647 overflowed `index + 1` (std::length_error: the node aborted);
  // 10,000,000 sized the containers by it (+840 MB).
  // As the active submap, and as a frozen one.
  for (const long long index : {2147483647LL, 10000000LL, 100000LL})
    for (const bool frozen : {false, true}) {
      const std::string folder =
          copyOfSaved("index_" + std::to_string(index) + (frozen ? "_frozen" : ""));
      renumberLast(folder, index, frozen);
      auto resumed = makeLearner()->resume(folder);
      ASSERT_FALSE(resumed.ok()) << index;
      const std::string field = frozen ? "submaps[4].index" : "active";
      EXPECT_TRUE(mentions({resumed.error()}, field + " must be from 0 to 99999"))
          << resumed.error();
      auto place = openPlace("hostile", folder, "map", {});
      ASSERT_FALSE(place.ok()) << index;
      EXPECT_TRUE(mentions({place.error()}, "place 'hostile'")) << place.error();
    }
  // The largest index allowed loads, as the submap it is.
  const std::string folder = copyOfSaved("index_largest");
  renumberLast(folder, kMaxSubmapIndex);
  auto resumed = makeLearner();
  ASSERT_TRUE(resumed->resume(folder).ok());
  ASSERT_EQ(resumed->models().size(), 5u);
  EXPECT_EQ(resumed->models().back().index, kMaxSubmapIndex);

  // A key-frame id past what the key-frame file holds (int32) is refused too.
  std::string text = relocalizer::testing::readBytes(submapManifestPath(saved()));
  const std::string id = "\"id\": 0,";
  ASSERT_NE(text.find(id), std::string::npos);
  text.replace(text.find(id), id.size(), "\"id\": 9223372036854775807,");
  auto huge_id = parseSubmapManifest(text, "m.json");
  ASSERT_FALSE(huge_id.ok());
  EXPECT_TRUE(mentions({huge_id.error()}, "keyframe_poses[0].id must be from 0 to"))
      << huge_id.error();
}

TEST_F(SubmapFolder, SymbolicLinksInASavedSetAreNotFollowedOutOfIt) {
  const std::string folder = copyOfSaved("linked");
  // Submap 1's own model, moved out and linked back: a link could as well
  // reach any file the node may read.
  const fs::path outside = dir_->path() / "outside.model";
  fs::rename(fs::path(folder) / submapFileName(1), outside);
  fs::create_symlink(outside, fs::path(folder) / submapFileName(1));
  auto resumed = makeLearner();
  auto warnings = resumed->resume(folder);
  ASSERT_TRUE(warnings.ok()) << warnings.error();
  EXPECT_TRUE(mentions(*warnings, submapFileName(1) + " is a symbolic link: not followed"))
      << ::testing::PrintToString(*warnings);
  std::vector<int> indices;
  for (const SubmapModel& m : resumed->models()) indices.push_back(m.index);
  EXPECT_EQ(indices, (std::vector<int>{0, 2, 3, 4}));

  // The manifest itself as a link: refused, naming it.
  const std::string manifest = submapManifestPath(folder);
  fs::rename(manifest, dir_->path() / "outside.json");
  fs::create_symlink(dir_->path() / "outside.json", manifest);
  auto linked = makeLearner()->resume(folder);
  ASSERT_FALSE(linked.ok());
  EXPECT_TRUE(mentions({linked.error()}, manifest + ": is a symbolic link")) << linked.error();
}

TEST_F(SubmapFolder, AManifestIsSizedBeforeItIsReadAndItsErrorsAreOurWordsInUtf8) {
  const std::string folder = copyOfSaved("big_manifest");
  const std::string manifest = submapManifestPath(folder);
  // Sparse: a manifest past the limit is refused from its size, unread.
  fs::resize_file(manifest, kMaxSubmapManifestBytes + 1);
  auto big = readSubmapManifest(folder);
  ASSERT_FALSE(big.ok());
  EXPECT_TRUE(mentions({big.error()}, "more than the " + std::to_string(kMaxSubmapManifestBytes)))
      << big.error();

  // Bytes that are not UTF-8: the error names the place in the file, never
  // quotes them nor the JSON library's own text.
  writeFile(manifest, "{\"format\": \"\xff\xfe\x01\"}");
  auto garbage = readSubmapManifest(folder);
  ASSERT_FALSE(garbage.ok());
  EXPECT_TRUE(printableText(garbage.error())) << garbage.error();
  EXPECT_TRUE(mentions({garbage.error()}, "JSON that does not parse (at byte")) << garbage.error();
  EXPECT_FALSE(mentions({garbage.error()}, "json.exception")) << garbage.error();
  // A field of the wrong type: our words, and what it holds quoted short.
  std::string text = relocalizer::testing::readBytes(submapManifestPath(saved()));
  const std::string name = "\"place_name\": \"learned\"";
  ASSERT_NE(text.find(name), std::string::npos);
  text.replace(text.find(name), name.size(), "\"place_name\": [" + std::string(100, '1') + "]");
  auto wrong = parseSubmapManifest(text, "m.json");
  ASSERT_FALSE(wrong.ok());
  EXPECT_TRUE(mentions({wrong.error()}, "place_name must be a string")) << wrong.error();
  EXPECT_FALSE(mentions({wrong.error()}, "json.exception")) << wrong.error();
}

TEST(FileHeads, AFileThatIsNotAModelIsRefusedFromItsHeadWhateverItsSize) {
  relocalizer::testing::TempDir dir("file_heads");
  // 1 TiB, sparse: read whole, it was std::bad_alloc (2 GB: +2 GB and 6.6 s).
  const fs::path huge = dir.path() / "huge.model";
  writeFile(huge, "not a model");
  std::error_code ec;
  fs::resize_file(huge, std::uintmax_t{1} << 40, ec);
  if (ec) GTEST_SKIP() << "no sparse 1 TiB file here: " << ec.message();
  auto model = loadModel(huge.string());
  ASSERT_FALSE(model.ok());
  EXPECT_TRUE(mentions({model.error()}, "wrong magic number")) << model.error();
  auto key_frames = loadKeyFrames(huge.string());
  ASSERT_FALSE(key_frames.ok());
  EXPECT_TRUE(mentions({key_frames.error()}, "bad magic")) << key_frames.error();
  auto place = openPlace("big", huge.string(), "map", {});
  ASSERT_FALSE(place.ok());
  EXPECT_TRUE(mentions({place.error()}, "wrong magic number")) << place.error();

  // A model's preamble naming a body past the file's end: truncated, from the preamble.
  std::string preamble(kModelMagic);
  const uint32_t version = kModelFormatVersion, reserved = 0, crc = 0;
  const uint64_t body = uint64_t{1} << 40;
  for (const auto& [data, size] :
       {std::pair<const void*, size_t>{&version, 4}, {&reserved, 4}, {&body, 8}, {&crc, 4}})
    preamble.append(static_cast<const char*>(data), size);
  writeFile(huge, preamble + "short");
  auto cut = loadModel(huge.string());
  ASSERT_FALSE(cut.ok());
  EXPECT_TRUE(mentions({cut.error()}, "truncated model file (5 of 1099511627776 body bytes"))
      << cut.error();
}

// Issue 38, D1 for folders: one saved set loaded twice into one frame (under
// another name, as a copy, through a link or another spelling of its path)
// was accepted, and every frame was then "ambiguous place".
TEST_F(SubmapFolder, OneFolderTwiceInOneFrameIsRefusedNamingItsHolder) {
  const RelocalizerParams params = relocalizer::testing::onlineRoomRelocalizer();
  const auto load = [&](const std::string& name, const std::string& path,
                        const std::string& frame = "map") {
    auto files = openPlace(name, path, frame, params);
    EXPECT_TRUE(files.ok()) << files.error();
    return std::move(*files);
  };
  PlaceSet set;
  ASSERT_TRUE(putPlaceFiles(set, "a", load("a", saved())).ok());
  ASSERT_EQ(set.size(), 5u);
  const fs::path link = dir_->path() / "link_to_saved";
  fs::create_directory_symlink(saved(), link);
  const std::string copy = copyOfSaved("twice_copy");
  for (const std::string& path : {saved(), saved() + "/", saved() + "/./", link.string(), copy,
                                  (fs::path(saved()) / submapFileName(2)).string()}) {
    const Status twice = putPlaceFiles(set, "b", load("b", path));
    ASSERT_FALSE(twice.ok()) << path;
    EXPECT_TRUE(mentions({twice.error()}, "is already loaded as place a/0 (" + saved() + "/" +
                                              submapFileName(0) + ") of group a in map") ||
                mentions({twice.error()}, "is already loaded as place a/2"))
        << twice.error();
    EXPECT_TRUE(mentions({twice.error()}, "unload a first")) << twice.error();
  }
  ASSERT_EQ(set.size(), 5u);
  // In another frame it is another map; the group itself may be loaded again.
  EXPECT_TRUE(putPlaceFiles(set, "b", load("b", copy, "other_map")).ok());
  EXPECT_TRUE(putPlaceFiles(set, "a", load("a", copy)).ok());
  EXPECT_EQ(set.size(), 10u);

  // The learning run's own frozen submaps are their files too: the folder
  // it saved, loaded beside it into its frame (the node's learned group),
  // is refused.
  PlaceSet learning;
  ASSERT_TRUE(putLearnedPlaces(learning, learner_->models(), {"learned", "map"}).ok());
  const Status beside = putPlaceFiles(learning, "old", load("old", saved()));
  ASSERT_FALSE(beside.ok());
  EXPECT_TRUE(
      mentions({beside.error()}, "is already loaded as place learned/0 (learned) of group learned"))
      << beside.error();
}

// Issue 41: one opener of a place on disk. A folder opened under no name is
// the set as it was saved (evaluate --model FOLDER), each submap answering
// with the model the learner had, named and identified by its file.
TEST_F(SubmapFolder, AFolderOpensUnderItsSavedNameWithTheLearnersModels) {
  const RelocalizerParams params = relocalizer::testing::onlineRoomRelocalizer();
  const std::vector<SubmapModel> learned = learner_->models();
  auto opened = openPlace("", saved(), "", params);
  ASSERT_TRUE(opened.ok()) << opened.error();
  EXPECT_TRUE(opened->folder);
  EXPECT_EQ(opened->name, "learned");
  EXPECT_EQ(opened->map_frame, "map");
  ASSERT_EQ(opened->places.size(), learned.size());
  for (std::size_t s = 0; s < learned.size(); ++s) {
    const Place& place = opened->places[s];
    EXPECT_EQ(place.name, "learned/" + std::to_string(learned[s].index));
    EXPECT_EQ(place.group, "learned");
    EXPECT_EQ(place.map_frame, "map");
    EXPECT_EQ(place.source, (fs::path(saved()) / submapFileName(learned[s].index)).string());
    EXPECT_EQ(place.model_id, modelFileIdentity(place.source));
    EXPECT_EQ(serializeModel(place.relocalizer->model()),
              serializeModel(learned[s].relocalizer->model()))
        << place.name;
  }
  // Asked for by name and frame, the same folder answers as those.
  auto named = openPlace("walk", saved(), "building", params);
  ASSERT_TRUE(named.ok()) << named.error();
  EXPECT_EQ(named->places.front().name, "walk/0");
  EXPECT_EQ(named->places.front().map_frame, "building");
  EXPECT_EQ(named->saved_map_frame, "map");
  // A folder with no manifest says what was expected there.
  const fs::path empty = dir_->path() / "no_manifest";
  fs::create_directory(empty);
  auto nothing = openPlace("", empty.string(), "", params);
  ASSERT_FALSE(nothing.ok());
  EXPECT_TRUE(mentions({nothing.error()}, empty.string() +
                                              ": is a directory, not a model file nor a folder "
                                              "of learned submaps (it has no manifest.json)"))
      << nothing.error();
}

// The active submap's model answers only beside the key frames it was saved
// with (a save cut between its two files leaves the key frames of a newer
// model): the reader refuses that model, naming both files, as a learner
// continuing the set would, and the frozen submaps still answer.
TEST_F(SubmapFolder, AnActiveSubmapsModelAnswersOnlyBesideItsOwnKeyFrames) {
  const RelocalizerParams params = relocalizer::testing::onlineRoomRelocalizer();
  const std::vector<SubmapModel> learned = learner_->models();
  ASSERT_FALSE(learned.back().frozen);
  const int active = learned.back().index;
  const std::string folder = copyOfSaved("active_cut");
  fs::copy_file(fs::path(folder) / submapFileName(active - 1),
                fs::path(folder) / submapFileName(active), fs::copy_options::overwrite_existing);
  auto opened = openPlace("", folder, "", params);
  ASSERT_TRUE(opened.ok()) << opened.error();
  ASSERT_EQ(opened->places.size(), learned.size() - 1);
  EXPECT_EQ(opened->places.back().name, "learned/" + std::to_string(active - 1));
  ASSERT_EQ(opened->warnings.size(), 1u);
  EXPECT_TRUE(mentions(opened->warnings, submapFileName(active) + " is not the model " + folder +
                                             "/" + keyFramesPath(submapFileName(active))))
      << opened->warnings[0];
  // Without its key frames the active model is not answered from either.
  fs::remove(fs::path(folder) / keyFramesPath(submapFileName(active)));
  auto alone = openPlace("", folder, "", params);
  ASSERT_TRUE(alone.ok()) << alone.error();
  EXPECT_EQ(alone->places.size(), learned.size() - 1);
  EXPECT_TRUE(mentions(alone->warnings, "without its key frames")) << alone->warnings[0];
}

// Issue 41: one naming of a learner's models as places. The node keeps a
// lone submap 0 under the place's own name; the tools index it.
TEST_F(SubmapFolder, ALearnersModelsArePlacesOfItsGroupNamedOneWay) {
  const std::vector<SubmapModel> models = learner_->models();
  const std::vector<Place> places = learnedPlaces(models, {"walk", "building"});
  ASSERT_EQ(places.size(), models.size());
  for (std::size_t s = 0; s < models.size(); ++s) {
    EXPECT_EQ(places[s].name, "walk/" + std::to_string(models[s].index));
    EXPECT_EQ(places[s].group, "walk");
    EXPECT_EQ(places[s].map_frame, "building");
    EXPECT_EQ(places[s].relocalizer, models[s].relocalizer);
    // A frozen submap is its file; the active one is no file's.
    EXPECT_EQ(places[s].model_id,
              models[s].frozen ? modelIdentity(models[s].file.crc, models[s].file.size) : "");
  }
  const std::vector<SubmapModel> first(models.begin(), models.begin() + 1);
  EXPECT_EQ(learnedPlaces(first, {"walk", "building"}).front().name, "walk/0");
  EXPECT_EQ(learnedPlaces(first, {"walk", "building"}, LoneSubmap::AsThePlace).front().name,
            "walk");
  EXPECT_EQ(learnedPlaces(models, {"walk", "building"}, LoneSubmap::AsThePlace).front().name,
            "walk/0");
}

TEST_F(SubmapFolder, APeersPathThatIsNotOursGetsOneAnswerWhateverIsThere) {
  const fs::path base = dir_->path() / "probe";
  fs::create_directories(base / "empty_folder");
  writeFile(base / "text.model", "hello");
  ASSERT_EQ(::mkfifo((base / "fifo.model").c_str(), 0600), 0);
  const std::string expected =
      "cannot load place 'p': X is not a model file nor a folder of "
      "learned submaps that this node can read";
  for (const std::string name :
       {"missing.model", "missing/deeper.model", "empty_folder", "text.model", "fifo.model"}) {
    const std::string path = (base / name).string();
    std::string answer = unreadablePlaceError("p", path);
    ASSERT_NE(answer.find(path), std::string::npos) << answer;
    answer.replace(answer.find(path), path.size(), "X");
    EXPECT_EQ(answer, expected) << name;
  }
  // Not text: refused without quoting it.
  for (const std::string path : {(base / "a\xff.model").string(), (base / "a\nb").string()}) {
    const std::string answer = unreadablePlaceError("p", path);
    EXPECT_TRUE(mentions({answer}, "not printable text")) << answer;
    EXPECT_TRUE(printableText(answer));
  }
  // Ours: the loader's own answer applies.
  EXPECT_EQ(unreadablePlaceError("p", saved()), "");
  EXPECT_EQ(unreadablePlaceError("p", (fs::path(saved()) / submapFileName(0)).string()), "");
}

TEST(SaveFolders, ASaveGoesOnlyIntoANewEmptyOrSavedFolderInsideTheRoot) {
  relocalizer::testing::TempDir dir("save_folders");
  const std::string root = (dir.path() / "saves").string();
  // A stand-in for /etc/cron.d: a folder outside the root, holding files.
  const fs::path cron = dir.path() / "cron.d";
  fs::create_directories(cron);
  writeFile(cron / "job", "* * * * * root true\n");

  // Relative paths resolve inside the root (created when missing), chains too.
  auto relative = confinedSaveFolder(root, "site/run1");
  ASSERT_TRUE(relative.ok()) << relative.error();
  EXPECT_EQ(*relative, (fs::canonical(root) / "site/run1").string());
  auto absolute = confinedSaveFolder(root, root + "/run2");
  ASSERT_TRUE(absolute.ok()) << absolute.error();

  // Outside, by absolute path, by `..` and by a link inside the root: refused alike.
  fs::create_directory_symlink(cron, fs::path(root) / "link");
  for (const std::string requested :
       {cron.string(), (cron / "new").string(), std::string("../cron.d"), std::string("link"),
        std::string("link/new"), root, std::string("."), std::string("/")}) {
    auto refused = confinedSaveFolder(root, requested);
    ASSERT_FALSE(refused.ok()) << requested;
    EXPECT_TRUE(mentions({refused.error()}, "not inside the save folder")) << refused.error();
  }
  // A folder inside that holds other files is not ours to fill; an empty one
  // and an earlier save are.
  fs::create_directories(fs::path(root) / "notes");
  writeFile(fs::path(root) / "notes" / "todo.txt", "x");
  auto foreign = confinedSaveFolder(root, "notes");
  ASSERT_FALSE(foreign.ok());
  EXPECT_TRUE(mentions({foreign.error()}, "holds files that are not a saved set"))
      << foreign.error();
  fs::create_directories(fs::path(root) / "empty");
  EXPECT_TRUE(confinedSaveFolder(root, "empty").ok());
  const fs::path earlier = fs::path(root) / "earlier";
  fs::create_directories(earlier);
  writeFile(earlier / kSubmapManifestName, std::string(kSubmapManifestMagic) + "}\n");
  writeFile(earlier / submapFileName(0), "model");
  EXPECT_TRUE(confinedSaveFolder(root, "earlier").ok());
  // A path that is not text is refused without being quoted.
  auto binary = confinedSaveFolder(root, "/etc/\xff");
  ASSERT_FALSE(binary.ok());
  EXPECT_TRUE(printableText(binary.error())) << binary.error();
  EXPECT_EQ(std::distance(fs::directory_iterator(cron), fs::directory_iterator()), 1);
}
