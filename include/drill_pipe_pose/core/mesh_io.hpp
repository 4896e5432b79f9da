#pragma once
// Meshes and model clouds on disk: read STL / OBJ / PLY (through PCL's VTK-based reader), sample a
// mesh's surface uniformly (what the thesis did by hand in CloudCompare), write / read PCD model
// clouds with normals.

#include <cstdint>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/tool_joint.hpp"

namespace drill_pipe_pose {

/// Reads a triangle mesh (.stl, .obj, .ply; polygons are fan-triangulated). `scale` multiplies
/// the coordinates (e.g. 0.001 for CAD in millimetres). Throws InputError naming the file.
TriangleMesh loadMesh(const std::string& path, double scale = 1.0);

/// Samples the mesh surface uniformly by area: about one point per spacing^2 [m^2], each with its
/// triangle's normal; deterministic for a seed.
std::vector<OrientedPoint> sampleMeshSurface(const TriangleMesh& mesh, double spacing,
                                             uint32_t seed);

/// Writes points with normals as a binary PCD (pcl::PointNormal). Throws InputError on failure.
void saveModelCloud(const std::vector<OrientedPoint>& points, const std::string& path);
/// Reads a PCD written by saveModelCloud (or any PCD with x y z normal_x normal_y normal_z).
std::vector<OrientedPoint> loadModelCloud(const std::string& path);

}  // namespace drill_pipe_pose
