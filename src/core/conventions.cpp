#include "drill_pipe_pose/core/conventions.hpp"

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

EndLabel parseEndLabel(const std::string& label, const std::string& source) {
  if (label == conventions::kBoxEndLabel) return EndLabel::kBoxEnd;
  if (label == conventions::kPinEndLabel) return EndLabel::kPinEnd;
  fail(source, ": label = \"", label, "\" is not a pipe end (expected \"",
       conventions::kBoxEndLabel, "\" or \"", conventions::kPinEndLabel, "\")");
}

}  // namespace drill_pipe_pose
