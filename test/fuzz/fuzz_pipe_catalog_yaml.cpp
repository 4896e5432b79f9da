// Fuzz harness: the pipe catalogue loader (core/pipe_catalog.hpp, parsePipeCatalog) on mutated
// YAML.
//
// The catalogue (config/pipe_catalog.yaml) feeds the estimator's models and the simulator's
// joints; a site may add its own entries. A bad entry must end in an InputError naming the file,
// the entry and the field. Checked beyond "no crash": every entry of a catalogue that loads has
// a geometry the tool-joint model accepts (the loader documents that it runs
// validateDimensions), i.e. toolJointProfile builds both ends' profiles, with finite points, and
// at() finds every entry by its name. Seed: config/pipe_catalog.yaml.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/pipe_catalog.hpp"
#include "drill_pipe_pose/core/tool_joint.hpp"

using namespace drill_pipe_pose;

namespace {
[[noreturn]] void violated(const std::string& what) {
  std::fprintf(stderr, "fuzz_pipe_catalog_yaml: %s\n", what.c_str());
  std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  PipeCatalog cat;
  try {
    cat = parsePipeCatalog(text, "fuzz_catalog.yaml");
  } catch (const InputError&) {
    return 0;  // documented: InputError naming the file, the entry and the field
  }
  for (const PipeType& t : cat.types) {
    if (&cat.at(t.name) != &t) violated("at() does not find entry '" + t.name + "'");
    for (EndLabel end : {EndLabel::kBoxEnd, EndLabel::kPinEnd}) {
      std::vector<ProfilePoint> profile;
      try {
        profile = toolJointProfile(end, t.dims);
      } catch (const InputError& e) {
        violated("entry '" + t.name + "' loaded but its profile is rejected: " + e.what());
      }
      for (const ProfilePoint& p : profile)
        if (!std::isfinite(p.z) || !std::isfinite(p.r))
          violated("entry '" + t.name + "' gives a profile point that is not finite");
    }
  }
  return 0;
}
