#pragma once
// Error type of the ROS-free core. Every message names the camera / field / file and the value,
// so that a log line at 3 a.m. says what to fix.

#include <sstream>
#include <stdexcept>
#include <string>

namespace drill_pipe_pose {

/// Bad input data or bad configuration. what() names the source, the field and the value.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Builds a message from stream-able parts: fail("cam1 depth_info: K[0] = ", fx, " ...").
template <typename... Args>
[[noreturn]] void fail(const Args&... args) {
  std::ostringstream s;
  (s << ... << args);
  throw InputError(s.str());
}

}  // namespace drill_pipe_pose
