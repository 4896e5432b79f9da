// The drill-pipe catalogue: the shipped file (config/pipe_catalog.yaml) and the loader's errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/estimator/estimator_config.hpp"
#include "drill_pipe_pose/core/pipe_catalog.hpp"

using namespace drill_pipe_pose;

namespace {

// Geometry fields every shipped entry sets (the twelve required ones and tube_length).
const std::vector<std::string> kGeometryFields = {
    "tube_od",          "tube_id",           "tool_joint_od",   "tool_joint_id",
    "elevator_taper_deg", "pin_tong_length", "box_tong_length", "pin_length",
    "pin_large_diameter", "pin_taper",       "box_counterbore_diameter",
    "box_thread_depth",   "tube_length"};

PipeCatalog shipped() {
  return loadPipeCatalog(pipeCatalogPath(DRILL_PIPE_POSE_SOURCE_DIR));
}

// One valid entry (a 5" NC50) as YAML, with fields replaced (raw YAML values) or dropped;
// "sources/<field>" drops or replaces that field's citation.
std::string entry(const std::string& name, const std::map<std::string, std::string>& set = {},
                  const std::set<std::string>& drop = {}) {
  const std::vector<std::pair<std::string, std::string>> fields = {
      {"name", name},
      {"nominal_size", "'5\"'"},
      {"weight", "19.5"},
      {"grade", "S-135"},
      {"connection", "NC50"},
      {"tube_od", "0.127"},
      {"tube_id", "0.1086"},
      {"tool_joint_od", "0.168"},
      {"tool_joint_id", "0.0826"},
      {"elevator_taper_deg", "18"},
      {"pin_tong_length", "0.229"},
      {"box_tong_length", "0.305"},
      {"pin_length", "0.1143"},
      {"pin_large_diameter", "0.13335"},
      {"pin_taper", "0.1666667"},
      {"box_counterbore_diameter", "0.13495"},
      {"box_thread_depth", "0.11748"}};
  std::string s = "  - ";
  for (const auto& [key, value] : fields) {
    if (drop.count(key)) continue;
    s += key + ": " + (set.count(key) ? set.at(key) : value) + "\n    ";
  }
  for (const auto& [key, value] : set)  // fields the list above does not hold
    if (std::none_of(fields.begin(), fields.end(), [&](const auto& f) { return f.first == key; }) &&
        key.rfind("sources/", 0) != 0)
      s += key + ": " + value + "\n    ";
  if (drop.count("sources")) return s + "\n";
  s += "sources:\n";
  for (size_t i = 5; i < fields.size(); ++i) {
    const std::string key = "sources/" + fields[i].first;
    if (drop.count(key)) continue;
    s += "      " + fields[i].first + ": " + (set.count(key) ? set.at(key) : "\"test figure\"") +
         "\n";
  }
  for (const auto& [key, value] : set)  // citations of fields the list above does not hold
    if (key.rfind("sources/", 0) == 0 &&
        std::none_of(fields.begin(), fields.end(),
                     [&](const auto& f) { return "sources/" + f.first == key; }))
      s += "      " + key.substr(8) + ": " + value + "\n";
  return s;
}

std::string catalog(const std::vector<std::string>& entries) {
  std::string s = "pipe_types:\n";
  for (const auto& e : entries) s += e;
  return s;
}

// The InputError message of parsePipeCatalog(text), or "" when it does not throw.
std::string errorOf(const std::string& text) {
  try {
    parsePipeCatalog(text, "test/catalog.yaml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

bool contains(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

}  // namespace

TEST(PipeCatalog, ShippedCatalogueCoversTheSevenSizes) {
  const PipeCatalog cat = shipped();
  EXPECT_EQ(cat.path, pipeCatalogPath(DRILL_PIPE_POSE_SOURCE_DIR));
  std::set<std::pair<std::string, std::string>> sizes;
  for (const auto& t : cat.types) sizes.insert({t.nominal_size, t.connection});
  const std::set<std::pair<std::string, std::string>> required = {
      {"3-1/2\"", "NC38"},   {"4\"", "NC46"},         {"4-1/2\"", "NC46"},
      {"4-1/2\"", "NC50"},   {"5\"", "NC50"},         {"5-1/2\"", "5-1/2 FH"},
      {"6-5/8\"", "6-5/8 FH"}};
  for (const auto& r : required)
    EXPECT_TRUE(sizes.count(r)) << r.first << " " << r.second << " is missing";
  EXPECT_GE(cat.types.size(), required.size());
}

TEST(PipeCatalog, ShippedEntriesValidateAndMakeProfiles) {
  const PipeCatalog cat = shipped();
  for (const auto& t : cat.types) {
    SCOPED_TRACE(t.name);
    EXPECT_NO_THROW(validateDimensions(t.dims, t.name));
    for (EndLabel e : {EndLabel::kBoxEnd, EndLabel::kPinEnd}) {
      const auto profile = toolJointProfile(e, t.dims);
      EXPECT_GE(profile.size(), 8u);
      for (const auto& p : profile) EXPECT_GT(p.r, 0.0);
    }
    EXPECT_GT(t.weight, 0.0);
    EXPECT_FALSE(t.grade.empty());
    EXPECT_DOUBLE_EQ(t.dims.tube_length, 0.25);  // the lab-sample length, not a catalogue figure
  }
}

TEST(PipeCatalog, EveryFieldHasASourceOrIsEstimated) {
  const PipeCatalog cat = shipped();
  for (const auto& t : cat.types) {
    SCOPED_TRACE(t.name);
    for (const auto& f : kGeometryFields) {
      const bool estimated =
          std::find(t.estimated.begin(), t.estimated.end(), f) != t.estimated.end();
      EXPECT_TRUE(t.sources.count(f) || estimated) << f << " has no source";
    }
    for (const auto& [field, citation] : t.sources) EXPECT_GE(citation.size(), 10u) << field;
    EXPECT_TRUE(t.sources.count("tube_length"));  // a modelling choice, said so
    EXPECT_EQ(std::count(t.estimated.begin(), t.estimated.end(), "tube_length"), 0);
  }
}

TEST(PipeCatalog, NamesAreUniqueAndWellFormed) {
  const PipeCatalog cat = shipped();
  const std::vector<std::string> names = cat.names();
  EXPECT_EQ(std::set<std::string>(names.begin(), names.end()).size(), names.size());
  const std::regex name_re("[A-Za-z0-9_.-]+");
  for (const auto& n : names) {
    EXPECT_TRUE(std::regex_match(n, name_re)) << n;
    EXPECT_EQ(cat.find(n), &cat.at(n));
  }
  EXPECT_EQ(cat.find("no_such_pipe"), nullptr);
  ASSERT_NE(cat.find("5in_NC50_6.625od"), nullptr);
}

TEST(PipeCatalog, DiametersAreOrdered) {
  // Entries by nominal size; within a size and connection by tool-joint OD; per entry the
  // diameters nest: tube ID < tube OD < joint OD, joint ID < pin cone < counterbore < joint OD.
  const PipeCatalog cat = shipped();
  for (size_t i = 0; i < cat.types.size(); ++i) {
    const PipeType& t = cat.types[i];
    const ToolJointDimensions& d = t.dims;
    SCOPED_TRACE(t.name);
    EXPECT_LT(d.tube_id, d.tube_od);
    EXPECT_LT(d.tube_od, d.tool_joint_od);
    EXPECT_LT(d.tool_joint_id, d.pin_large_diameter - d.pin_length * d.pin_taper);
    EXPECT_LT(d.pin_large_diameter, d.box_counterbore_diameter);
    EXPECT_LT(d.box_counterbore_diameter, d.tool_joint_od);
    EXPECT_LT(d.pin_length, d.box_thread_depth);  // the box is deeper than the pin is long
    if (i == 0) continue;
    const PipeType& prev = cat.types[i - 1];
    EXPECT_GE(d.tube_od, prev.dims.tube_od);
    if (prev.nominal_size == t.nominal_size && prev.connection == t.connection) {
      EXPECT_GT(d.tool_joint_od, prev.dims.tool_joint_od);
    }
  }
}

TEST(PipeCatalog, Nc50CarriesTheApiSpec72Figures) {
  // API Spec 7-2 Table B.1, NC50: DL 133.35 mm, Qc 134.95 mm, LPC 114.31 mm, LBT 117.48 mm.
  const PipeCatalog cat = shipped();
  const PipeType& t = cat.at("5in_NC50_6.625od");
  EXPECT_NEAR(t.dims.pin_large_diameter, 0.13335, 1e-9);
  EXPECT_NEAR(t.dims.box_counterbore_diameter, 0.13495, 1e-9);
  EXPECT_NEAR(t.dims.pin_length, 0.11431, 1e-9);
  EXPECT_NEAR(t.dims.box_thread_depth, 0.11748, 1e-9);
  EXPECT_NEAR(t.dims.pin_taper, 1.0 / 6.0, 1e-12);
  EXPECT_NEAR(t.dims.tool_joint_od, 6.625 * 0.0254, 1e-9);
  EXPECT_NEAR(t.dims.tool_joint_id, 3.25 * 0.0254, 1e-9);
  EXPECT_TRUE(t.sources.count("pin_large_diameter"));
  EXPECT_EQ(std::count(t.estimated.begin(), t.estimated.end(), "pin_large_diameter"), 0);
}

TEST(PipeCatalog, ParsesAValidEntry) {
  const PipeCatalog cat =
      parsePipeCatalog(catalog({entry("a", {{"tube_length", "0.3"}, {"sources/tube_length",
                                                                      "\"model\""}}),
                                entry("b", {{"estimated", "[pin_tong_length]"}},
                                      {"sources/pin_tong_length"})}),
                       "t.yaml");
  ASSERT_EQ(cat.types.size(), 2u);
  EXPECT_EQ(cat.path, "t.yaml");
  EXPECT_EQ(cat.names(), (std::vector<std::string>{"a", "b"}));
  const PipeType& a = cat.at("a");
  EXPECT_EQ(a.nominal_size, "5\"");
  EXPECT_EQ(a.connection, "NC50");
  EXPECT_EQ(a.grade, "S-135");
  EXPECT_DOUBLE_EQ(a.weight, 19.5);
  EXPECT_DOUBLE_EQ(a.dims.tool_joint_od, 0.168);
  EXPECT_DOUBLE_EQ(a.dims.tube_length, 0.3);
  EXPECT_EQ(a.sources.at("tube_length"), "model");
  EXPECT_DOUBLE_EQ(cat.at("b").dims.tube_length, 0.25);  // the default
  EXPECT_EQ(cat.at("b").estimated, std::vector<std::string>{"pin_tong_length"});
}

TEST(PipeCatalog, BadGeometryNamesFileEntryAndField) {
  const std::string e = errorOf(catalog({entry("5in_NC50_6.625od", {{"tool_joint_id", "0.2"}})}));
  EXPECT_TRUE(contains(e, "test/catalog.yaml: entry \"5in_NC50_6.625od\": field tool_joint_id = "
                          "0.2 must be < tool_joint_od = 0.168"))
      << e;
  const std::string c = errorOf(catalog({entry("c", {{"box_counterbore_diameter", "0.13"}})}));
  EXPECT_TRUE(contains(c, "entry \"c\": field box_counterbore_diameter = 0.13 must be > "
                          "pin_large_diameter"))
      << c;
  const std::string p = errorOf(catalog({entry("p", {{"pin_length", "-0.1"}})}));
  EXPECT_TRUE(contains(p, "entry \"p\": field pin_length = -0.1 must be finite and > 0")) << p;
  const std::string t = errorOf(catalog({entry("t", {{"tube_od", "0.2"}})}));
  EXPECT_TRUE(contains(t, "entry \"t\": field tube_od = 0.2 must be < tool_joint_od")) << t;
}

TEST(PipeCatalog, BadEntriesAreNamed) {
  struct Case {
    std::string what, text;
    std::vector<std::string> parts;  // each must be in the message
  };
  const std::vector<Case> cases = {
      {"duplicate name", catalog({entry("a"), entry("a")}),
       {"test/catalog.yaml", "entry \"a\"", "duplicate name"}},
      {"unknown field", catalog({entry("a", {{"tube_odd", "0.127"}})}),
       {"entry \"a\"", "unknown field 'tube_odd'", "tube_od"}},
      {"field given twice", catalog({entry("a", {{"tube_id", "0.1086\n    tube_id: 0.1"}})}),
       {"entry \"a\"", "tube_id", "twice"}},
      {"missing field", catalog({entry("a", {}, {"pin_length"})}),
       {"entry \"a\"", "missing field pin_length"}},
      {"missing descriptive field", catalog({entry("a", {}, {"grade"})}),
       {"entry \"a\"", "missing field grade"}},
      {"non-number", catalog({entry("a", {{"tube_od", "five"}})}),
       {"entry \"a\"", "field tube_od", "'five' is not a number"}},
      {"non-finite", catalog({entry("a", {{"tube_id", ".nan"}})}),
       {"entry \"a\"", "field tube_id", "not finite"}},
      {"list for a number", catalog({entry("a", {{"tube_od", "[1, 2]"}})}),
       {"entry \"a\"", "field tube_od", "must be a number"}},
      {"bad weight", catalog({entry("a", {{"weight", "0"}})}),
       {"entry \"a\"", "field weight = 0 must be > 0"}},
      {"no name", catalog({entry("a"), entry("", {}, {"name"})}),
       {"test/catalog.yaml: entry 1", "missing field name"}},
      {"bad name", catalog({entry("a b")}), {"entry \"a b\"", "[A-Za-z0-9_.-]+"}},
      {"missing source", catalog({entry("a", {}, {"sources/tube_id"})}),
       {"entry \"a\"", "field tube_id has no source"}},
      {"unknown source field", catalog({entry("a", {{"sources/pin_lenght", "\"x\""}})}),
       {"entry \"a\": sources", "unknown field 'pin_lenght'"}},
      {"unknown estimated field", catalog({entry("a", {{"estimated", "[pin_lenght]"}})}),
       {"entry \"a\": estimated", "unknown field 'pin_lenght'"}},
      {"estimated twice", catalog({entry("a", {{"estimated", "[tube_id, tube_id]"}})}),
       {"entry \"a\": estimated", "tube_id", "twice"}},
      {"no sources", catalog({entry("a", {}, {"sources"})}),
       {"entry \"a\"", "missing field sources"}},
      {"sources not a map", catalog({entry("a", {{"sources", "x"}}, {"sources"})}),
       {"entry \"a\"", "field sources must be a map"}},
      {"entry not a map", "pipe_types:\n  - 3\n", {"test/catalog.yaml: entry 0", "map"}},
      {"empty catalogue", "pipe_types: []\n", {"test/catalog.yaml", "non-empty list"}},
      {"no pipe_types", "pipes: []\n", {"test/catalog.yaml", "unknown field 'pipes'"}},
      {"not a map", "- a\n- b\n", {"test/catalog.yaml", "expected a map with 'pipe_types'"}},
      {"empty file", "", {"test/catalog.yaml", "expected a map with 'pipe_types'"}},
      {"not YAML", "pipe_types: [\n", {"test/catalog.yaml", "not valid YAML"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    const std::string e = errorOf(c.text);
    ASSERT_FALSE(e.empty()) << "no error for:\n" << c.text;
    for (const auto& part : c.parts) EXPECT_TRUE(contains(e, part)) << e;
  }
}

TEST(PipeCatalog, MissingFileAndUnknownNameAreNamed) {
  try {
    loadPipeCatalog("/nonexistent/pipe_catalog.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_TRUE(contains(e.what(), "/nonexistent/pipe_catalog.yaml")) << e.what();
  }
  const PipeCatalog cat = parsePipeCatalog(catalog({entry("a"), entry("b")}), "t.yaml");
  try {
    cat.at("c");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_TRUE(contains(e.what(), "t.yaml")) << e.what();
    EXPECT_TRUE(contains(e.what(), "\"c\"")) << e.what();
    EXPECT_TRUE(contains(e.what(), "known: a, b")) << e.what();
  }
}

TEST(PipeCatalog, ValidateDimensionsNamesTheField) {
  auto errorOfDims = [](const ToolJointDimensions& d) -> std::string {
    try {
      validateDimensions(d, "dims");
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(errorOfDims(ToolJointDimensions()), "");
  ToolJointDimensions d;
  d.pin_taper = -0.1;
  EXPECT_TRUE(contains(errorOfDims(d), "dims: field pin_taper = -0.1 must be finite and >= 0"));
  d = ToolJointDimensions();
  d.tube_length = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(contains(errorOfDims(d), "dims: field tube_length = nan must be finite and > 0"));
  d = ToolJointDimensions();
  d.tool_joint_id = 0.12;  // above the pin cone's small end
  EXPECT_TRUE(contains(errorOfDims(d), "dims: field tool_joint_id = 0.12 must be < the pin cone"));
  d = ToolJointDimensions();
  d.box_counterbore_diameter = 0.17;
  EXPECT_TRUE(contains(errorOfDims(d), "field box_counterbore_diameter = 0.17 must be < "
                                       "tool_joint_od = 0.168275"));
  d = ToolJointDimensions();
  d.elevator_taper_deg = 90;
  EXPECT_TRUE(contains(errorOfDims(d), "field elevator_taper_deg = 90 must be >= 1 and < 90"));
  d.elevator_taper_deg = 0.5;
  EXPECT_TRUE(contains(errorOfDims(d), "field elevator_taper_deg = 0.5 must be >= 1 and < 90"));
  d.elevator_taper_deg = 1e-320;  // positive (denormal), yet its taper would be infinitely long
  EXPECT_TRUE(contains(errorOfDims(d), "must be >= 1 and < 90 (deg)"));
  d = ToolJointDimensions();
  d.threads = true;
  d.thread_height = 0;
  EXPECT_TRUE(contains(errorOfDims(d), "field thread_height = 0 must be finite and > 0"));
  // toolJointProfile runs the same checks.
  d = ToolJointDimensions();
  d.pin_large_diameter = 0.2;
  try {
    toolJointProfile(EndLabel::kPinEnd, d);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_TRUE(contains(e.what(), "tool joint dimensions: field pin_large_diameter = 0.2 must "
                                   "be < tool_joint_od = 0.168275"))
        << e.what();
  }
}

// -- the estimator's pipe types from the catalogue (resolvePipeTypes)

TEST(PipeTypes, DefaultsAreTheCataloguesNc50) {
  // The simulator's and the estimator's default joint (ToolJointDimensions{}) is this entry.
  const ToolJointDimensions d, c = shipped().at(EstimatorConfig().pipe_type).dims;
  EXPECT_DOUBLE_EQ(d.tube_od, c.tube_od);
  EXPECT_DOUBLE_EQ(d.tube_id, c.tube_id);
  EXPECT_DOUBLE_EQ(d.tool_joint_od, c.tool_joint_od);
  EXPECT_DOUBLE_EQ(d.tool_joint_id, c.tool_joint_id);
  EXPECT_DOUBLE_EQ(d.elevator_taper_deg, c.elevator_taper_deg);
  EXPECT_DOUBLE_EQ(d.pin_tong_length, c.pin_tong_length);
  EXPECT_DOUBLE_EQ(d.box_tong_length, c.box_tong_length);
  EXPECT_DOUBLE_EQ(d.pin_length, c.pin_length);
  EXPECT_DOUBLE_EQ(d.pin_large_diameter, c.pin_large_diameter);
  EXPECT_DOUBLE_EQ(d.pin_taper, c.pin_taper);
  EXPECT_DOUBLE_EQ(d.box_counterbore_diameter, c.box_counterbore_diameter);
  EXPECT_DOUBLE_EQ(d.box_thread_depth, c.box_thread_depth);
  EXPECT_DOUBLE_EQ(d.tube_length, c.tube_length);
}

TEST(PipeTypes, ResolvesTheStartTypeWithOverridesAndTheCandidates) {
  const PipeCatalog cat = shipped();
  EstimatorConfig c;
  c.pipe_type = "5.5in_FH_7.0od";
  c.dims.box_tong_length = 0.25;  // an override (differs from the default)
  resolvePipeTypes(&c, cat);
  EXPECT_DOUBLE_EQ(c.dims.tool_joint_od, cat.at("5.5in_FH_7.0od").dims.tool_joint_od);
  EXPECT_DOUBLE_EQ(c.dims.box_tong_length, 0.25);
  ASSERT_EQ(c.candidates.size(), cat.types.size());  // [all]
  for (const PipeCandidate& k : c.candidates) {
    if (k.name == c.pipe_type) {
      EXPECT_DOUBLE_EQ(k.dims.box_tong_length, 0.25);
    }
  }
  EstimatorConfig two;
  two.pipe_types = {"5in_NC50_6.625od", "4.5in_NC46_6.25od"};
  resolvePipeTypes(&two, cat);
  ASSERT_EQ(two.candidates.size(), 2u);
  EXPECT_EQ(two.candidates[1].name, "4.5in_NC46_6.25od");
}

TEST(PipeTypes, BadTypesStopWithTheNameAndTheField) {
  const PipeCatalog cat = shipped();
  const auto message = [&](EstimatorConfig c) {
    try {
      resolvePipeTypes(&c, cat);
      validateConfig(c);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EstimatorConfig unknown;
  unknown.pipe_types = {"5in_NC50_6.625od", "7in_NC99"};
  EXPECT_NE(message(unknown).find("7in_NC99"), std::string::npos) << message(unknown);
  EstimatorConfig start;
  start.pipe_type = "9in_XX";
  EXPECT_NE(message(start).find("9in_XX"), std::string::npos) << message(start);
  EstimatorConfig missing;
  missing.pipe_types = {"4in_NC46_6.0od"};
  EXPECT_NE(message(missing).find("not among pipe_types"), std::string::npos) << message(missing);
  EstimatorConfig empty;
  empty.pipe_types = {};
  EXPECT_NE(message(empty).find("pipe_types is empty"), std::string::npos) << message(empty);
  EstimatorConfig impossible;  // an override that breaks the geometry: ID >= OD
  impossible.dims.tool_joint_id = 0.2;
  const std::string m = message(impossible);
  EXPECT_NE(m.find("tool_joint_id"), std::string::npos) << m;
  EXPECT_NE(m.find("5in_NC50_6.625od"), std::string::npos) << m;
}
