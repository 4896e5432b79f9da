// Mesh files and model clouds: STL round trip, uniform sampling, PCD round trip, bad files.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/mesh_io.hpp"

using namespace drill_pipe_pose;

namespace {

std::string tmpPath(const std::string& name) {
  return (testing::TempDir().empty() ? std::string("/tmp/") : testing::TempDir()) + name;
}

}  // namespace

TEST(MeshIo, StlRoundTripAndUniformSampling) {
  const ToolJointDimensions d;
  const TriangleMesh mesh = revolveProfile(toolJointProfile(EndLabel::kBoxEnd, d), 64);
  const std::string stl = tmpPath("dpp_box.stl");
  writeStl(mesh, stl);
  const TriangleMesh back = loadMesh(stl);
  ASSERT_EQ(back.triangles.size(), mesh.triangles.size());
  // Sampling: count ~ area / spacing^2; points on the (faceted) surface: radius within the facet
  // sagitta of the profile's radii; normals of unit length.
  double area = 0;
  for (const auto& t : back.triangles)
    area += 0.5 * (back.vertices[t[1]] - back.vertices[t[0]])
                      .cross(back.vertices[t[2]] - back.vertices[t[0]])
                      .norm();
  const double spacing = 0.004;
  const auto pts = sampleMeshSurface(back, spacing, 3);
  EXPECT_NEAR(static_cast<double>(pts.size()), area / (spacing * spacing), 1.0);
  size_t on_tong = 0;
  for (const auto& op : pts) {
    ASSERT_NEAR(op.n.norm(), 1.0f, 1e-4f);
    if (op.p.z() < -0.01 && op.p.z() > -d.box_tong_length + 0.01 &&
        std::hypot(op.p.x(), op.p.y()) > d.tool_joint_od / 2 - 0.001)
      ++on_tong;
  }
  const double tong_area = 2 * M_PI * d.tool_joint_od / 2 * (d.box_tong_length - 0.02);
  EXPECT_NEAR(on_tong / static_cast<double>(pts.size()), tong_area / area, 0.02);
  std::remove(stl.c_str());
}

TEST(MeshIo, ModelCloudRoundTrip) {
  const auto pts =
      sampleProfileSurface(toolJointProfile(EndLabel::kPinEnd, ToolJointDimensions()), 0.01, 1);
  const std::string pcd = tmpPath("dpp_pin.pcd");
  saveModelCloud(pts, pcd);
  const auto back = loadModelCloud(pcd);
  ASSERT_EQ(back.size(), pts.size());
  for (size_t i = 0; i < pts.size(); ++i) {
    ASSERT_EQ(back[i].p, pts[i].p);
    ASSERT_EQ(back[i].n, pts[i].n);
  }
  std::remove(pcd.c_str());
}

TEST(MeshIoBadInput, MissingUnsupportedAndEmptyFilesAreNamed) {
  try {
    loadMesh("/nonexistent/joint.stl");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/joint.stl"), std::string::npos);
  }
  const std::string step = tmpPath("dpp_joint.step");
  std::ofstream(step) << "ISO-10303-21;";
  try {
    loadMesh(step);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'.step' is not supported"), std::string::npos)
        << e.what();
  }
  std::remove(step.c_str());
  EXPECT_THROW(loadModelCloud("/nonexistent/model.pcd"), InputError);
}
