// Fuzz harness: the pose estimator's parameter file (loadEstimatorNodeYaml,
// core/estimator/estimator_params_table.hpp) on mutated YAML, then what the node and
// bench_estimator build from it: the CycleRunner (the estimator with its models, the frame
// synchroniser).
//
// The YAML file (config/estimator_thesis_lab.yaml, a rig's own settings) is read by
// bench_estimator --config and, through rosparam, by the node; every key goes through the one
// parameter table. A bad key, type or range must be an InputError naming the file and the key.
// A file that loads must give a configuration the CycleRunner accepts or rejects with an
// InputError (cross-field checks, pipe types), never a crash. The file's `rig` and
// `pipe_catalog` paths are replaced by "" and the package's catalogue: those files have their own
// harnesses, and a fuzzed path must not make the harness read /dev/zero.
// Checked beyond "no crash": every key of a file that loads is stored as written (an integer
// that passed its range check must not be truncated into the field, a list must keep its
// elements), compared through the table's own accessors.
// Seeds: config/estimator_thesis_lab.yaml and test/fuzz/corpus/estimator_yaml/ (every key).

#include <sys/mman.h>
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

#include "drill_pipe_pose/core/cycle_runner.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/pipe_catalog.hpp"

using namespace drill_pipe_pose;

namespace {

[[noreturn]] void violated(const std::string& what) {
  std::fprintf(stderr, "fuzz_estimator_yaml: %s\n", what.c_str());
  std::abort();
}

/// The loader reads a file: one in-memory file (memfd) rewritten per input, no disk traffic.
const std::string& writeInput(const uint8_t* data, size_t size) {
  static int fd = -1;
  static std::string path;
  if (fd < 0) {
    fd = memfd_create("fuzz_estimator_yaml", 0);
    if (fd < 0) violated("memfd_create failed");
    path = "/proc/self/fd/" + std::to_string(fd);
  }
  if (ftruncate(fd, 0) != 0 || pwrite(fd, data, size, 0) != static_cast<ssize_t>(size))
    violated("cannot write the input file");
  return path;
}

class NoTransforms : public TransformSource {
 public:
  Eigen::Isometry3d lookup(const std::string&, const std::string&, int64_t) override {
    return Eigen::Isometry3d::Identity();
  }
};

/// Whether the value read back through the table equals the value in the file.
bool sameValue(const ParamValue& stored, const ParamValue& written) {
  if (stored.index() != written.index()) return false;
  if (const auto* d = std::get_if<double>(&stored)) {
    const double w = std::get<double>(written);
    // float fields read back as the float's shortest decimal (param_detail::floatAsDouble)
    return *d == w || static_cast<float>(*d) == static_cast<float>(w);
  }
  return stored == written;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string& path = writeInput(data, size);
  // FUZZ_VERBOSE=1: say why an input was rejected (to check that the seeds get through).
  static const bool verbose = std::getenv("FUZZ_VERBOSE") != nullptr;
  EstimatorNodeConfig cfg;
  try {
    loadEstimatorNodeYaml(&cfg, path);
  } catch (const InputError& e) {
    if (verbose) std::fprintf(stderr, "rejected: %s\n", e.what());
    return 0;  // documented: InputError naming the file and the key
  }

  // Stored as written: the last value of each key in the file, parsed by the key's row.
  const ParamTable<EstimatorNodeConfig>& table = estimatorNodeParamTable();
  std::map<std::string, YAML::Node> written;
  for (const auto& [key, node] : flattenYamlFile(path)) written[key] = node;
  for (const auto& [key, node] : written) {
    const ParamSpec<EstimatorNodeConfig>* row = findParam(table, key);
    if (!row) violated("key '" + key + "' loaded but the table has no row for it");
    const ParamValue w = parseParamYaml(row->info, node, path);
    const ParamValue s = row->get(cfg);
    if (!sameValue(s, w))
      violated("key '" + key + "' = " + formatParamValue(w) + " is stored as " +
               formatParamValue(s));
  }

  // What the node builds next (CycleRunner: pipe types from the catalogue, the estimator).
  cfg.rig.clear();
  cfg.estimator.pipe_catalog = pipeCatalogPath(DRILL_PIPE_POSE_SOURCE_DIR);
  NoTransforms tf;
  try {
    CycleRunner runner(cfg, &tf);
    if (verbose) std::fprintf(stderr, "accepted, CycleRunner built\n");
  } catch (const InputError& e) {
    // documented: the configuration or the pipe types are rejected naming the key
    if (verbose) std::fprintf(stderr, "CycleRunner rejected: %s\n", e.what());
  }
  return 0;
}
