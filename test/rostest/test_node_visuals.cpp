// What RViz is fed (node_visuals.h): the latched ~surface holds the surfaces of
// the places in the map frame, point for point, and follows ~load_place and
// ~unload_place; ~inliers holds each answer's inliers, as many of each kind as
// its ~result counts.

#include <relocalizer/LoadPlace.h>
#include <relocalizer/UnloadPlace.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include "../../src/ros/node/node_visuals.h"
#include "node_test_support.h"
#include "relocalizer/forest/model_io.h"

using namespace relocalizer_test;
using Cloud = sensor_msgs::PointCloud2;

namespace {

std::string fixturePath(const std::string& file) {
  std::string fixture;
  ros::NodeHandle("~").getParam("fixture", fixture);
  return fixture + "/" + file;
}

size_t surfaceSize(const std::string& model_file) {
  auto model = relocalizer::loadModel(fixturePath(model_file));
  if (!model) throw std::runtime_error(model.error());
  return model->surface.elements().size();
}

// The next ~surface cloud of `points` points, from a fresh subscription (latched).
std::optional<Cloud> surfaceOf(size_t points) {
  Listener<Cloud> surface("/relocalizer/surface");
  return surface.waitFor([&](const Cloud& c) { return c.width * c.height == points; }, 60.0);
}

}  // namespace

TEST(Visuals, SurfaceIsLatchedInTheMapFrameAndFollowsThePlaces) {
  const size_t room = surfaceSize("model.bin"), lab = surfaceSize("model2.bin");
  ASSERT_GT(room, 1000u);
  ASSERT_GT(lab, 1000u);
  std::optional<Cloud> cloud = surfaceOf(room);
  ASSERT_TRUE(cloud) << "no ~surface of the model's " << room << " surface voxels in 60 s";
  EXPECT_EQ(cloud->header.frame_id, "map");
  // The model's own first voxel, where the model has it.
  auto model = relocalizer::loadModel(fixturePath("model.bin"));
  ASSERT_TRUE(model.ok()) << model.error();
  sensor_msgs::PointCloud2ConstIterator<float> x(*cloud, "x"), z(*cloud, "z");
  EXPECT_FLOAT_EQ(*x, model->surface.elements().front().point.x());
  EXPECT_FLOAT_EQ(*z, model->surface.elements().front().point.z());

  relocalizer::LoadPlace load;
  load.request.name = "lab";
  load.request.model = fixturePath("model2.bin");
  ASSERT_TRUE(ros::service::waitForService("/relocalizer/load_place", ros::Duration(60.0)));
  ASSERT_TRUE(ros::service::call("/relocalizer/load_place", load));
  ASSERT_TRUE(load.response.success) << load.response.message;
  EXPECT_TRUE(surfaceOf(room + lab)) << "~surface did not grow by the loaded place's surface";

  relocalizer::UnloadPlace unload;
  unload.request.name = "lab";
  ASSERT_TRUE(ros::service::call("/relocalizer/unload_place", unload));
  ASSERT_TRUE(unload.response.success) << unload.response.message;
  EXPECT_TRUE(surfaceOf(room)) << "~surface still holds the unloaded place";
}

// Issue 38, R2: every load and unload sent every place's surface again (722
// MB in 30 s during a storm of loads). A change in another frame sends
// nothing; a storm in the map frame is a few clouds, the last one right.
TEST(Visuals, AStormOfLoadsSendsOnlyWhatChangedAtABoundedRate) {
  const size_t room = surfaceSize("model.bin"), lab = surfaceSize("model2.bin");
  ASSERT_TRUE(surfaceOf(room)) << "no ~surface of the model alone";
  Listener<Cloud> surface("/relocalizer/surface");
  ASSERT_TRUE(surface.waitFor([](const Cloud&) { return true; }, 30.0)) << "not latched";
  const auto change = [](const std::string& name, const std::string& model,
                         const std::string& frame) {
    if (model.empty()) {
      relocalizer::UnloadPlace unload;
      unload.request.name = name;
      ASSERT_TRUE(ros::service::call("/relocalizer/unload_place", unload));
      ASSERT_TRUE(unload.response.success) << unload.response.message;
      return;
    }
    relocalizer::LoadPlace load;
    load.request.name = name;
    load.request.model = fixturePath(model);
    load.request.map_frame = frame;
    ASSERT_TRUE(ros::service::call("/relocalizer/load_place", load));
    ASSERT_TRUE(load.response.success) << load.response.message;
  };
  constexpr int kChanges = 10;
  surface.clear();
  for (int i = 0; i < kChanges; ++i) {
    change("elsewhere", "model2.bin", "elsewhere_map");
    change("elsewhere", "", "");
  }
  ros::WallDuration(2 * relocalizer_ros::kSurfaceInterval + 0.5).sleep();
  EXPECT_EQ(surface.messages().size(), 0u) << "places in another frame changed ~surface";

  const ros::WallTime start = ros::WallTime::now();
  for (int i = 0; i < kChanges; ++i) {
    change("lab", "model2.bin", "");
    change("lab", "", "");
  }
  change("lab", "model2.bin", "");
  const double seconds = (ros::WallTime::now() - start).toSec();
  ASSERT_TRUE(surfaceOf(room + lab)) << "the last cloud does not hold the last places";
  ros::WallDuration(relocalizer_ros::kSurfaceInterval + 0.5).sleep();
  const size_t clouds = surface.messages().size();
  EXPECT_LE(clouds, static_cast<size_t>(seconds / relocalizer_ros::kSurfaceInterval) + 2)
      << 2 * kChanges + 1 << " changes in " << seconds << " s";
  EXPECT_LT(clouds, static_cast<size_t>(2 * kChanges + 1));
  change("lab", "", "");
  EXPECT_TRUE(surfaceOf(room));
}

TEST(Visuals, InliersOfEachAnswerAreItsCountedPointAndLineInliers) {
  Listener<ResultMsg> results("/relocalizer/result");
  Listener<Cloud> inliers("/relocalizer/inliers");
  // Answers with their clouds, matched by stamp.
  int matched = 0;
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(90.0);
  while (matched < 3 && ros::WallTime::now() < give_up) {
    matched = 0;
    for (const Cloud& cloud : inliers.messages()) {
      for (const ResultMsg& r : results.messages()) {
        if (!r.success || r.header.stamp != cloud.header.stamp) continue;
        ++matched;
        EXPECT_EQ(cloud.header.frame_id, r.header.frame_id);
        ASSERT_EQ(cloud.width * cloud.height, r.point_inliers + r.line_inliers);
        uint32_t points = 0, lines = 0;
        for (sensor_msgs::PointCloud2ConstIterator<uint8_t> kind(cloud, "kind"); kind != kind.end();
             ++kind)
          (*kind == 0 ? points : lines) += 1;
        EXPECT_EQ(points, r.point_inliers);
        EXPECT_EQ(lines, r.line_inliers);
        EXPECT_GT(lines, 0u) << "the fixture room's answers have line inliers";
      }
    }
    ros::WallDuration(0.2).sleep();
  }
  EXPECT_GE(matched, 3) << "fewer than 3 answers with their ~inliers in 90 s";
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_visuals");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int code = RUN_ALL_TESTS();
  spinner.stop();
  return code;
}
