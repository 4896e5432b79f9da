// The parameter tables (core/param_table.hpp): every row round-trips, out-of-range values are
// rejected naming the key, applyParam / loadEstimatorYaml on valid and invalid input, the YAML in
// config/ loads, and docs/parameters.md holds the generated tables.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

#include "drill_pipe_pose/core/detector/detector_node_params.hpp"
#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/estimator/estimator_params_table.hpp"
#include "drill_pipe_pose/sim/simulator_node_params.hpp"

using namespace drill_pipe_pose;

namespace {

const std::string kSource = DRILL_PIPE_POSE_SOURCE_DIR;

/// The message of the InputError `f` throws ("" when it throws none).
template <class F>
std::string errorOf(F f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

/// A value just outside the row's range ("nan" when it has no bound), or "" for non-numbers.
std::string outOfRange(const ParamInfo& info) {
  const bool numeric = info.type == ParamType::kInt || info.type == ParamType::kDouble ||
                       info.type == ParamType::kVec3 || info.type == ParamType::kDoubleList;
  if (!numeric) return "";
  std::string v = "nan";
  if (std::isfinite(info.range.min)) {
    std::ostringstream s;
    s << (info.range.min_exclusive ? info.range.min : info.range.min - 1);
    v = s.str();
  } else if (std::isfinite(info.range.max)) {
    std::ostringstream s;
    s << (info.range.max_exclusive ? info.range.max : info.range.max + 1);
    v = s.str();
  }
  if (info.type == ParamType::kInt && v == "nan") return "";
  if (info.type == ParamType::kVec3) return "[0, 0, " + v + "]";
  if (info.type == ParamType::kDoubleList) return "[" + v + "]";
  return v;
}

/// Every row: names unique and documented; the default, formatted and parsed back, gives the
/// default; a value out of range is rejected naming the key.
template <class Config>
void checkTable(const ParamTable<Config>& table) {
  std::set<std::string> names;
  const Config defaults;
  for (const auto& row : table) {
    const ParamInfo& info = row.info;
    SCOPED_TRACE(info.name);
    EXPECT_TRUE(names.insert(info.name).second) << "duplicate key";
    EXPECT_FALSE(info.doc.empty());
    const ParamValue d = row.get(defaults);
    EXPECT_NO_THROW(checkParamValue(info, d, "default"));
    std::string text = formatParamValue(d);
    if (info.type == ParamType::kString || info.type == ParamType::kEnum)
      text = std::get<std::string>(d);  // unquoted on a command line
    Config c;
    EXPECT_NO_THROW(applyParamString(table, &c, info.name, text, "test"));
    EXPECT_EQ(formatParamValue(row.get(c)), formatParamValue(d)) << text;

    const std::string bad = outOfRange(info);
    if (!bad.empty()) {
      const std::string e = errorOf([&] { applyParamString(table, &c, info.name, bad, "test"); });
      EXPECT_NE(e.find(info.name), std::string::npos) << bad << ": " << e;
      EXPECT_NE(e.find("must be"), std::string::npos) << e;
    }
    if (info.type == ParamType::kBool || info.type == ParamType::kInt ||
        info.type == ParamType::kDouble || info.type == ParamType::kEnum) {
      const std::string e =
          errorOf([&] { applyParamString(table, &c, info.name, "not-a-value", "test"); });
      EXPECT_NE(e.find(info.name), std::string::npos) << e;
    }
  }
}

std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

std::string readFile(const std::string& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

}  // namespace

TEST(ParamTables, EveryEstimatorRowRoundTripsAndChecksItsRange) {
  checkTable(estimatorParamTable());
  checkTable(estimatorNodeParamTable());
}

TEST(ParamTables, EveryDetectorAndSimulatorRowRoundTrips) {
  checkTable(pipeDetectorParamTable());
  checkTable(rigSimulatorParamTable());
}

TEST(ParamTables, EveryEstimatorFieldHasARow) {
  // The four baseline fields the old loader could not read, the thread model and the seed.
  for (const char* key :
       {"baseline/prealign_distance", "baseline/min_points", "baseline/position_std",
        "baseline/tilt_std", "tool_joint/threads", "tool_joint/thread_height", "axis_fit/seed",
        "threads", "method", "work_zone/min"})
    EXPECT_NE(findParam(estimatorParamTable(), key), nullptr) << key;
  EXPECT_EQ(estimatorParamTable().size(), 160u) << "a field added: add its row too";
}

TEST(ParamTables, DefaultsAreTheNodes) {
  EXPECT_EQ(EstimatorConfig().threads, 2);
  EXPECT_NO_THROW(validateConfig(EstimatorConfig()));
  EstimatorNodeConfig n;
  EXPECT_NE(errorOf([&] { validateEstimatorNodeConfig(n); }).find("cameras"), std::string::npos);
  n.cameras = {"cam1"};
  EXPECT_NO_THROW(validateEstimatorNodeConfig(n));
}

TEST(ParamTables, ValidateConfigNamesTheKeyAndRange) {
  EstimatorConfig c;
  c.carving.vote_fraction = 1.5;
  std::string e = errorOf([&] { validateConfig(c); });
  EXPECT_NE(e.find("carving/vote_fraction = 1.5: must be in [0, 1]"), std::string::npos) << e;
  c = EstimatorConfig();
  c.baseline.prealign_distance = 0;
  e = errorOf([&] { validateConfig(c); });
  EXPECT_NE(e.find("baseline/prealign_distance"), std::string::npos) << e;
  // Cross-field checks are kept.
  c = EstimatorConfig();
  c.cutout.max_range = 0.2;
  EXPECT_NE(errorOf([&] { validateConfig(c); }).find("cutout/max_range"), std::string::npos);
  c = EstimatorConfig();
  c.work_zone.min.z() = 2e3;
  EXPECT_NE(errorOf([&] { validateConfig(c); }).find("work_zone/min[2]"), std::string::npos);
  c = EstimatorConfig();
  c.dims.tube_od = 0.2;
  EXPECT_NE(errorOf([&] { validateConfig(c); }).find("tube_od"), std::string::npos);
  c = EstimatorConfig();
  c.instances.handling_point = {4.7, 4.85};
  e = errorOf([&] { validateConfig(c); });
  EXPECT_NE(e.find("instances/handling_point has 2 values"), std::string::npos) << e;
  c.instances.handling_point = {4.7, 4.85, std::nan("")};
  e = errorOf([&] { validateConfig(c); });
  EXPECT_NE(e.find("instances/handling_point"), std::string::npos) << e;
  c.instances.handling_point = {4.7, 4.85, 0.6};
  EXPECT_NO_THROW(validateConfig(c));
}

TEST(ApplyParam, SetsValidValues) {
  EstimatorConfig c;
  applyParam(&c, "carving/vote_fraction", "0.8");
  EXPECT_EQ(c.carving.vote_fraction, 0.8);
  applyParam(&c, "threads", "1");
  EXPECT_EQ(c.threads, 1);
  applyParam(&c, "tracking/enabled", "false");
  EXPECT_FALSE(c.tracking.enabled);
  applyParam(&c, "method", "thesis_baseline");
  EXPECT_EQ(c.method, EstimatorMethod::kThesisBaseline);
  applyParam(&c, "work_zone/min", "[1, 2.5, -3]");
  EXPECT_EQ(c.work_zone.min, Eigen::Vector3d(1, 2.5, -3));
  applyParam(&c, "work_zone/max", "4,5,6");
  EXPECT_EQ(c.work_zone.max, Eigen::Vector3d(4, 5, 6));
  applyParam(&c, "tool_joint/tool_joint_od", "0.1588");
  EXPECT_EQ(c.dims.tool_joint_od, 0.1588);
  applyParam(&c, "baseline/tilt_std", "0.1");
  EXPECT_EQ(c.baseline.tilt_std, 0.1);
  applyParam(&c, "cutout/min_confidence", "0.3");
  EXPECT_FLOAT_EQ(c.cutout.min_confidence, 0.3f);
  EXPECT_NO_THROW(validateConfig(c));
}

TEST(ApplyParam, RejectsUnknownKeysWrongTypesAndOutOfRange) {
  EstimatorConfig c;
  std::string e = errorOf([&] { applyParam(&c, "carving/vote_fractoin", "0.8"); });
  EXPECT_NE(e.find("unknown parameter 'carving/vote_fractoin'"), std::string::npos) << e;
  EXPECT_NE(e.find("did you mean carving/vote_fraction"), std::string::npos) << e;
  e = errorOf([&] { applyParam(&c, "carving/vote_fraction", "high"); });
  EXPECT_NE(e.find("carving/vote_fraction = high: expected a number"), std::string::npos) << e;
  e = errorOf([&] { applyParam(&c, "carving/vote_fraction", "1.5"); });
  EXPECT_NE(e.find("carving/vote_fraction = 1.5: must be in [0, 1]"), std::string::npos) << e;
  e = errorOf([&] { applyParam(&c, "carving/min_cameras", "2.5"); });
  EXPECT_NE(e.find("expected an integer"), std::string::npos) << e;
  e = errorOf([&] { applyParam(&c, "carving/min_cameras", "0"); });
  EXPECT_NE(e.find("carving/min_cameras = 0: must be >= 1"), std::string::npos) << e;
  // An integer beyond the field's type (an int here) is refused, not cut to another value: the
  // estimator_yaml fuzzer's 10^6-input run (seed 2, input 146107) found 2^32 stored as 0.
  e = errorOf([&] { applyParam(&c, "axis_fit/hypotheses", "4294967296"); });
  EXPECT_NE(e.find("axis_fit/hypotheses = 4294967296: out of the range of its integer type "
                   "(-2147483648 to 2147483647)"),
            std::string::npos)
      << e;
  EXPECT_EQ(c.axis_fit.hypotheses, EstimatorConfig().axis_fit.hypotheses) << "unchanged";
  e = errorOf([&] { applyParam(&c, "axis_fit/hypotheses", "2147483647"); });
  EXPECT_EQ(e, "") << "the largest int is accepted";
  c.axis_fit.hypotheses = EstimatorConfig().axis_fit.hypotheses;
  e = errorOf([&] { applyParam(&c, "tracking/enabled", "yes"); });
  EXPECT_NE(e.find("expected a boolean"), std::string::npos) << e;
  e = errorOf([&] { applyParam(&c, "method", "icp"); });
  EXPECT_NE(e.find("must be one of ours, thesis_baseline"), std::string::npos) << e;
  e = errorOf([&] { applyParam(&c, "work_zone/min", "1,2"); });
  EXPECT_NE(e.find("expected a list of 3 numbers"), std::string::npos) << e;
  e = errorOf([&] { applyParam(&c, "noise/scale", "inf"); });
  EXPECT_NE(e.find("noise/scale"), std::string::npos) << e;
  EXPECT_EQ(formatParamValue(estimatorParamTable()[0].get(c)), "\"ours\"") << "unchanged";
}

TEST(LoadEstimatorYaml, TheConfigFileLoads) {
  const std::string path = kSource + "/config/estimator_thesis_lab.yaml";
  EstimatorConfig c;
  loadEstimatorYaml(&c, path);
  EXPECT_EQ(c.work_zone.min, Eigen::Vector3d(2.7, 4.0, 0.0));
  EXPECT_EQ(c.work_zone.max, Eigen::Vector3d(6.7, 8.1, 3.0));
  EXPECT_EQ(c.method, EstimatorMethod::kOurs);
  EXPECT_EQ(c.threads, 2);
  EstimatorNodeConfig n;
  loadEstimatorNodeYaml(&n, path);
  EXPECT_EQ(n.cameras.size(), 6u);
  EXPECT_EQ(n.sync.window, 0.0333);
  EXPECT_EQ(n.estimator.work_zone.min, c.work_zone.min);
}

TEST(LoadEstimatorYaml, ReadsNestedKeysAndRejectsBadFiles) {
  EstimatorConfig c;
  loadEstimatorYaml(&c, writeTemp("ok.yaml",
                                   "cameras: [a]\nthreads: 1\ncarving: {vote_fraction: 0.5}\n"
                                   "baseline:\n  prealign_distance: 0.1\n  min_points: 12\n"
                                   "tool_joint: {threads: true}\n"));
  EXPECT_EQ(c.threads, 1);
  EXPECT_EQ(c.carving.vote_fraction, 0.5);
  EXPECT_EQ(c.baseline.prealign_distance, 0.1);
  EXPECT_EQ(c.baseline.min_points, 12u);
  EXPECT_TRUE(c.dims.threads);

  const std::vector<std::pair<std::string, std::string>> bad = {
      {"carving: {vote_fractoin: 0.5}\n", "unknown parameter 'carving/vote_fractoin'"},
      {"threads: two\n", "threads = two: expected an integer"},
      {"carving: {vote_fraction: 1.5}\n", "carving/vote_fraction = 1.5: must be in [0, 1]"},
      {"tracking: {enabled: 1}\n", "tracking/enabled = 1: expected a boolean"},
      {"work_zone: {min: [1, 2]}\n", "work_zone/min = [1, 2]: expected a list of 3 numbers"},
      {"work_zone: {min: [0, 0, 5], max: [1, 1, 1]}\n", "work_zone/min[2]"},
      {"sync: {window: 0}\n", "sync/window = 0: must be >= 0.0001"},
      {"method: icp\n", "must be one of ours, thesis_baseline"},
      {"- a\n- b\n", "expected a map"},
      {"a: [unclosed\n", "cannot read YAML"},
  };
  for (size_t i = 0; i < bad.size(); ++i) {
    const std::string path = writeTemp("bad" + std::to_string(i) + ".yaml", bad[i].first);
    EstimatorConfig d;
    const std::string e = errorOf([&] { loadEstimatorYaml(&d, path); });
    EXPECT_NE(e.find(bad[i].second), std::string::npos) << bad[i].first << " -> " << e;
    EXPECT_NE(e.find(path), std::string::npos) << "names the file: " << e;
  }
  EXPECT_NE(errorOf([&] { loadEstimatorYaml(&c, "/nonexistent.yaml"); }).find("/nonexistent.yaml"),
            std::string::npos);
}

TEST(ParamTables, ReadmeTablesAreTheGeneratedOnes) {
  // Regenerate with: rosrun drill_pipe_pose param_tables --update docs/parameters.md
  const std::string readme = readFile(kSource + "/docs/parameters.md");
  const std::vector<std::pair<std::string, std::string>> sections = {
      {"pose_estimator parameters", estimatorParamsMarkdown()},
      {"pipe_detector parameters", pipeDetectorParamsMarkdown()},
      {"rig_simulator parameters", rigSimulatorParamsMarkdown()},
  };
  for (const auto& [name, text] : sections) {
    std::string in_readme;
    ASSERT_NO_THROW(in_readme = generatedSection(readme, name)) << name;
    EXPECT_EQ(in_readme, text) << name << ": run param_tables --update docs/parameters.md";
  }
}
