#include "relocalizer/forest/features.h"

namespace relocalizer {

FeatureImage FeatureImage::of(const cv::Mat& colour, const cv::Mat& depth) {
  CV_Assert(colour.type() == CV_8UC3 &&
            (depth.empty() || (depth.type() == CV_32FC1 && colour.size() == depth.size())));
  FeatureImage image;
  image.colour = colour.ptr<uint8_t>();
  image.width = colour.cols;
  image.height = colour.rows;
  image.colour_stride = colour.step[0];
  if (!depth.empty()) {
    image.depth = depth.ptr<float>();
    image.depth_stride = depth.step[0] / sizeof(float);
  }
  return image;
}

}  // namespace relocalizer
