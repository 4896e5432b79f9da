#include "drill_pipe_pose/core/mesh_io.hpp"

#include <pcl/PolygonMesh.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/vtk_lib_io.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <fstream>
#include <random>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

TriangleMesh loadMesh(const std::string& path, double scale) {
  if (!std::ifstream(path)) fail("mesh file '", path, "' cannot be read");
  std::string ext = path.substr(path.find_last_of('.') + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  if (ext != "stl" && ext != "obj" && ext != "ply")
    fail("mesh file '", path, "': extension '.", ext, "' is not supported (.stl, .obj, .ply)");
  pcl::PolygonMesh pm;
  if (pcl::io::loadPolygonFile(path, pm) == 0 || pm.polygons.empty())
    fail("mesh file '", path, "' has no polygons (unreadable or not a ", ext, " mesh)");
  pcl::PointCloud<pcl::PointXYZ> verts;
  pcl::fromPCLPointCloud2(pm.cloud, verts);
  TriangleMesh m;
  for (const auto& v : verts.points)
    m.vertices.emplace_back(static_cast<float>(v.x * scale), static_cast<float>(v.y * scale),
                            static_cast<float>(v.z * scale));
  for (const auto& poly : pm.polygons)
    for (size_t k = 2; k < poly.vertices.size(); ++k) {
      const Eigen::Vector3i t(poly.vertices[0], poly.vertices[k - 1], poly.vertices[k]);
      if (t.maxCoeff() >= static_cast<int>(m.vertices.size()))
        fail("mesh file '", path, "': a face refers to vertex ", t.maxCoeff(), " of ",
             m.vertices.size());
      m.triangles.push_back(t);
    }
  return m;
}

std::vector<OrientedPoint> sampleMeshSurface(const TriangleMesh& mesh, double spacing,
                                             uint32_t seed) {
  if (!(spacing > 0.0)) fail("sampleMeshSurface: spacing = ", spacing, " must be > 0");
  std::vector<double> cdf;
  double total = 0;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[t[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[t[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[t[2]].cast<double>();
    total += 0.5 * (b - a).cross(c - a).norm();
    cdf.push_back(total);
  }
  if (!(total > 0)) fail("sampleMeshSurface: the mesh has no area");
  const size_t n = static_cast<size_t>(std::ceil(total / (spacing * spacing)));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::vector<OrientedPoint> out;
  out.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const size_t k = std::min<size_t>(
        std::lower_bound(cdf.begin(), cdf.end(), U(rng) * total) - cdf.begin(), cdf.size() - 1);
    const auto& t = mesh.triangles[k];
    const Eigen::Vector3f &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]],
                          &c = mesh.vertices[t[2]];
    const double s = std::sqrt(U(rng)), r = U(rng);  // uniform on the triangle
    const Eigen::Vector3f p = (1 - s) * a + s * (1 - r) * b + s * r * c;
    out.push_back({p, (b - a).cross(c - a).normalized()});
  }
  return out;
}

void saveModelCloud(const std::vector<OrientedPoint>& points, const std::string& path) {
  pcl::PointCloud<pcl::PointNormal> cloud;
  for (const auto& op : points) {
    pcl::PointNormal q;
    q.x = op.p.x();
    q.y = op.p.y();
    q.z = op.p.z();
    q.normal_x = op.n.x();
    q.normal_y = op.n.y();
    q.normal_z = op.n.z();
    q.curvature = 0;
    cloud.push_back(q);
  }
  if (pcl::io::savePCDFileBinary(path, cloud) != 0) fail("cannot write PCD '", path, "'");
}

std::vector<OrientedPoint> loadModelCloud(const std::string& path) {
  if (!std::ifstream(path)) fail("model cloud '", path, "' cannot be read");
  pcl::PointCloud<pcl::PointNormal> cloud;
  if (pcl::io::loadPCDFile(path, cloud) != 0 || cloud.empty())
    fail("model cloud '", path, "' is not a readable, non-empty PCD with normals");
  std::vector<OrientedPoint> out;
  out.reserve(cloud.size());
  for (const auto& q : cloud.points)
    out.push_back(
        {Eigen::Vector3f(q.x, q.y, q.z), Eigen::Vector3f(q.normal_x, q.normal_y, q.normal_z)});
  return out;
}

}  // namespace drill_pipe_pose
