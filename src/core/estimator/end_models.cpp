#include "end_models.hpp"

namespace drill_pipe_pose {

EndModels::EndModels(const EstimatorConfig& config)
    : EndModels(config, config.dims, config.dims) {}

EndModels::EndModels(const EstimatorConfig& config, const ToolJointDimensions& box,
                     const ToolJointDimensions& pin) {
  const std::array<const ToolJointDimensions*, kNumEnds> dims{{&box, &pin}};
  for (int l = 0; l < kNumEnds; ++l) {
    const EndLabel label = static_cast<EndLabel>(l);
    models[l] = ProfileModel(label, *dims[l]);
    ToolJointDimensions long_tong = *dims[l];
    long_tong.box_tong_length += 0.3;
    long_tong.pin_tong_length += 0.3;
    search_models[l] = ProfileModel(label, long_tong);
    joint_radius[l] = dims[l]->tool_joint_od / 2;
    tube_radius[l] = dims[l]->tube_od / 2;
  }
  for (int l = 0; l < kNumEnds; ++l) {
    const ProfileModel& m = models[l];
    // The joint with its taper and tube_length of tube: a flipped or mislabelled model predicts
    // surface there that the cameras see through (a worn taper is off by less than a pixel).
    const double z_lo = m.zMin() - config.free_space.tube_length;
    ToolJointDimensions d = *dims[l];
    d.tube_length = config.free_space.tube_length;
    for (const OrientedPoint& s :
         sampleProfileSurface(toolJointProfile(static_cast<EndLabel>(l), d),
                              config.free_space.sample_spacing, 1, true)) {
      if (s.p.z() < z_lo + 1e-3 || s.p.z() > m.zMax() + 1e-6) continue;
      fs_samples[l].push_back(s);
    }
  }
}

}  // namespace drill_pipe_pose
