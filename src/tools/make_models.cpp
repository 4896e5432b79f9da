// make_models: writes the parametric tool-joint models (default 5" NC50) to a folder:
// box_end.stl, pin_end.stl (meshes) and box_end.pcd, pin_end.pcd (uniform clouds with normals).
//
//   rosrun drill_pipe_pose make_models OUT_DIR [--spacing 0.003] [--threads]
#include <iostream>
#include <string>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/mesh_io.hpp"
#include "drill_pipe_pose/core/tool_joint.hpp"

int main(int argc, char** argv) {
  std::string dir;
  double spacing = 0.003;
  drill_pipe_pose::ToolJointDimensions dims;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--spacing" && i + 1 < argc)
      spacing = std::stod(argv[++i]);
    else if (a == "--threads")
      dims.threads = true;
    else if (dir.empty())
      dir = a;
  }
  if (dir.empty()) {
    std::cerr << "usage: make_models OUT_DIR [--spacing M] [--threads]\n";
    return 2;
  }
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
