#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>

#include <opencv2/imgproc.hpp>

#include "relocalizer/forest/line_detector_input.h"
#include "relocalizer/forest/line_segment_detector.h"
#include "relocalizer/forest/sampling.h"

using namespace relocalizer;

namespace {

constexpr double kPi = 3.14159265358979323846;

double segmentLength(const LineSegment& s) { return std::hypot(s.x2 - s.x1, s.y2 - s.y1); }

// Undirected angle between a segment and a direction, degrees in [0, 90].
double angleTo(const LineSegment& s, double degrees) {
  double diff = std::fmod(std::atan2(s.y2 - s.y1, s.x2 - s.x1) * 180.0 / kPi - degrees, 180.0);
  if (diff < 0) diff += 180.0;
  return std::min(diff, 180.0 - diff);
}

// Distance of a point from the infinite line through (px, py) at `degrees`.
double distanceToLine(double x, double y, double px, double py, double degrees) {
  const double a = degrees * kPi / 180.0;
  return std::abs(-(x - px) * std::sin(a) + (y - py) * std::cos(a));
}

cv::Mat flat(int cols, int rows, int level) {
  return cv::Mat(rows, cols, CV_8UC1, cv::Scalar(level));
}

// Two grey levels meeting along the line through the image centre at
// `degrees`, antialiased: each pixel takes the share of its area (sampled
// 8x8) on the bright side.
cv::Mat halfPlanes(int cols, int rows, double degrees) {
  cv::Mat image(rows, cols, CV_8UC1);
  const double a = degrees * kPi / 180.0, nx = -std::sin(a), ny = std::cos(a);
  const double cx = cols / 2.0, cy = rows / 2.0;
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols; ++x) {
      int bright = 0;
      for (int j = 0; j < 8; ++j)
        for (int i = 0; i < 8; ++i)
          bright += (x - 0.5 + (i + 0.5) / 8 - cx) * nx + (y - 0.5 + (j + 0.5) / 8 - cy) * ny > 0;
      image.at<unsigned char>(y, x) = static_cast<unsigned char>(60 + (120 * bright + 32) / 64);
    }
  return image;
}

const LineSegment* longest(const std::vector<LineSegment>& segments) {
  const LineSegment* best = nullptr;
  for (const LineSegment& s : segments)
    if (!best || segmentLength(s) > segmentLength(*best)) best = &s;
  return best;
}

}  // namespace

TEST(LineSegmentDetector, FindsTheFourSidesOfARectangle) {
  // Bright from column 30 to 119 and row 20 to 89: the edges lie between
  // pixel centres, at x = 29.5 and 119.5, y = 19.5 and 89.5.
  cv::Mat image = flat(160, 120, 40);
  image(cv::Rect(30, 20, 90, 70)).setTo(180);
  const std::vector<LineSegment> segments = detectLineSegments(image);
  ASSERT_EQ(segments.size(), 4u);
  struct Side {
    double degrees, x, y, length;
  };
  const Side sides[] = {
      {0, 74.5, 19.5, 90}, {0, 74.5, 89.5, 90}, {90, 29.5, 54.5, 70}, {90, 119.5, 54.5, 70}};
  for (const Side& side : sides) {
    const auto match = std::find_if(segments.begin(), segments.end(), [&](const LineSegment& s) {
      return angleTo(s, side.degrees) < 1.0 && distanceToLine((s.x1 + s.x2) / 2, (s.y1 + s.y2) / 2,
                                                              side.x, side.y, side.degrees) < 1.0;
    });
    ASSERT_NE(match, segments.end()) << "no segment along the side at " << side.x << ", " << side.y;
    // Within a pixel of the corners (a corner's 2x2 gradient is oblique).
    EXPECT_NEAR(segmentLength(*match), side.length, 2.0);
    EXPECT_NEAR((match->x1 + match->x2) / 2, side.x, 1.0);
    EXPECT_NEAR((match->y1 + match->y2) / 2, side.y, 1.0);
  }
}

TEST(LineSegmentDetector, FindsAnEdgeAtEveryAngleWithinAPixelAndADegree) {
  for (double degrees :
       {0.0, 7.0, 22.5, 30.0, 45.0, 60.0, 83.0, 90.0, 112.0, 135.0, 150.0, 171.0}) {
    SCOPED_TRACE(degrees);
    const std::vector<LineSegment> segments = detectLineSegments(halfPlanes(160, 120, degrees));
    const LineSegment* s = longest(segments);
    ASSERT_NE(s, nullptr);
    EXPECT_LT(angleTo(*s, degrees), 1.0);
    EXPECT_LT(distanceToLine(s->x1, s->y1, 80, 60, degrees), 1.0);
    EXPECT_LT(distanceToLine(s->x2, s->y2, 80, 60, degrees), 1.0);
    // The edge crosses the whole image: at least 100 px long whatever the angle.
    EXPECT_GT(segmentLength(*s), 100.0);
    // Nothing else in the image.
    for (const LineSegment& other : segments) EXPECT_LT(angleTo(other, degrees), 1.0);
  }
}

TEST(LineSegmentDetector, TheBrightSideIsOnTheLeft) {
  // Bright below a horizontal edge: looking along the segment (y down) the
  // bright side is on the left, so the segment runs right to left.
  cv::Mat image = flat(160, 120, 40);
  image(cv::Rect(0, 60, 160, 60)).setTo(200);
  const std::vector<LineSegment> segments = detectLineSegments(image);
  ASSERT_EQ(segments.size(), 1u);
  EXPECT_LT(segments[0].x2, segments[0].x1);
  cv::Mat inverted = 240 - image;
  const std::vector<LineSegment> flipped = detectLineSegments(inverted);
  ASSERT_EQ(flipped.size(), 1u);
  EXPECT_GT(flipped[0].x2, flipped[0].x1);
}

TEST(LineSegmentDetector, NothingOnFlatImagesOrNoise) {
  EXPECT_TRUE(detectLineSegments(flat(160, 120, 0)).empty());
  EXPECT_TRUE(detectLineSegments(flat(160, 120, 128)).empty());
  // A shallow ramp: one grey level every 4 pixels is quantisation, not an edge.
  cv::Mat ramp(120, 160, CV_8UC1);
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) ramp.at<unsigned char>(y, x) = static_cast<unsigned char>(x / 4);
  EXPECT_TRUE(detectLineSegments(ramp).empty());
  for (uint32_t seed : {1u, 2u, 3u}) {
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> grey(0, 255);
    cv::Mat noise(120, 160, CV_8UC1);
    for (int y = 0; y < noise.rows; ++y)
      for (int x = 0; x < noise.cols; ++x)
        noise.at<unsigned char>(y, x) = static_cast<unsigned char>(grey(rng));
    EXPECT_TRUE(detectLineSegments(noise).empty()) << "seed " << seed;
  }
}

TEST(LineSegmentDetector, RejectsOtherImageTypes) {
  EXPECT_THROW(detectLineSegments(cv::Mat(10, 10, CV_8UC3)), std::invalid_argument);
  EXPECT_THROW(lineDetectorInput(cv::Mat(10, 10, CV_8UC1), 0.5f), std::invalid_argument);
  EXPECT_TRUE(detectLineSegments(cv::Mat(1, 10, CV_8UC1, cv::Scalar(5))).empty());
}

TEST(LineSegmentDetector, InputIsLumaAveragedOverEachOutputPixelsArea) {
  cv::Mat bgr(8, 8, CV_8UC3, cv::Scalar(0, 0, 0));
  bgr(cv::Rect(0, 0, 4, 4)).setTo(cv::Scalar(255, 255, 255));
  bgr(cv::Rect(4, 0, 4, 4)).setTo(cv::Scalar(0, 0, 255));  // red: 0.299 * 255
  bgr.at<cv::Vec3b>(7, 7) = cv::Vec3b(0, 160, 0);          // green: 0.587 * 160 = 93.9
  const cv::Mat full = lineDetectorInput(bgr, 1.0f);
  EXPECT_EQ(full.at<unsigned char>(0, 0), 255);
  EXPECT_EQ(full.at<unsigned char>(0, 4), 76);
  EXPECT_EQ(full.at<unsigned char>(7, 7), 94);
  const cv::Mat quarter = lineDetectorInput(bgr, 0.25f);
  ASSERT_EQ(quarter.size(), cv::Size(2, 2));
  EXPECT_EQ(quarter.at<unsigned char>(0, 0), 255);
  EXPECT_EQ(quarter.at<unsigned char>(0, 1), 76);
  EXPECT_EQ(quarter.at<unsigned char>(1, 0), 0);
  EXPECT_EQ(quarter.at<unsigned char>(1, 1), 6);  // 94 / 16 = 5.9
  // 8 -> 3: each output pixel covers 8/3 source pixels, partly.
  const cv::Mat third = lineDetectorInput(bgr, 0.375f);
  ASSERT_EQ(third.size(), cv::Size(3, 3));
  EXPECT_EQ(third.at<unsigned char>(0, 0), 255);
  // Columns 2.67-5.33: a third of column 2 and all of 3 white, all of 4 and a
  // third of 5 red, (1.33 * 255 + 1.33 * 76) / 2.67 = 165.5.
  EXPECT_EQ(third.at<unsigned char>(0, 1), 166);
}

namespace {

// Test frames drawn with integers only (no renderer whose rounding could
// change between platforms): rectangles and triangles of fixed grey levels on
// a mt19937 texture, at constant depth 2 m, so every sample along a segment
// has depth and lies on the 3D line.
RgbdFrame digestFrame(uint32_t seed) {
  RgbdFrame frame;
  frame.camera = CameraIntrinsics::kinectDefault();
  frame.colour.create(480, 640, CV_8UC3);
  std::mt19937 rng(seed);
  for (int y = 0; y < 480; ++y)
    for (int x = 0; x < 640; ++x) {
      const unsigned v = rng();
      frame.colour.at<cv::Vec3b>(y, x) =
          cv::Vec3b(90 + (v & 15), 100 + ((v >> 4) & 15), 80 + ((v >> 8) & 15));
    }
  for (int shape = 0; shape < 12; ++shape) {
    const int x0 = static_cast<int>(rng() % 560), y0 = static_cast<int>(rng() % 400);
    const int w = 40 + static_cast<int>(rng() % 200), h = 40 + static_cast<int>(rng() % 160);
    const int slope = static_cast<int>(rng() % 7) - 3;  // sheared: edges at other angles
    // One draw per statement: the order of a call's arguments is the compiler's.
    const unsigned blue = rng() % 256, green = rng() % 256, red = rng() % 256;
    const cv::Vec3b colour(blue, green, red);
    for (int y = y0; y < std::min(480, y0 + h); ++y)
      for (int x = x0 + (slope * (y - y0)) / 4; x < std::min(640, x0 + w); ++x)
        if (x >= 0) frame.colour.at<cv::Vec3b>(y, x) = colour;
  }
  frame.depth = cv::Mat(480, 640, CV_32FC1, cv::Scalar(2.0f));
  return frame;
}

void mix(uint64_t& hash, int64_t value) {
  for (int byte = 0; byte < 8; ++byte) {
    hash ^= static_cast<uint64_t>(value >> (8 * byte)) & 0xff;
    hash *= 1099511628211ull;  // FNV-1a
  }
}

// The line samples of three fixed 640x480 frames (segments on the 160x120
// input, sampled every 5 px, 3D lines by RANSAC), and the segments themselves
// to 1/64 px, as one hash.
std::string lineSamplesDigest(const LineSamplingParams& params, int& segments, int& samples) {
  uint64_t hash = 14695981039346656037ull;
  segments = samples = 0;
  for (uint32_t seed : {11u, 12u, 13u}) {
    const RgbdFrame frame = digestFrame(seed);
    for (const LineSegment& s : detectLineSegments(
             lineDetectorInput(frame.colour, lsdScaleFor(params, 640)), params.lsd_validation)) {
      for (double c : {s.x1, s.y1, s.x2, s.y2}) mix(hash, std::llround(c * 64));
      ++segments;
    }
    std::mt19937 rng(seed);
    const LineSamples lines = sampleLines(frame, params, 0, rng);
    for (const Sample& sample : lines.samples) {
      mix(hash, sample.u);
      mix(hash, sample.v);
      mix(hash, sample.line);
    }
    samples += static_cast<int>(lines.samples.size());
  }
  char digest[20];
  std::snprintf(digest, sizeof digest, "%016llx", static_cast<unsigned long long>(hash));
  return digest;
}

}  // namespace

// Any platform, compiler or OpenCV version that detects or samples differently
// fails here: a model trained on one platform answers the same on another.
TEST(LineSegmentDetector, SamplesOfFixedFramesMatchTheirDigest) {
  const LineSamplingParams defaults;
  ASSERT_EQ(defaults.line_detector, LineDetector::kOwn);
  ASSERT_FALSE(defaults.lsd_validation);
  int segments = 0, samples = 0;
  EXPECT_EQ(lineSamplesDigest(defaults, segments, samples), "67ca0905787b99ca")
      << segments << " segments, " << samples << " samples";
  EXPECT_GT(segments, 60);
  EXPECT_GT(samples, 1000);
}

TEST(LineSegmentDetector, ValidatedSamplesOfFixedFramesMatchTheirDigest) {
  // Models trained before lsd_validation was false, and those that set it.
  LineSamplingParams validated;
  validated.lsd_validation = true;
  int segments = 0, samples = 0;
  EXPECT_EQ(lineSamplesDigest(validated, segments, samples), "a24951beee50406a")
      << segments << " segments, " << samples << " samples";
  EXPECT_GT(segments, 60);
}

namespace {

// Share of `segments` with a segment in `others` whose endpoints are both
// within `tolerance` px.
double shareFoundIn(const std::vector<cv::Vec4f>& segments, const std::vector<cv::Vec4f>& others,
                    double tolerance) {
  int found = 0;
  for (const cv::Vec4f& s : segments)
    for (const cv::Vec4f& o : others)
      if (std::hypot(s[0] - o[0], s[1] - o[1]) <= tolerance &&
          std::hypot(s[2] - o[2], s[3] - o[3]) <= tolerance) {
        ++found;
        break;
      }
  return segments.empty() ? 0.0 : static_cast<double>(found) / segments.size();
}

}  // namespace

TEST(LineSegmentDetector, UnvalidatedItFindsWhatOpenCvsLsdWithoutRefinementFinds) {
  // lsd_validation: false is meant to give the segments of OpenCV's
  // LSD_REFINE_NONE (the same 2x2 gradient, region growing and rectangle; no
  // density check, no NFA, the paper's minimum region). On smoothed noise
  // (short curved level lines, most of which the NFA rejects) whose 160x120
  // detector input is the same for both: grey, each pixel 4x4 in the frame.
  if (!lineDetectorMissing(LineDetector::kOpenCvLsd).empty())
    GTEST_SKIP() << lineDetectorMissing(LineDetector::kOpenCvLsd);
  for (uint32_t seed : {11u, 12u, 13u}) {
    std::mt19937 rng(seed);
    cv::Mat noise(120, 160, CV_8UC1), smooth, grey;
    for (int y = 0; y < noise.rows; ++y)
      for (int x = 0; x < noise.cols; ++x)
        noise.at<unsigned char>(y, x) = static_cast<unsigned char>(rng() % 256);
    cv::blur(noise, smooth, cv::Size(5, 5));
    cv::resize(smooth, grey, cv::Size(640, 480), 0, 0, cv::INTER_NEAREST);
    cv::Mat colour;
    cv::cvtColor(grey, colour, cv::COLOR_GRAY2BGR);
    const float scale = lsdScaleFor(LineSamplingParams{}, 640);
    const auto opencv = detectSegments(colour, LineDetector::kOpenCvLsd, scale, false);
    const auto ours = detectSegments(colour, LineDetector::kOwn, scale, false);
    const auto validated = detectSegments(colour, LineDetector::kOwn, scale, true);
    ASSERT_GT(opencv.size(), 20u);
    // Not all to the bit: OpenCV grows regions with a float atan2 and breaks
    // ties between equal gradients in its own order.
    EXPECT_GE(shareFoundIn(ours, opencv, 0.1), 0.8) << ours.size() << " of ours, seed " << seed;
    EXPECT_GE(shareFoundIn(opencv, ours, 0.1), 0.8)
        << opencv.size() << " of OpenCV's, seed " << seed;
    EXPECT_LT(shareFoundIn(opencv, validated, 0.1), 0.2) << "validated, seed " << seed;
  }
}
