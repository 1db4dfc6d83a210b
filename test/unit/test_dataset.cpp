// Dataset readers and frame selection. Fixtures are tiny images written at
// test time (no binary files in the repository); the real-data check runs on
// ../shared/data/7scenes-redkitchen-dev when it is present.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <thread>

#include "relocalizer/core/decimal_number.h"
#include "relocalizer/core/id_ranges.h"
#include "relocalizer/data/dataset.h"
#include "relocalizer/data/frame_selection.h"
#include "relocalizer/data/frame_source.h"
#include "support.h"

using namespace relocalizer;
using relocalizer::testing::TempDir;
namespace fs = std::filesystem;

namespace {

constexpr int kWidth = 32;
constexpr int kHeight = 24;

::testing::AssertionResult mentions(const std::string& message, const std::string& part) {
  if (message.find(part) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "'" << message << "' does not mention '" << part << "'";
}

template <typename T>
std::string errorOf(const Expected<T>& result) {
  return result.ok() ? std::string("<no error>") : result.error();
}

Pose makePose(double angle_deg, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  Pose pose = Pose::Identity();
  pose.linear() = Eigen::AngleAxisd(angle_deg * M_PI / 180.0, axis.normalized()).toRotationMatrix();
  pose.translation() = t;
  return pose;
}

void writeText(const fs::path& file, const std::string& content) {
  fs::create_directories(file.parent_path());
  std::ofstream(file) << content;
}

std::string matrixText(const Eigen::Matrix4d& m) {
  std::ostringstream out;
  out << std::setprecision(17);
  for (int r = 0; r < 4; ++r)
    out << m(r, 0) << " " << m(r, 1) << " " << m(r, 2) << " " << m(r, 3) << "\n";
  return out.str();
}

// 16-bit depth of `value` everywhere but two invalid pixels: (0, 0) = 0 and
// (1, 0) = 65535, the two "no reading" codes.
cv::Mat depthImage(uint16_t value, cv::Size size = {kWidth, kHeight}) {
  cv::Mat depth(size, CV_16UC1, cv::Scalar(value));
  depth.at<uint16_t>(0, 0) = 0;
  depth.at<uint16_t>(0, 1) = 65535;
  return depth;
}

std::string stem(int number) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "frame-%06d", number);
  return buffer;
}

// One 7-Scenes frame: colour filled with (b, g, r) = (10 * number, 100, 200),
// depth 1.5 m, the given pose.
void writeSevenScenesFrame(const fs::path& dir, int number, const std::optional<Pose>& pose,
                           const std::string& colour_ext = ".png",
                           cv::Size colour_size = {kWidth, kHeight}) {
  fs::create_directories(dir);
  const std::string base = (dir / stem(number)).string();
  cv::imwrite(base + ".color" + colour_ext,
              cv::Mat(colour_size, CV_8UC3, cv::Scalar(10 * number, 100, 200)));
  cv::imwrite(base + ".depth.png", depthImage(1500));
  if (pose) writeText(base + ".pose.txt", matrixText(pose->matrix()));
}

Pose sevenScenesPose(int number) {
  return makePose(10.0 * number, {0.2, 1, 0.3}, {0.1 * number, -0.2, 1.0 + 0.01 * number});
}

void writeSevenScenesFolder(const fs::path& dir, int frames, bool intrinsics_file = true) {
  for (int i = 0; i < frames; ++i) writeSevenScenesFrame(dir, i, sevenScenesPose(i));
  if (intrinsics_file) writeText(dir / "camera-intrinsics.txt", "500 0 16\n0 510 12\n0 0 1\n");
}

void expectPoseNear(const Pose& actual, const Pose& expected, double tolerance = 1e-9) {
  EXPECT_TRUE(actual.matrix().isApprox(expected.matrix(), tolerance))
      << "actual\n"
      << actual.matrix() << "\nexpected\n"
      << expected.matrix();
}

std::unique_ptr<Dataset> openOrFail(const std::string& path, const DatasetOptions& options = {}) {
  auto dataset = openDataset(path, options);
  EXPECT_TRUE(dataset.ok()) << errorOf(dataset);
  return dataset.ok() ? std::move(dataset).value() : nullptr;
}

}  // namespace

// ---- frame selection ------------------------------------------------------------

TEST(DecimalNumber, ReadsWhatStrtodReadsInTheCLocaleAndNothingAround) {
  EXPECT_EQ(parseDecimal("0.25"), 0.25);
  EXPECT_EQ(parseDecimal("-1.5e-3"), -1.5e-3);
  EXPECT_EQ(parseDecimal("+2"), 2.0);
  EXPECT_EQ(parseDecimal("7"), 7.0);
  EXPECT_TRUE(std::isinf(*parseDecimal("-inf")));
  EXPECT_TRUE(std::isnan(*parseDecimal("nan")));
  for (const char* bad : {"", " 1", "1 ", "1,5", "0x10", "1.5.2", "+-1", "e3", "1e"})
    EXPECT_FALSE(parseDecimal(bad)) << "'" << bad << "'";
}

TEST(FrameSelection, RangesAndSingleNumbers) {
  auto selection = FrameSelection::parse("0-99,200-299");
  ASSERT_TRUE(selection.ok()) << errorOf(selection);
  EXPECT_FALSE(selection->all());
  for (int id : {0, 50, 99, 200, 299}) EXPECT_TRUE(selection->contains(id)) << id;
  for (int id : {-1, 100, 199, 300, 100000}) EXPECT_FALSE(selection->contains(id)) << id;
  EXPECT_EQ(selection->str(), "0-99,200-299");

  auto spaced = FrameSelection::parse("  5 , 10 - 12 ");
  ASSERT_TRUE(spaced.ok()) << errorOf(spaced);
  EXPECT_TRUE(spaced->contains(5));
  EXPECT_FALSE(spaced->contains(6));
  EXPECT_TRUE(spaced->contains(11));
  EXPECT_EQ(spaced->str(), "5,10-12");
}

TEST(FrameSelection, CanonicalFormMergesAndRoundTrips) {
  auto selection = FrameSelection::parse("9,3-5,4-8,20");
  ASSERT_TRUE(selection.ok()) << errorOf(selection);
  EXPECT_EQ(selection->str(), "3-9,20");
  auto again = FrameSelection::parse(selection->str());
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->str(), "3-9,20");
  EXPECT_EQ(formatIdRanges({7, 1, 2, 3, 9, 8, 20}), "1-3,7-9,20");
  EXPECT_EQ(formatIdRanges({}), "none");
}

TEST(FrameSelection, EmptyAndAllSelectEverything) {
  for (const std::string expression : {"", "   ", "all"}) {
    auto selection = FrameSelection::parse(expression);
    ASSERT_TRUE(selection.ok()) << expression;
    EXPECT_TRUE(selection->all());
    EXPECT_TRUE(selection->contains(123456));
    EXPECT_EQ(selection->str(), "all");
  }
  EXPECT_TRUE(FrameSelection().all());
}

TEST(FrameSelection, BadExpressionsSayWhatAndWhere) {
  struct Case {
    std::string expression, item, problem;
  };
  const std::vector<Case> cases = {
      {"abc", "item 1 'abc'", "not a frame number"},
      {"5-2", "item 1 '5-2'", "range end 2 is before its start 5"},
      {"-3", "item 1 '-3'", "missing range start"},
      {"1,,2", "item 2", "is empty"},
      {"1-", "item 1 '1-'", "missing range end"},
      {"0-99,2x", "item 2 '2x'", "not a frame number"},
      {"1-2-3", "item 1 '1-2-3'", "more than one '-'"},
      {"99999999999", "item 1", "too large"},
      {"1,", "item 2", "is empty"},
  };
  for (const auto& c : cases) {
    auto selection = FrameSelection::parse(c.expression);
    ASSERT_FALSE(selection.ok()) << c.expression;
    const std::string& message = selection.error();
    EXPECT_EQ(message.rfind("bad frame range expression '" + c.expression + "': ", 0), 0u)
        << message;
    EXPECT_TRUE(mentions(message, c.item));
    EXPECT_TRUE(mentions(message, c.problem));
  }
}

// ---- format names ---------------------------------------------------------------

TEST(DatasetFormat, ParsesCommandLineNames) {
  EXPECT_EQ(*parseDatasetFormat("auto"), DatasetFormat::Auto);
  EXPECT_EQ(*parseDatasetFormat("7scenes"), DatasetFormat::SevenScenesFolder);
  EXPECT_EQ(*parseDatasetFormat("12scenes"), DatasetFormat::TwelveScenes);
  EXPECT_EQ(*parseDatasetFormat("4Scenes"), DatasetFormat::TwelveScenes);
  EXPECT_EQ(*parseDatasetFormat("TUM"), DatasetFormat::Tum);
  auto bad = parseDatasetFormat("kitti");
  ASSERT_FALSE(bad.ok());
  EXPECT_TRUE(mentions(bad.error(), "'kitti'"));
  EXPECT_TRUE(mentions(bad.error(), "12scenes"));
  EXPECT_EQ(formatName(DatasetFormat::Tum), "TUM RGB-D");
}

// ---- 7-Scenes folder ------------------------------------------------------------

TEST(SevenScenesFolder, ReadsFramesIntrinsicsDepthAndPoses) {
  TempDir dir;
  writeSevenScenesFolder(dir.path(), 3);
  auto dataset = openOrFail(dir.str());
  ASSERT_TRUE(dataset);
  EXPECT_EQ(dataset->format(), DatasetFormat::SevenScenesFolder);
  ASSERT_EQ(dataset->size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(dataset->id(i), static_cast<int>(i));
    EXPECT_EQ(dataset->stamp(i), static_cast<double>(i));
    ASSERT_TRUE(dataset->groundTruth(i).has_value());
    expectPoseNear(*dataset->groundTruth(i), sevenScenesPose(static_cast<int>(i)));
  }
  const CameraIntrinsics& camera = dataset->camera();
  EXPECT_EQ(camera.fx, 500);
  EXPECT_EQ(camera.fy, 510);
  EXPECT_EQ(camera.cx, 16);
  EXPECT_EQ(camera.cy, 12);
  EXPECT_EQ(camera.width, kWidth);
  EXPECT_EQ(camera.height, kHeight);

  auto frame = dataset->load(2);
  ASSERT_TRUE(frame.ok()) << errorOf(frame);
  EXPECT_EQ(frameValidationError(*frame), "");
  EXPECT_EQ(frame->id, 2);
  EXPECT_EQ(frame->stamp, 2.0);
  EXPECT_EQ(frame->source, (dir.path() / "frame-000002.color.png").string());
  EXPECT_EQ(frame->colour.type(), CV_8UC3);
  EXPECT_EQ(frame->colour.at<cv::Vec3b>(5, 5), cv::Vec3b(20, 100, 200));
  EXPECT_TRUE(std::isnan(frame->depth.at<float>(0, 0)));  // 0
  EXPECT_TRUE(std::isnan(frame->depth.at<float>(0, 1)));  // 65535
  EXPECT_FLOAT_EQ(frame->depth.at<float>(5, 5), 1.5f);
  ASSERT_TRUE(frame->ground_truth.has_value());
  expectPoseNear(*frame->ground_truth, sevenScenesPose(2));
  EXPECT_EQ(frame->camera.fx, 500);
}

TEST(FrameSource, AFolderAsASourceNamesItsFormatAndTheFramesUsed) {
  TempDir dir;
  writeSevenScenesFolder(dir.path(), 6);
  DatasetOptions options;
  options.frames = "0-1,3,5";
  auto source = openDatasetSource(dir.str(), options);
  ASSERT_TRUE(source.ok()) << errorOf(source);
  const FrameSource& s = **source;
  EXPECT_EQ(s.size(), 4u);
  EXPECT_EQ(s.path(), dir.str());
  EXPECT_EQ(s.usedIds(), "0-1,3,5");
  EXPECT_EQ(s.formatDescription(), formatName(DatasetFormat::SevenScenesFolder));
  EXPECT_TRUE(s.integerStamps());
  EXPECT_EQ(s.camera().fx, 500);
  auto frame = s.load(2);
  ASSERT_TRUE(frame.ok()) << errorOf(frame);
  EXPECT_EQ(frame->id, 3);
  EXPECT_TRUE(
      mentions(errorOf(openDatasetSource((dir.path() / "missing").string(), {})), "missing"));
}

TEST(SevenScenesFolder, DefaultIntrinsicsJpegColourAndNoPoses) {
  TempDir dir;
  for (int i = 0; i < 2; ++i) writeSevenScenesFrame(dir.path(), i, std::nullopt, ".jpg");
  auto dataset = openOrFail(dir.str());
  ASSERT_TRUE(dataset);
  EXPECT_EQ(dataset->format(), DatasetFormat::SevenScenesFolder);
  EXPECT_EQ(dataset->camera().fx, 585);
  EXPECT_EQ(dataset->camera().fy, 585);
  EXPECT_EQ(dataset->camera().cx, 320);
  EXPECT_EQ(dataset->camera().cy, 240);
  EXPECT_FALSE(dataset->groundTruth(0).has_value());
  auto frame = dataset->load(1);
  ASSERT_TRUE(frame.ok()) << errorOf(frame);
  EXPECT_TRUE(mentions(frame->source, "frame-000001.color.jpg"));
  EXPECT_NEAR(frame->colour.at<cv::Vec3b>(5, 5)[2], 200, 8);  // JPEG is lossy
}

TEST(SevenScenesFolder, SelectionKeepsChosenIdsAndSummaryShowsThem) {
  TempDir dir;
  writeSevenScenesFolder(dir.path(), 6);
  DatasetOptions options;
  options.frames = "1-2, 4";
  auto dataset = openOrFail(dir.str(), options);
  ASSERT_TRUE(dataset);
  ASSERT_EQ(dataset->size(), 3u);
  EXPECT_EQ(dataset->id(0), 1);
  EXPECT_EQ(dataset->id(1), 2);
  EXPECT_EQ(dataset->id(2), 4);
  const std::string summary = dataset->summary();
  EXPECT_TRUE(mentions(summary, "7-Scenes folder"));
  EXPECT_TRUE(mentions(summary, dir.str()));
  EXPECT_TRUE(mentions(summary, "3 of 6"));
  EXPECT_TRUE(mentions(summary, "1-2,4"));
  EXPECT_TRUE(mentions(summary, "32x24"));
  EXPECT_TRUE(mentions(summary, "fx 500"));
  EXPECT_TRUE(mentions(summary, "ground truth: 3 of 3"));
  // Only the 1 -> 2 step counts: 2 -> 4 skips a frame.
  const double step = (sevenScenesPose(2).translation() - sevenScenesPose(1).translation()).norm();
  char expected[32];
  std::snprintf(expected, sizeof expected, "%.2f m", step);
  EXPECT_TRUE(mentions(summary, expected));
}

TEST(SevenScenesFolder, SelectionMatchingNothingNamesTheExpression) {
  TempDir dir;
  writeSevenScenesFolder(dir.path(), 3);
  DatasetOptions options;
  options.frames = "100-200";
  auto dataset = openDataset(dir.str(), options);
  ASSERT_FALSE(dataset.ok());
  EXPECT_TRUE(mentions(dataset.error(), "'100-200'"));
  EXPECT_TRUE(mentions(dataset.error(), "0-2"));
}

TEST(SevenScenesFolder, LoadIsThreadSafe) {
  TempDir dir;
  writeSevenScenesFolder(dir.path(), 4);
  auto dataset = openOrFail(dir.str());
  ASSERT_TRUE(dataset);
  std::vector<int> ok(8, 0);
  std::vector<std::thread> threads;
  for (size_t t = 0; t < ok.size(); ++t)
    threads.emplace_back([&, t] {
      for (int repeat = 0; repeat < 5; ++repeat) {
        auto frame = dataset->load(t % dataset->size());
        ok[t] += frame.ok() && frame->id == static_cast<int>(t % dataset->size()) ? 1 : 0;
      }
    });
  for (auto& thread : threads) thread.join();
  for (int count : ok) EXPECT_EQ(count, 5);
}

// ---- 7-Scenes scene -------------------------------------------------------------

namespace {
void writeSevenScenesScene(const fs::path& root) {
  for (int seq : {1, 2})
    for (int i = 0; i < 2; ++i)
      writeSevenScenesFrame(root / ("seq-0" + std::to_string(seq)), i, sevenScenesPose(seq + i));
  writeText(root / "TrainSplit.txt", "sequence1\n");
  writeText(root / "TestSplit.txt", "sequence2\r\n\n");
}

std::vector<int> idsOf(const Dataset& dataset) {
  std::vector<int> ids;
  for (size_t i = 0; i < dataset.size(); ++i) ids.push_back(dataset.id(i));
  return ids;
}
}  // namespace

TEST(SevenScenesScene, SplitsSelectSequencesAndIdsEncodeThem) {
  TempDir dir;
  writeSevenScenesScene(dir.path());
  DatasetOptions options;
  options.split = "train";
  auto train = openOrFail(dir.str(), options);
  ASSERT_TRUE(train);
  EXPECT_EQ(train->format(), DatasetFormat::SevenScenesScene);
  EXPECT_EQ(idsOf(*train), (std::vector<int>{1000, 1001}));
  EXPECT_EQ(train->stamp(1), 1001.0);

  options.split = "test";
  auto test = openOrFail(dir.str(), options);
  ASSERT_TRUE(test);
  EXPECT_EQ(idsOf(*test), (std::vector<int>{2000, 2001}));
  ASSERT_TRUE(test->groundTruth(1).has_value());
  expectPoseNear(*test->groundTruth(1), sevenScenesPose(3));
  auto frame = test->load(0);
  ASSERT_TRUE(frame.ok()) << errorOf(frame);
  EXPECT_EQ(frame->id, 2000);
  EXPECT_TRUE(mentions(frame->source, "seq-02"));
  EXPECT_EQ(frame->camera.fx, 585);

  options.split = "all";
  options.frames = "1001-2000";
  auto all = openOrFail(dir.str(), options);
  ASSERT_TRUE(all);
  EXPECT_EQ(idsOf(*all), (std::vector<int>{1001, 2000}));
}

TEST(SevenScenesScene, ExplicitSevenScenesFormatDetectsTheLayout) {
  TempDir scene, folder;
  writeSevenScenesScene(scene.path());
  writeSevenScenesFolder(folder.path(), 2);
  DatasetOptions options;
  options.format = *parseDatasetFormat("7scenes");
  auto a = openOrFail(scene.str(), options);
  auto b = openOrFail(folder.str(), options);
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->format(), DatasetFormat::SevenScenesScene);
  EXPECT_EQ(b->format(), DatasetFormat::SevenScenesFolder);
}

TEST(SevenScenesScene, SplitFileProblemsNameTheFile) {
  TempDir dir;
  writeSevenScenesScene(dir.path());
  DatasetOptions options;
  options.split = "test";

  writeText(dir.path() / "TestSplit.txt", "sequence2\nseq3\n");
  auto malformed = openDataset(dir.str(), options);
  ASSERT_FALSE(malformed.ok());
  EXPECT_TRUE(mentions(malformed.error(), "TestSplit.txt: line 2: expected 'sequenceN'"));

  writeText(dir.path() / "TestSplit.txt", "sequence7\n");
  auto missing_sequence = openDataset(dir.str(), options);
  ASSERT_FALSE(missing_sequence.ok());
  EXPECT_TRUE(mentions(missing_sequence.error(), "seq-07: missing"));

  fs::remove(dir.path() / "TestSplit.txt");
  auto missing_file = openDataset(dir.str(), options);
  ASSERT_FALSE(missing_file.ok());
  EXPECT_TRUE(mentions(missing_file.error(), "TestSplit.txt: missing"));

  options.split = "validation";
  auto bad_split = openDataset(dir.str(), options);
  ASSERT_FALSE(bad_split.ok());
  EXPECT_TRUE(mentions(bad_split.error(), "'validation'"));
}

TEST(SevenScenesScene, SplitOnAnotherLayoutIsAnError) {
  TempDir dir;
  writeSevenScenesFolder(dir.path(), 2);
  DatasetOptions options;
  options.split = "train";
  auto dataset = openDataset(dir.str(), options);
  ASSERT_FALSE(dataset.ok());
  EXPECT_TRUE(mentions(dataset.error(), "split 'train'"));
}

// ---- 12-Scenes ------------------------------------------------------------------

namespace {
// Depth 32x24, colour 64x48 (left half blue, right half red) so a 2x area
// resampling has exact expected values away from the seam.
void writeTwelveScenes(const fs::path& root) {
  writeText(root / "info.txt",
            "m_versionNumber = 4\n"
            "m_sensorName = StructureSensor\n"
            "m_colorWidth = 64\n"
            "m_colorHeight = 48\n"
            "m_depthWidth = 32\n"
            "m_depthHeight = 24\n"
            "m_depthShift = 1000\n"
            "m_calibrationColorIntrinsic = 60 0 32 0 0 60 24 0 0 0 1 0 0 0 0 1 \n"
            "m_calibrationDepthIntrinsic = 30 0 16 0 0 31 12 0 0 0 1 0 0 0 0 1 \n"
            "m_frames.size = 3\n");
  const fs::path data = root / "data";
  fs::create_directories(data);
  cv::Mat colour(48, 64, CV_8UC3, cv::Scalar(255, 0, 0));
  colour.colRange(32, 64).setTo(cv::Scalar(0, 0, 255));
  for (int i = 0; i < 3; ++i) {
    const std::string base = (data / stem(i)).string();
    cv::imwrite(base + ".color.jpg", colour);
    cv::imwrite(base + ".depth.png", depthImage(2000));
  }
  writeText(data / (stem(0) + ".pose.txt"), matrixText(sevenScenesPose(4).matrix()));
  writeText(data / (stem(1) + ".pose.txt"),
            "-inf -inf -inf -inf\n-inf -inf -inf -inf\n-inf -inf -inf -inf\n-inf -inf -inf -inf\n");
  writeText(data / (stem(2) + ".pose.txt"), "nan nan nan nan\nINF 0 0 0\n0 0 1 0\n0 0 0 1\n");
}
}  // namespace

TEST(TwelveScenes, ResamplesColourAndReadsDepthIntrinsics) {
  TempDir dir;
  writeTwelveScenes(dir.path());
  auto dataset = openOrFail(dir.str());
  ASSERT_TRUE(dataset);
  EXPECT_EQ(dataset->format(), DatasetFormat::TwelveScenes);
  ASSERT_EQ(dataset->size(), 3u);
  EXPECT_EQ(dataset->camera().fx, 30);
  EXPECT_EQ(dataset->camera().fy, 31);
  EXPECT_EQ(dataset->camera().cx, 16);
  EXPECT_EQ(dataset->camera().cy, 12);
  EXPECT_EQ(dataset->camera().width, 32);
  EXPECT_EQ(dataset->camera().height, 24);
  EXPECT_TRUE(mentions(dataset->summary(), "colour resampled from 64x48"));

  auto frame = dataset->load(0);
  ASSERT_TRUE(frame.ok()) << errorOf(frame);
  EXPECT_EQ(frameValidationError(*frame), "");
  EXPECT_EQ(frame->colour.size(), cv::Size(32, 24));
  const cv::Vec3b left = frame->colour.at<cv::Vec3b>(12, 4);
  const cv::Vec3b right = frame->colour.at<cv::Vec3b>(12, 28);
  EXPECT_GT(left[0], 240);
  EXPECT_LT(left[2], 15);
  EXPECT_LT(right[0], 15);
  EXPECT_GT(right[2], 240);
  EXPECT_TRUE(std::isnan(frame->depth.at<float>(0, 0)));
  EXPECT_FLOAT_EQ(frame->depth.at<float>(10, 10), 2.0f);
  ASSERT_TRUE(frame->ground_truth.has_value());
  expectPoseNear(*frame->ground_truth, sevenScenesPose(4));
}

TEST(TwelveScenes, InfinitePosesMeanNoGroundTruth) {
  TempDir dir;
  writeTwelveScenes(dir.path());
  auto dataset = openOrFail(dir.str());
  ASSERT_TRUE(dataset);
  EXPECT_TRUE(dataset->groundTruth(0).has_value());
  EXPECT_FALSE(dataset->groundTruth(1).has_value());
  EXPECT_FALSE(dataset->groundTruth(2).has_value());
  auto frame = dataset->load(1);
  ASSERT_TRUE(frame.ok()) << errorOf(frame);
  EXPECT_FALSE(frame->ground_truth.has_value());
  EXPECT_TRUE(mentions(dataset->summary(), "ground truth: 1 of 3"));
}

TEST(TwelveScenes, InfoFileProblemsNameFileAndKey) {
  TempDir dir;
  writeTwelveScenes(dir.path());
  writeText(dir.path() / "info.txt", "m_depthWidth = 32\nm_depthHeight = 24\n");
  DatasetOptions options;
  options.format = DatasetFormat::TwelveScenes;
  auto missing_key = openDataset(dir.str(), options);
  ASSERT_FALSE(missing_key.ok());
  EXPECT_TRUE(mentions(missing_key.error(), "info.txt"));
  EXPECT_TRUE(mentions(missing_key.error(), "m_calibrationDepthIntrinsic"));

  writeText(dir.path() / "info.txt",
            "m_depthWidth = 32\nm_depthHeight = 24\nm_calibrationDepthIntrinsic = 30 0 16 0\n");
  auto short_k = openDataset(dir.str(), options);
  ASSERT_FALSE(short_k.ok());
  EXPECT_TRUE(mentions(short_k.error(), "info.txt: line 3"));
  EXPECT_TRUE(mentions(short_k.error(), "expected 16 numbers, got 4"));

  fs::remove(dir.path() / "info.txt");
  auto missing_file = openDataset(dir.str(), options);
  ASSERT_FALSE(missing_file.ok());
  EXPECT_TRUE(mentions(missing_file.error(), "info.txt: missing"));
}

// ---- TUM RGB-D ------------------------------------------------------------------

namespace {
std::string stampName(double stamp) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6f.png", stamp);
  return buffer;
}

// Colour at 1.00 1.10 1.20 1.30; depth at 1.005, 1.13 (0.03 from 1.10: not
// associated), 1.21, 1.29. Ground truth: 0.96 and 1.04 bracket 1.00 (halfway,
// interpolated); 1.19 and 1.40 are too far apart, so 1.20 takes the nearest
// sample (1.19) and 1.30 (0.10 / 0.11 away) gets none.
void writeTum(const fs::path& root) {
  std::string rgb = "# colour images\n# file: 'rgbd_dataset'\n# timestamp filename\n";
  std::string depth = "# depth maps\n";
  for (double stamp : {1.00, 1.10, 1.20, 1.30}) {
    cv::Mat colour(kHeight, kWidth, CV_8UC3, cv::Scalar(0, 50, 100 + 100 * (stamp - 1.0)));
    fs::create_directories(root / "rgb");
    cv::imwrite((root / "rgb" / stampName(stamp)).string(), colour);
    rgb += stampName(stamp).substr(0, 8) + " rgb/" + stampName(stamp) + "\n";
  }
  for (double stamp : {1.005, 1.13, 1.21, 1.29}) {
    fs::create_directories(root / "depth");
    cv::imwrite((root / "depth" / stampName(stamp)).string(), depthImage(5000));
    depth += stampName(stamp).substr(0, 8) + " depth/" + stampName(stamp) + "\n";
  }
  writeText(root / "rgb.txt", rgb);
  writeText(root / "depth.txt", depth);
  writeText(root / "groundtruth.txt",
            "# ground truth trajectory\n"
            "# timestamp tx ty tz qx qy qz qw\n"
            "0.96 0 0 0 0 0 0 1\n"
            "1.04 1 0 0 0 0 0.70710678118654752 0.70710678118654752\n"
            "1.19 2 3 4 0 0 0 1\n"
            "1.40 5 5 5 0 0 0 1\n");
}
}  // namespace

TEST(Tum, AssociatesByNearestStampWithinTwentyMilliseconds) {
  TempDir parent;
  const fs::path root = parent.path() / "rgbd_dataset_freiburg2_desk";
  writeTum(root);
  auto dataset = openOrFail(root.string());
  ASSERT_TRUE(dataset);
  EXPECT_EQ(dataset->format(), DatasetFormat::Tum);
  ASSERT_EQ(dataset->size(), 3u);  // 1.10 has no depth within 0.02 s
  EXPECT_EQ(idsOf(*dataset), (std::vector<int>{0, 1, 2}));
  EXPECT_DOUBLE_EQ(dataset->stamp(0), 1.00);
  EXPECT_DOUBLE_EQ(dataset->stamp(1), 1.20);
  EXPECT_DOUBLE_EQ(dataset->stamp(2), 1.30);

  auto frame = dataset->load(1);
  ASSERT_TRUE(frame.ok()) << errorOf(frame);
  EXPECT_TRUE(mentions(frame->source, "rgb/1.200000.png"));
  EXPECT_FLOAT_EQ(frame->depth.at<float>(3, 3), 1.0f);  // 5000 units per metre
  EXPECT_TRUE(std::isnan(frame->depth.at<float>(0, 0)));
  EXPECT_DOUBLE_EQ(frame->stamp, 1.20);
  EXPECT_EQ(frame->id, 1);
}

TEST(Tum, GreedyAssociationTakesTheSmallestGapFirst) {
  TempDir dir;
  fs::create_directories(dir.path() / "rgb");
  fs::create_directories(dir.path() / "depth");
  for (const char* name : {"rgb/a.png", "rgb/b.png"})
    cv::imwrite((dir.path() / name).string(),
                cv::Mat(kHeight, kWidth, CV_8UC3, cv::Scalar(1, 2, 3)));
  cv::imwrite((dir.path() / "depth/c.png").string(), depthImage(5000));
  // 1.008 is 0.008 from a and 0.004 from b: b gets it, a stays unpaired.
  writeText(dir.path() / "rgb.txt", "1.000 rgb/a.png\n1.012 rgb/b.png\n");
  writeText(dir.path() / "depth.txt", "1.008 depth/c.png\n");
  auto dataset = openOrFail(dir.str());
  ASSERT_TRUE(dataset);
  ASSERT_EQ(dataset->size(), 1u);
  EXPECT_DOUBLE_EQ(dataset->stamp(0), 1.012);
  EXPECT_FALSE(dataset->groundTruth(0).has_value());  // no groundtruth.txt
}

TEST(Tum, GroundTruthIsInterpolatedOrNearestOrAbsent) {
  TempDir parent;
  const fs::path root = parent.path() / "rgbd_dataset_freiburg2_desk";
  writeTum(root);
  auto dataset = openOrFail(root.string());
  ASSERT_TRUE(dataset);
  // 1.00 is halfway between 0.96 (identity at the origin) and 1.04 (90 degrees
  // about z at x = 1): x = 0.5 and 45 degrees about z.
  ASSERT_TRUE(dataset->groundTruth(0).has_value());
  expectPoseNear(*dataset->groundTruth(0), makePose(45, {0, 0, 1}, {0.5, 0, 0}));
  ASSERT_TRUE(dataset->groundTruth(1).has_value());
  expectPoseNear(*dataset->groundTruth(1), makePose(0, {0, 0, 1}, {2, 3, 4}));
  EXPECT_FALSE(dataset->groundTruth(2).has_value());
}

TEST(Tum, IntrinsicsFollowTheFolderNameUnlessOverridden) {
  struct Case {
    std::string folder;
    double fx, fy, cx, cy;
  };
  const std::vector<Case> cases = {
      {"rgbd_dataset_freiburg1_xyz", 517.3, 516.5, 318.6, 255.3},
      {"rgbd_dataset_freiburg2_desk", 520.9, 521.0, 325.1, 249.7},
      {"fr3_office", 535.4, 539.2, 320.1, 247.6},
      {"my_recording", 525.0, 525.0, 319.5, 239.5},
  };
  TempDir parent;
  for (const auto& c : cases) {
    writeTum(parent.path() / c.folder);
    // A trailing separator must not hide the folder name.
    auto dataset = openOrFail((parent.path() / c.folder).string() + "/");
    ASSERT_TRUE(dataset) << c.folder;
    EXPECT_EQ(dataset->camera().fx, c.fx) << c.folder;
    EXPECT_EQ(dataset->camera().fy, c.fy) << c.folder;
    EXPECT_EQ(dataset->camera().cx, c.cx) << c.folder;
    EXPECT_EQ(dataset->camera().cy, c.cy) << c.folder;
    EXPECT_EQ(dataset->camera().width, kWidth);
  }
  DatasetOptions options;
  options.intrinsics = CameraIntrinsics{400, 410, 15.5, 11.5, 640, 480};
  auto overridden = openOrFail((parent.path() / cases[0].folder).string(), options);
  ASSERT_TRUE(overridden);
  EXPECT_EQ(overridden->camera().fx, 400);
  EXPECT_EQ(overridden->camera().fy, 410);
  EXPECT_EQ(overridden->camera().cx, 15.5);
  EXPECT_EQ(overridden->camera().width, kWidth);  // size comes from the images
  auto frame = overridden->load(0);
  ASSERT_TRUE(frame.ok()) << errorOf(frame);
  EXPECT_EQ(frame->camera.fx, 400);
  EXPECT_EQ(frameValidationError(*frame), "");
}

TEST(Tum, ListAndGroundTruthProblemsNameFileAndLine) {
  TempDir dir;
  writeTum(dir.path());
  writeText(dir.path() / "groundtruth.txt", "# header\n0.95 0 0 0 0 0 0 1\n1.05 1 0 0 0 0 1\n");
  auto short_line = openDataset(dir.str());
  ASSERT_FALSE(short_line.ok());
  EXPECT_TRUE(mentions(short_line.error(), "groundtruth.txt: line 3: expected 8 numbers"));
  EXPECT_TRUE(mentions(short_line.error(), "got 7"));

  writeTum(dir.path());
  writeText(dir.path() / "rgb.txt", "1.000000 rgb/1.000000.png\nnonsense\n");
  auto bad_list = openDataset(dir.str());
  ASSERT_FALSE(bad_list.ok());
  EXPECT_TRUE(mentions(bad_list.error(), "rgb.txt: line 2: expected 'timestamp filename'"));

  writeTum(dir.path());
  fs::remove(dir.path() / "depth" / stampName(1.21));
  auto missing_image = openDataset(dir.str());
  ASSERT_FALSE(missing_image.ok());
  EXPECT_TRUE(mentions(missing_image.error(), "1.210000.png: missing"));
  EXPECT_TRUE(mentions(missing_image.error(), "depth.txt line 4"));
}

// ---- auto-detection -------------------------------------------------------------

TEST(AutoDetection, RecognisesEachLayoutAndListsWhatItLookedFor) {
  TempDir folder, scene, twelve, tum, other;
  writeSevenScenesFolder(folder.path(), 2);
  writeSevenScenesScene(scene.path());
  writeTwelveScenes(twelve.path());
  writeTum(tum.path());
  writeText(other.path() / "readme.txt", "not a dataset\n");
  const std::vector<std::pair<const TempDir*, DatasetFormat>> cases = {
      {&folder, DatasetFormat::SevenScenesFolder},
      {&scene, DatasetFormat::SevenScenesScene},
      {&twelve, DatasetFormat::TwelveScenes},
      {&tum, DatasetFormat::Tum},
  };
  for (const auto& [dir, format] : cases) {
    auto dataset = openOrFail(dir->str());
    ASSERT_TRUE(dataset);
    EXPECT_EQ(dataset->format(), format) << dir->str();
  }
  auto unknown = openDataset(other.str());
  ASSERT_FALSE(unknown.ok());
  for (const char* looked_for : {"rgb.txt", "depth.txt", "info.txt", "seq-XX", "frame-XXXXXX"})
    EXPECT_TRUE(mentions(unknown.error(), looked_for));
  EXPECT_TRUE(mentions(unknown.error(), other.str()));
}

// ---- errors ---------------------------------------------------------------------

TEST(DatasetErrors, PoseFileWithTooFewNumbers) {
  TempDir dir;
  writeSevenScenesFolder(dir.path(), 3);
  writeText(dir.path() / "frame-000001.pose.txt", "1 0 0 0\n0 1 0 0\n0 0 1\n0 0 0 1\n");
  auto dataset = openDataset(dir.str());
  ASSERT_FALSE(dataset.ok());
  EXPECT_TRUE(mentions(dataset.error(), (dir.path() / "frame-000001.pose.txt").string() +
                                            ": line 3: expected 4 numbers, got 3"));
}

TEST(DatasetErrors, PoseFileWithNaNOrTextOrBadRotation) {
  TempDir dir;
  writeSevenScenesFolder(dir.path(), 3);
  const fs::path pose = dir.path() / "frame-000002.pose.txt";
  writeText(pose, "1 0 0 nan\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  auto nan = openDataset(dir.str());
  ASSERT_FALSE(nan.ok());
  EXPECT_TRUE(mentions(nan.error(), pose.string() + ": pose contains NaN"));

  writeText(pose, "1 0 0 0\n0 1 0 0\n0 0 1 zero\n0 0 0 1\n");
  auto text = openDataset(dir.str());
  ASSERT_FALSE(text.ok());
  EXPECT_TRUE(mentions(text.error(), pose.string() + ": line 3: 'zero' is not a number"));

  writeText(pose, "2 0 0 0\n0 2 0 0\n0 0 2 0\n0 0 0 1\n");
  auto scaled = openDataset(dir.str());
  ASSERT_FALSE(scaled.ok());
  EXPECT_TRUE(mentions(scaled.error(), pose.string()));
  EXPECT_TRUE(mentions(scaled.error(), "not a rotation"));

  writeText(pose, "1 0 0 0\n0 1 0 0\n");
  auto rows = openDataset(dir.str());
  ASSERT_FALSE(rows.ok());
  EXPECT_TRUE(mentions(rows.error(), pose.string() + ": expected a 4x4 matrix"));
}

TEST(DatasetErrors, UnreadableDepthIsReportedByLoad) {
  TempDir dir;
  writeSevenScenesFolder(dir.path(), 3);
  writeText(dir.path() / "frame-000001.depth.png", "this is not a PNG file");
  auto dataset = openOrFail(dir.str());
  ASSERT_TRUE(dataset);
  auto frame = dataset->load(1);
  ASSERT_FALSE(frame.ok());
  EXPECT_EQ(frame.error(),
            (dir.path() / "frame-000001.depth.png").string() + ": cannot be read as an image");
  EXPECT_TRUE(dataset->load(2).ok());
}

TEST(DatasetErrors, DepthOfTheWrongType) {
  TempDir dir;
  writeSevenScenesFolder(dir.path(), 3);
  cv::imwrite((dir.path() / "frame-000002.depth.png").string(),
              cv::Mat(kHeight, kWidth, CV_8UC3, cv::Scalar(1, 2, 3)));
  auto dataset = openOrFail(dir.str());
  ASSERT_TRUE(dataset);
  auto frame = dataset->load(2);
  ASSERT_FALSE(frame.ok());
  EXPECT_EQ(frame.error(), (dir.path() / "frame-000002.depth.png").string() +
                               ": expected 16-bit single-channel depth, got 8-bit 3-channel");
}

TEST(DatasetErrors, ColourAndDepthOfDifferentSizesNameBothFiles) {
  TempDir dir;
  writeSevenScenesFolder(dir.path(), 2);
  writeSevenScenesFrame(dir.path(), 1, sevenScenesPose(1), ".png", {40, 30});
  auto dataset = openOrFail(dir.str());
  ASSERT_TRUE(dataset);
  auto frame = dataset->load(1);
  ASSERT_FALSE(frame.ok());
  EXPECT_TRUE(
      mentions(frame.error(), (dir.path() / "frame-000001.color.png").string() + " (40x30)"));
  EXPECT_TRUE(
      mentions(frame.error(), (dir.path() / "frame-000001.depth.png").string() + " (32x24)"));
}

TEST(DatasetErrors, FrameOfADifferentSizeThanTheFirst) {
  TempDir dir;
  writeSevenScenesFolder(dir.path(), 2);
  cv::imwrite((dir.path() / "frame-000001.color.png").string(), cv::Mat::zeros(30, 40, CV_8UC3));
  cv::imwrite((dir.path() / "frame-000001.depth.png").string(), depthImage(1000, {40, 30}));
  auto dataset = openOrFail(dir.str());
  ASSERT_TRUE(dataset);
  auto frame = dataset->load(1);
  ASSERT_FALSE(frame.ok());
  EXPECT_TRUE(mentions(frame.error(), "frame-000001.depth.png: expected 32x24"));
}

TEST(DatasetErrors, EmptyFolderAndMissingFiles) {
  TempDir dir;
  DatasetOptions options;
  options.format = DatasetFormat::SevenScenesFolder;
  auto empty = openDataset(dir.str(), options);
  ASSERT_FALSE(empty.ok());
  EXPECT_EQ(empty.error(), "no frames found in " + dir.str() +
                               ": expected frame-XXXXXX.color.png|jpg / .depth.png / .pose.txt");

  writeSevenScenesFolder(dir.path(), 3);
  fs::remove(dir.path() / "frame-000001.depth.png");
  auto no_depth = openDataset(dir.str());
  ASSERT_FALSE(no_depth.ok());
  EXPECT_TRUE(mentions(no_depth.error(), "frame-000001.depth.png: missing"));

  writeSevenScenesFolder(dir.path(), 3);
  fs::remove(dir.path() / "frame-000002.pose.txt");
  auto no_pose = openDataset(dir.str());
  ASSERT_FALSE(no_pose.ok());
  EXPECT_TRUE(mentions(no_pose.error(), "frame-000002.pose.txt: missing"));

  // Frames outside the selection are not checked.
  options.frames = "0-1";
  EXPECT_TRUE(openDataset(dir.str(), options).ok());

  writeSevenScenesFolder(dir.path(), 3);
  fs::remove(dir.path() / "camera-intrinsics.txt");
  writeText(dir.path() / "camera-intrinsics.txt", "585 0 320\n0 585\n0 0 1\n");
  auto bad_k = openDataset(dir.str());
  ASSERT_FALSE(bad_k.ok());
  EXPECT_TRUE(mentions(bad_k.error(), "camera-intrinsics.txt: line 2"));
}

TEST(DatasetErrors, BadPathsAndIndices) {
  TempDir dir;
  auto missing = openDataset((dir.path() / "nowhere").string());
  ASSERT_FALSE(missing.ok());
  EXPECT_TRUE(mentions(missing.error(), "nowhere: no such folder"));

  writeText(dir.path() / "file.txt", "x");
  auto file = openDataset((dir.path() / "file.txt").string());
  ASSERT_FALSE(file.ok());
  EXPECT_TRUE(mentions(file.error(), "file.txt: not a folder"));

  EXPECT_FALSE(openDataset("").ok());

  writeSevenScenesFolder(dir.path() / "frames", 2);
  DatasetOptions options;
  options.frames = "0-";
  auto bad_selection = openDataset((dir.path() / "frames").string(), options);
  ASSERT_FALSE(bad_selection.ok());
  EXPECT_TRUE(mentions(bad_selection.error(), "bad frame range expression '0-'"));

  auto dataset = openOrFail((dir.path() / "frames").string());
  ASSERT_TRUE(dataset);
  auto out_of_range = dataset->load(2);
  ASSERT_FALSE(out_of_range.ok());
  EXPECT_TRUE(mentions(out_of_range.error(), "out of range"));
}

TEST(DatasetErrors, GarbageFilesDoNotCrash) {
  TempDir dir;
  writeSevenScenesFolder(dir.path(), 2);
  std::string garbage;
  for (int i = 0; i < 4096; ++i) garbage += static_cast<char>((i * 7919 + 13) % 256);
  writeText(dir.path() / "frame-000001.pose.txt", garbage);
  auto bad_pose = openDataset(dir.str());
  ASSERT_FALSE(bad_pose.ok());
  EXPECT_TRUE(mentions(bad_pose.error(), "frame-000001.pose.txt"));

  TempDir tum;
  writeTum(tum.path());
  writeText(tum.path() / "rgb.txt", garbage);
  writeText(tum.path() / "groundtruth.txt", garbage);
  EXPECT_FALSE(openDataset(tum.str()).ok());

  TempDir twelve;
  writeTwelveScenes(twelve.path());
  writeText(twelve.path() / "info.txt", garbage);
  EXPECT_FALSE(openDataset(twelve.str()).ok());
}

// ---- real data ------------------------------------------------------------------

TEST(RealData, RedkitchenTrainingFrames) {
  RELOCALIZER_REQUIRE_REDKITCHEN(dir);
  DatasetOptions options;
  options.frames = "0-99,200-299,400-499";
  auto dataset = openOrFail(dir, options);
  ASSERT_TRUE(dataset);
  EXPECT_EQ(dataset->format(), DatasetFormat::SevenScenesFolder);
  ASSERT_EQ(dataset->size(), 300u);
  EXPECT_EQ(dataset->id(100), 200);

  auto frame = dataset->load(150);
  ASSERT_TRUE(frame.ok()) << errorOf(frame);
  EXPECT_EQ(frameValidationError(*frame), "");
  EXPECT_EQ(frame->colour.cols, 640);
  EXPECT_EQ(frame->colour.rows, 480);
  EXPECT_EQ(frame->depth.cols, 640);
  EXPECT_EQ(frame->depth.rows, 480);
  EXPECT_EQ(frame->camera.fx, 585);
  EXPECT_GT(countValidDepth(frame->depth), 640 * 480 / 2);

  std::vector<float> valid;
  valid.reserve(frame->depth.total());
  for (int v = 0; v < frame->depth.rows; ++v)
    for (int u = 0; u < frame->depth.cols; ++u)
      if (std::isfinite(frame->depth.at<float>(v, u)))
        valid.push_back(frame->depth.at<float>(v, u));
  ASSERT_FALSE(valid.empty());
  std::nth_element(valid.begin(), valid.begin() + valid.size() / 2, valid.end());
  const float median = valid[valid.size() / 2];
  EXPECT_GT(median, 0.5f);
  EXPECT_LT(median, 4.0f);

  ASSERT_TRUE(frame->ground_truth.has_value());
  const Eigen::Matrix3d r = frame->ground_truth->linear();
  EXPECT_TRUE((r.transpose() * r).isIdentity(1e-9));
  EXPECT_NEAR(r.determinant(), 1.0, 1e-9);
}

TEST(RealData, RedkitchenSummaryPathLength) {
  RELOCALIZER_REQUIRE_REDKITCHEN(dir);
  auto dataset = openOrFail(dir);
  ASSERT_TRUE(dataset);
  ASSERT_EQ(dataset->size(), 500u);
  double length = 0.0;
  for (size_t i = 1; i < dataset->size(); ++i)
    length += (dataset->groundTruth(i)->translation() - dataset->groundTruth(i - 1)->translation())
                  .norm();
  // The data README says about 4.0 m.
  EXPECT_GT(length, 3.0);
  EXPECT_LT(length, 5.0);
  char expected[32];
  std::snprintf(expected, sizeof expected, "%.2f m", length);
  EXPECT_TRUE(mentions(dataset->summary(), expected));
  EXPECT_TRUE(mentions(dataset->summary(), "500 of 500"));
}
