// ROS <-> core conversions: exact round trips and bad messages named by camera and field.
#include <gtest/gtest.h>

#include <boost/make_shared.hpp>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/ros/conversions.hpp"
#include "sample_messages.hpp"

using namespace drill_pipe_pose;
using drill_pipe_pose_test::sampleSensorFrame;
using drill_pipe_pose_test::serialize;

namespace {

SensorFrameConstPtr share(const SensorFrame& f) {
  return boost::make_shared<SensorFrame>(f);
}

void expectRejected(const SensorFrame& f, std::initializer_list<const char*> needles) {
  try {
    fromMsg(share(f));
    FAIL() << "accepted a bad SensorFrame";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    for (const char* n : needles) EXPECT_NE(msg.find(n), std::string::npos) << msg;
  }
}

}  // namespace

TEST(Conversions, SensorFrameRoundTripIsExact) {
  for (const char* enc : {"16UC1", "32FC1"}) {
    const SensorFrame msg = sampleSensorFrame("cam4", 11, enc);
    const SensorFrameData data = fromMsg(share(msg));
    EXPECT_EQ(data.camera, "cam4");
    EXPECT_EQ(data.boxes.size(), 2u);
    EXPECT_EQ(data.boxes[1].label, EndLabel::kPinEnd);
    EXPECT_EQ(data.depth_info.roi.width, 37u);
    EXPECT_EQ(serialize(toMsg(data)), serialize(msg)) << "encoding " << enc;
  }
}

TEST(Conversions, DepthIsSharedNotCopied) {
  const auto msg = share(sampleSensorFrame("cam1", 3));
  const SensorFrameData data = fromMsg(msg);
  EXPECT_EQ(data.depth.data.get(), msg->depth.data.data());
}

TEST(Conversions, CameraInfoRoundTripAndModel) {
  const SensorFrame msg = sampleSensorFrame("cam1", 1);
  const CameraInfoData c = fromMsg(msg.depth_info);
  const sensor_msgs::CameraInfo back = toMsg(c, toNs(msg.depth_info.header.stamp));
  EXPECT_EQ(back, msg.depth_info);
  const auto cam = PinholeCamera::fromCameraInfo(c, "cam1 depth_info");
  EXPECT_EQ(cam.offsetX(), 200u);
  EXPECT_EQ(cam.imageHeight(), 61u);
}

TEST(Conversions, StampKeepsNanoseconds) {
  ros::Time t;
  t.fromNSec(1700000000123456789ull);
  EXPECT_EQ(fromNs(toNs(t)), t);
}

TEST(ConversionsBadInput, EmptyCameraName) {
  SensorFrame f = sampleSensorFrame("cam1", 1);
  f.camera = "";
  expectRejected(f, {"camera is empty"});
}

TEST(ConversionsBadInput, UnsupportedEncoding) {
  SensorFrame f = sampleSensorFrame("cam5", 1);
  f.depth.encoding = "mono8";
  expectRejected(f, {"cam5 depth", "encoding = \"mono8\""});
}

TEST(ConversionsBadInput, WrongStep) {
  SensorFrame f = sampleSensorFrame("cam5", 1);
  f.depth.step = 37;
  expectRejected(f, {"cam5 depth", "step = 37"});
}

TEST(ConversionsBadInput, SizeDoesNotMatchRoi) {
  SensorFrame f = sampleSensorFrame("cam5", 1);
  f.depth_info.roi.width = 40;
  expectRejected(f, {"cam5 depth", "37x61", "40x61"});
}

TEST(ConversionsBadInput, ZeroFocalLengthInColourInfo) {
  SensorFrame f = sampleSensorFrame("cam6", 1);
  f.color_info.P[0] = 0.0;
  f.color_info.P[5] = 0.0;
  f.color_info.K[0] = 0.0;
  expectRejected(f, {"cam6 color_info", "K[0] (fx) = 0"});
}

TEST(ConversionsBadInput, BigEndianAndUnknownLabelAndBadBox) {
  SensorFrame f = sampleSensorFrame("cam2", 1);
  f.depth.is_bigendian = 1;
  expectRejected(f, {"cam2 depth", "is_bigendian"});
  f = sampleSensorFrame("cam2", 1);
  f.boxes[1].label = "pipe";
  expectRejected(f, {"cam2 boxes[1]", "label = \"pipe\""});
  f = sampleSensorFrame("cam2", 1);
  f.boxes[0].x_max = f.boxes[0].x_min - 1.0f;
  expectRejected(f, {"cam2 boxes[0]", "min <= max"});
}

TEST(ConversionsBadInput, SizesBeyondTheLimitsAreRejectedFirst) {
  // A depth image declared 20000 x 20000 with no data, a colour CameraInfo of 10^9 pixels and
  // 1000 boxes: each names the camera, the field and the limit, before any other check.
  SensorFrame f = sampleSensorFrame("cam3", 1);
  f.depth.width = 20000;
  f.depth.height = 20000;
  f.depth.data.clear();
  expectRejected(f, {"cam3 depth", "20000 x 20000", "limits/max_image_pixels = 16777216"});
  f = sampleSensorFrame("cam3", 1);
  f.color_info.width = 100000;
  f.color_info.height = 10000;
  expectRejected(f, {"cam3 color_info", "limits/max_image_pixels"});
  f = sampleSensorFrame("cam3", 1);
  f.boxes.resize(1000, f.boxes[0]);
  expectRejected(f, {"cam3 boxes", "1000 boxes", "limits/max_boxes = 64"});
  // Within a limit set by the node, the same frame passes; beyond a tighter one it does not.
  InputLimits tight;
  tight.max_boxes = 1;
  f = sampleSensorFrame("cam3", 1);
  ASSERT_GE(f.boxes.size(), 2u);
  EXPECT_NO_THROW(fromMsg(share(f)));
  EXPECT_THROW(fromMsg(share(f), tight), InputError);
  tight = InputLimits();
  tight.max_image_pixels = static_cast<uint64_t>(f.depth.width) * f.depth.height - 1;
  EXPECT_THROW(fromMsg(share(f), tight), InputError);
}
