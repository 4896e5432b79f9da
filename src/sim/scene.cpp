// Placeholder: the simulator lands here (issue 3).
namespace drill_pipe_pose {
namespace sim {}
}  // namespace drill_pipe_pose
