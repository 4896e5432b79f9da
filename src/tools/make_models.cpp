// make_models: writes the parametric tool-joint models (default 5" NC50) to a folder:
// box_end.stl, pin_end.stl (meshes) and box_end.pcd, pin_end.pcd (uniform clouds with normals).
//
//   rosrun drill_pipe_pose make_models OUT_DIR [--spacing 0.003] [--threads]
//
// OUT_DIR must exist. Exit status 0; 1 when a model cannot be written; 2 on a bad command line.
#include <iostream>
#include <string>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/mesh_io.hpp"
#include "drill_pipe_pose/core/tool_joint.hpp"
#include "cli.hpp"

int main(int argc, char** argv) {
  std::string dir;
  double spacing = 0.003;
  drill_pipe_pose::ToolJointDimensions dims;
  CLI::App app{"Writes the parametric tool-joint models (default 5\" NC50) as STL meshes and PCD "
               "clouds with normals.",
               "make_models"};
  drill_pipe_pose::tools::configureApp(app);
  app.add_option("OUT_DIR", dir, "existing folder for box_end/pin_end .stl and .pcd")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("--spacing", spacing, "[m] point spacing of the sampled clouds")
      ->capture_default_str()
      ->check(CLI::Range(1e-4, 0.1));
  app.add_flag("--threads", dims.threads,
               "model the thread ridges (4 TPI) on the pin and in the box");
  drill_pipe_pose::tools::parseOrExit(app, argc, argv);
  try {
    for (auto end : {drill_pipe_pose::EndLabel::kBoxEnd, drill_pipe_pose::EndLabel::kPinEnd}) {
      const auto profile = drill_pipe_pose::toolJointProfile(end, dims);
      const std::string base = dir + "/" + drill_pipe_pose::labelName(end);
      drill_pipe_pose::writeStl(drill_pipe_pose::revolveProfile(profile, 96), base + ".stl");
      const auto pts = drill_pipe_pose::sampleProfileSurface(profile, spacing, 1);
      drill_pipe_pose::saveModelCloud(pts, base + ".pcd");
      std::cout << "make_models: " << base << ".stl, " << base << ".pcd (" << pts.size()
                << " points)\n";
    }
  } catch (const std::exception& e) {
    std::cerr << "make_models: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
