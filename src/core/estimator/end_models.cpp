#include "end_models.hpp"

namespace drill_pipe_pose {

EndModels::EndModels(const EstimatorConfig& config) {
  models[0] = ProfileModel(EndLabel::kBoxEnd, config.dims);
  models[1] = ProfileModel(EndLabel::kPinEnd, config.dims);
  ToolJointDimensions long_tong = config.dims;
  long_tong.box_tong_length += 0.3;
  long_tong.pin_tong_length += 0.3;
  search_models[0] = ProfileModel(EndLabel::kBoxEnd, long_tong);
  search_models[1] = ProfileModel(EndLabel::kPinEnd, long_tong);
  for (int l = 0; l < kNumEnds; ++l) {
    const ProfileModel& m = models[l];
    // The joint with its taper and tube_length of tube: a flipped or mislabelled model predicts
    // surface there that the cameras see through (a worn taper is off by less than a pixel).
    const double z_lo = m.zMin() - config.free_space.tube_length;
    ToolJointDimensions d = config.dims;
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
