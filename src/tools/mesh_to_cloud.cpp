// mesh_to_cloud: samples any STL / OBJ / PLY mesh uniformly into a model cloud with normals (PCD),
// replacing the thesis's manual CloudCompare step for users with real CAD.
//
//   rosrun drill_pipe_pose mesh_to_cloud MESH OUT.pcd [--spacing 0.003] [--scale 1] [--seed 1]
//
// --scale converts units (0.001 for a CAD model in millimetres). The model must be expressed in
// the pipe-end frame of docs/conventions.md (origin at the shoulder on the axis, z out toward
// the mate).
// Exit status 0; 1 when the mesh cannot be read or the cloud written; 2 on a bad command line.
#include <iostream>
#include <string>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/mesh_io.hpp"
#include "cli.hpp"

int main(int argc, char** argv) {
  std::string in, out;
  double spacing = 0.003, scale = 1.0;
  uint32_t seed = 1;
  CLI::App app{"Samples a mesh uniformly into a model cloud with normals (PCD).", "mesh_to_cloud"};
  drill_pipe_pose::tools::configureApp(app);
  app.add_option("MESH", in, "input mesh: .stl, .obj or .ply")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("OUT", out, "output cloud (.pcd)")->required();
  app.add_option("--spacing", spacing, "[m] point spacing of the sampled cloud")
      ->capture_default_str()
      ->check(CLI::Range(1e-4, 0.1));
  app.add_option("--scale", scale, "factor from the mesh's units to metres (0.001 for mm)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--seed", seed, "random seed of the sampling")->capture_default_str();
  drill_pipe_pose::tools::parseOrExit(app, argc, argv);
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
