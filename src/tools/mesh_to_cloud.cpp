// mesh_to_cloud: samples any STL / OBJ / PLY mesh uniformly into a model cloud with normals (PCD),
// replacing the thesis's manual CloudCompare step for users with real CAD.
//
//   rosrun drill_pipe_pose mesh_to_cloud MESH OUT.pcd [--spacing 0.003] [--scale 1] [--seed 1]
//
// --scale converts units (0.001 for a CAD model in millimetres). The model must be expressed in
// the pipe-end frame of the README (origin at the shoulder on the axis, z out toward the mate).
#include <iostream>
#include <string>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/mesh_io.hpp"

int main(int argc, char** argv) {
  std::string in, out;
  double spacing = 0.003, scale = 1.0;
  uint32_t seed = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if ((a == "--spacing" || a == "--scale" || a == "--seed") && i + 1 < argc) {
      const std::string v = argv[++i];
      if (a == "--spacing")
        spacing = std::stod(v);
      else if (a == "--scale")
        scale = std::stod(v);
      else
        seed = static_cast<uint32_t>(std::stoul(v));
    } else if (in.empty())
      in = a;
    else if (out.empty())
      out = a;
    else
      in.clear(), i = argc;
  }
  if (in.empty() || out.empty()) {
    std::cerr << "usage: mesh_to_cloud MESH(.stl|.obj|.ply) OUT.pcd [--spacing M] [--scale S] "
                 "[--seed N]\n";
    return 2;
  }
  try {
    const auto mesh = drill_pipe_pose::loadMesh(in, scale);
    const auto pts = drill_pipe_pose::sampleMeshSurface(mesh, spacing, seed);
    drill_pipe_pose::saveModelCloud(pts, out);
    std::cout << "mesh_to_cloud: " << in << ": " << mesh.triangles.size() << " triangles -> "
              << pts.size() << " points (spacing " << spacing << " m) -> " << out << "\n";
  } catch (const std::exception& e) {
    std::cerr << "mesh_to_cloud: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
