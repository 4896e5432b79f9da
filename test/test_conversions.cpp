// ROS <-> core conversions: exact round trips and bad messages named by camera and field.
#include <gtest/gtest.h>
#include <topic_tools/shape_shifter.h>

#include <boost/make_shared.hpp>
#include <cstring>

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

namespace {

/// `f` with an amplitude image of its depth's size (16UC1, value 100 + u + v DN).
SensorFrame withAmplitude(SensorFrame f) {
  sensor_msgs::Image& a = f.amplitude;
  a.header = f.depth.header;
  a.width = f.depth.width;
  a.height = f.depth.height;
  a.encoding = "16UC1";
  a.step = a.width * 2;
  a.data.resize(static_cast<size_t>(a.step) * a.height);
  for (uint32_t v = 0; v < a.height; ++v)
    for (uint32_t u = 0; u < a.width; ++u) {
      const uint16_t dn = static_cast<uint16_t>(100 + u + v);
      std::memcpy(&a.data[v * a.step + 2 * u], &dn, 2);
    }
  return f;
}

}  // namespace

TEST(Conversions, AmplitudeRoundTripIsExactAndShared) {
  const SensorFrame msg = withAmplitude(sampleSensorFrame("cam4", 11));
  const auto shared = share(msg);
  const SensorFrameData data = fromMsg(shared);
  EXPECT_TRUE(data.amplitude_refused.empty()) << data.amplitude_refused;
  ASSERT_FALSE(data.amplitude.empty());
  EXPECT_EQ(data.amplitude.data.get(), shared->amplitude.data.data());
  EXPECT_FLOAT_EQ(data.amplitude.at(3, 2), 105.0f);
  EXPECT_EQ(serialize(toMsg(data)), serialize(msg));
}

TEST(Conversions, NoAmplitudeMeansNotAvailable) {
  const SensorFrameData data = fromMsg(share(sampleSensorFrame("cam1", 3)));
  EXPECT_TRUE(data.amplitude.empty());
  EXPECT_TRUE(data.amplitude_refused.empty());
}

TEST(ConversionsBadInput, AmplitudeOfAnotherSizeOrEncodingIsRefusedButTheDepthIsUsed) {
  SensorFrame other_crop = withAmplitude(sampleSensorFrame("cam2", 5));
  other_crop.amplitude.width -= 1;
  other_crop.amplitude.step -= 2;
  SensorFrame bad_encoding = withAmplitude(sampleSensorFrame("cam2", 5));
  bad_encoding.amplitude.encoding = "8UC1";
  SensorFrame short_data = withAmplitude(sampleSensorFrame("cam2", 5));
  short_data.amplitude.data.resize(10);
  for (const auto& [f, needle] : {std::pair{other_crop, "is 36x"}, {bad_encoding, "8UC1"},
                                  {short_data, "data has 10 bytes"}}) {
    const SensorFrameData data = fromMsg(share(f));  // no throw: the depth is still used
    EXPECT_TRUE(data.amplitude.empty());
    EXPECT_EQ(data.depth.width, f.depth.width);
    for (const char* n : {"cam2", "amplitude", needle})
      EXPECT_NE(data.amplitude_refused.find(n), std::string::npos) << data.amplitude_refused;
  }
}

TEST(Conversions, AFrameOfTheDefinitionBeforeAmplitudeReadsWithoutIt) {
  // A bag or a publisher of the older definition: the same fields but the amplitude.
  const SensorFrame now = sampleSensorFrame("cam3", 7);
  const LegacySensorFrame old = drill_pipe_pose_test::legacyOf(now);
  EXPECT_NE(std::string(ros::message_traits::md5sum<LegacySensorFrame>()),
            std::string(ros::message_traits::md5sum<SensorFrame>()));
  EXPECT_EQ(serialize(upgrade(old)), serialize(now));
}

TEST(Conversions, TheNodeTellsBothDefinitionsApartOnTheWire) {
  // What the estimator node's subscription gets: a ShapeShifter of whatever the publisher sent.
  const SensorFrame now = withAmplitude(sampleSensorFrame("cam5", 2));
  const LegacySensorFrame old = drill_pipe_pose_test::legacyOf(now);
  const auto shifted = [](const auto& m) {
    using M = std::decay_t<decltype(m)>;
    std::vector<uint8_t> b(ros::serialization::serializationLength(m));
    ros::serialization::OStream out(b.data(), static_cast<uint32_t>(b.size()));
    ros::serialization::serialize(out, m);
    topic_tools::ShapeShifter ss;
    // Both publish as drill_pipe_pose/SensorFrame; only the MD5 sums differ.
    ss.morph(ros::message_traits::md5sum<M>(), "drill_pipe_pose/SensorFrame",
             ros::message_traits::definition<M>(), "0");
    ros::serialization::IStream in(b.data(), static_cast<uint32_t>(b.size()));
    ss.read(in);
    return ss;
  };
  const SensorFrameConstPtr a = sensorFrameOf(shifted(now));
  ASSERT_TRUE(a);
  EXPECT_EQ(serialize(*a), serialize(now));
  const SensorFrameConstPtr b = sensorFrameOf(shifted(old));
  ASSERT_TRUE(b);
  EXPECT_TRUE(b->amplitude.data.empty());
  EXPECT_EQ(b->depth.data, now.depth.data);
  // Another type on the topic is not a SensorFrame.
  topic_tools::ShapeShifter other;
  other.morph(ros::message_traits::md5sum<sensor_msgs::Image>(), "sensor_msgs/Image", "", "0");
  EXPECT_FALSE(sensorFrameOf(other));
}
