// Depth images: encodings, a plane at known depth, roi crops, bad images.
#include <gtest/gtest.h>

#include <cmath>

#include "drill_pipe_pose/core/depth_image.hpp"
#include "drill_pipe_pose/core/errors.hpp"

using namespace drill_pipe_pose;

namespace {

PinholeCamera depthCamera() {
  return PinholeCamera::fromIntrinsics(512, 424, 365.4, 365.4, 260.9, 205.6);
}

void expectInvalid(const DepthImage& img, const PinholeCamera& cam,
                   std::initializer_list<const char*> needles) {
  try {
    validateDepthImage(img, cam, "cam3 depth");
    FAIL() << "accepted a bad depth image";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("cam3 depth"), std::string::npos) << msg;
    for (const char* n : needles) EXPECT_NE(msg.find(n), std::string::npos) << msg;
  }
}

}  // namespace

TEST(DepthImage, EncodingsParseAndReject) {
  EXPECT_EQ(parseDepthEncoding("16UC1", "x"), DepthEncoding::kU16Millimetres);
  EXPECT_EQ(parseDepthEncoding("32FC1", "x"), DepthEncoding::kF32Metres);
  try {
    parseDepthEncoding("rgb8", "cam2 depth");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cam2 depth: encoding = \"rgb8\""), std::string::npos)
        << e.what();
  }
}

TEST(DepthImage, InvalidPixelsAreNan) {
  for (auto enc : {DepthEncoding::kU16Millimetres, DepthEncoding::kF32Metres}) {
    auto img = DepthImage::allocate(4, 2, enc);
    EXPECT_TRUE(std::isnan(img.depthAt(0, 0)));  // zero-filled = invalid
    img.setDepth(1, 1, 2.5f);
    EXPECT_NEAR(img.depthAt(1, 1), 2.5f, 1e-6f);
    img.setDepth(1, 1, std::nanf(""));
    EXPECT_TRUE(std::isnan(img.depthAt(1, 1)));
  }
  auto mm = DepthImage::allocate(2, 1, DepthEncoding::kU16Millimetres);
  mm.setDepth(0, 0, 1.23449f);  // 1 mm quantisation
  EXPECT_FLOAT_EQ(mm.depthAt(0, 0), 1.234f);
}

// A camera's depth calibration (rig file) applies on read: z = (z_meas - offset) / scale, the
// stored pixels unchanged; a correction that leaves no positive depth makes the pixel invalid.
TEST(DepthImage, CorrectionAppliesOnRead) {
  for (auto enc : {DepthEncoding::kU16Millimetres, DepthEncoding::kF32Metres}) {
    auto img = DepthImage::allocate(3, 1, enc);
    img.setDepth(0, 0, 6.125f);  // exact in both encodings
    img.setDepth(1, 0, 0.02f);
    DepthImage corrected = img;  // shares the pixels
    corrected.setCorrection(DepthCorrection{0.0255, 1.019}, "cam1 depth");
    EXPECT_NEAR(corrected.depthAt(0, 0), (6.125 - 0.0255) / 1.019, 1e-6);
    EXPECT_FLOAT_EQ(img.depthAt(0, 0), 6.125f);          // the original reads as stored
    EXPECT_TRUE(std::isnan(corrected.depthAt(1, 0)));    // 20 mm - 25.5 mm: nothing left
    EXPECT_TRUE(std::isnan(corrected.depthAt(2, 0)));    // invalid stays invalid
    corrected.setCorrection(DepthCorrection(), "cam1 depth");
    EXPECT_EQ(corrected.depthAt(0, 0), img.depthAt(0, 0));  // none: bit-identical
  }
  auto img = DepthImage::allocate(1, 1, DepthEncoding::kF32Metres);
  for (const DepthCorrection bad : {DepthCorrection{0.0, 0.0}, DepthCorrection{NAN, 1.0},
                                    DepthCorrection{0.0, INFINITY}}) {
    try {
      img.setCorrection(bad, "cam4 depth");
      FAIL() << "accepted offset " << bad.offset << " scale " << bad.scale;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("cam4 depth: depth correction"), std::string::npos)
          << e.what();
    }
  }
}

TEST(DepthProjector, PlaneAtKnownDepthGivesExpectedPoints) {
  const auto cam = depthCamera();
  for (auto enc : {DepthEncoding::kU16Millimetres, DepthEncoding::kF32Metres}) {
    auto img = DepthImage::allocate(512, 424, enc);
    for (uint32_t v = 0; v < 424; ++v)
      for (uint32_t u = 0; u < 512; ++u) img.setDepth(u, v, 2.0f);
    img.setDepth(5, 5, 0.0f);  // one hole
    validateDepthImage(img, cam, "test");
    const DepthProjector proj(cam);
    const auto pts = proj.allPoints(img);
    ASSERT_EQ(pts.size(), 512u * 424u - 1u);
    Eigen::Vector3f p;
    ASSERT_TRUE(proj.pointAt(img, 0, 0, &p));
    EXPECT_NEAR(p.x(), (0 - 260.9) / 365.4 * 2.0, 1e-5);
    EXPECT_NEAR(p.y(), (0 - 205.6) / 365.4 * 2.0, 1e-5);
    EXPECT_FLOAT_EQ(p.z(), 2.0f);
    EXPECT_FALSE(proj.pointAt(img, 5, 5, &p));
    for (const auto& q : pts) ASSERT_FLOAT_EQ(q.z(), 2.0f);
  }
}

TEST(DepthProjector, CroppedImageGivesSamePointsAsFull) {
  const auto full_cam = depthCamera();
  auto full = DepthImage::allocate(512, 424, DepthEncoding::kU16Millimetres);
  for (uint32_t v = 0; v < 424; ++v)
    for (uint32_t u = 0; u < 512; ++u) full.setDepth(u, v, 1.0f + 0.003f * u + 0.002f * v);
  const ImageRoi roi{200, 150, 40, 30};
  const auto crop_cam = full_cam.cropped(roi, "test");
  auto crop = DepthImage::allocate(roi.width, roi.height, DepthEncoding::kU16Millimetres);
  for (uint32_t v = 0; v < roi.height; ++v)
    for (uint32_t u = 0; u < roi.width; ++u)
      crop.setDepth(u, v, full.depthAt(u + roi.x_offset, v + roi.y_offset));
  validateDepthImage(crop, crop_cam, "test");

  std::vector<Eigen::Vector3f> from_full;
  DepthProjector(full_cam).forEachPoint(
      full, roi.x_offset, roi.y_offset, roi.x_offset + roi.width, roi.y_offset + roi.height,
      [&](int, int, const Eigen::Vector3f& p) { from_full.push_back(p); });
  const auto from_crop = DepthProjector(crop_cam).allPoints(crop);
  ASSERT_EQ(from_full.size(), from_crop.size());
  ASSERT_EQ(from_crop.size(), size_t{40 * 30});
  for (size_t i = 0; i < from_crop.size(); ++i)
    ASSERT_NEAR((from_full[i] - from_crop[i]).norm(), 0.0f, 1e-6f) << "i " << i;
}

TEST(DepthProjector, ForEachPointClampsToImage) {
  const auto cam = depthCamera();
  auto img = DepthImage::allocate(512, 424, DepthEncoding::kF32Metres);
  for (uint32_t v = 0; v < 424; ++v)
    for (uint32_t u = 0; u < 512; ++u) img.setDepth(u, v, 3.0f);
  int n = 0;
  DepthProjector(cam).forEachPoint(img, -10, -10, 5, 4,
                                   [&](int, int, const Eigen::Vector3f&) { ++n; });
  EXPECT_EQ(n, 20);
}

TEST(DepthImageBadInput, SizeDoesNotMatchCameraInfo) {
  auto img = DepthImage::allocate(500, 424, DepthEncoding::kU16Millimetres);
  expectInvalid(img, depthCamera(), {"500x424", "512x424"});
  const auto crop_cam = depthCamera().cropped({10, 10, 64, 32}, "test");
  expectInvalid(DepthImage::allocate(512, 424, DepthEncoding::kU16Millimetres), crop_cam,
                {"512x424", "roi", "64x32"});
}

TEST(DepthImageBadInput, WrongStep) {
  auto img = DepthImage::allocate(512, 424, DepthEncoding::kF32Metres);
  img.step = 512 * 2;  // a 16-bit step for a float image
  expectInvalid(img, depthCamera(), {"step = 1024", "2048"});
}

TEST(DepthImageBadInput, TruncatedData) {
  auto img = DepthImage::allocate(512, 424, DepthEncoding::kU16Millimetres);
  img.size -= 2;
  expectInvalid(img, depthCamera(), {"434174 bytes", "434176"});
}
