#include "drill_pipe_pose/core/pipe_catalog.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

namespace {

using Field = double ToolJointDimensions::*;

/// The geometry fields an entry must set, in ToolJointDimensions order.
const std::vector<std::pair<std::string, Field>>& requiredFields() {
  static const std::vector<std::pair<std::string, Field>> f = {
      {"tube_od", &ToolJointDimensions::tube_od},
      {"tube_id", &ToolJointDimensions::tube_id},
      {"tool_joint_od", &ToolJointDimensions::tool_joint_od},
      {"tool_joint_id", &ToolJointDimensions::tool_joint_id},
      {"elevator_taper_deg", &ToolJointDimensions::elevator_taper_deg},
      {"pin_tong_length", &ToolJointDimensions::pin_tong_length},
      {"box_tong_length", &ToolJointDimensions::box_tong_length},
      {"pin_length", &ToolJointDimensions::pin_length},
      {"pin_large_diameter", &ToolJointDimensions::pin_large_diameter},
      {"pin_taper", &ToolJointDimensions::pin_taper},
      {"box_counterbore_diameter", &ToolJointDimensions::box_counterbore_diameter},
      {"box_thread_depth", &ToolJointDimensions::box_thread_depth}};
  return f;
}

/// Numeric geometry fields an entry may set (ToolJointDimensions' defaults otherwise).
const std::vector<std::pair<std::string, Field>>& optionalFields() {
  static const std::vector<std::pair<std::string, Field>> f = {
      {"threads_per_inch", &ToolJointDimensions::threads_per_inch},
      {"thread_height", &ToolJointDimensions::thread_height},
      {"tube_length", &ToolJointDimensions::tube_length}};
  return f;
}

const std::set<std::string> kDescriptive = {"name",       "nominal_size", "weight",   "grade",
                                            "connection", "sources",      "estimated"};

/// Geometry fields (the keys `sources` and `estimated` may name).
std::set<std::string> geometryFieldNames() {
  std::set<std::string> names = {"threads"};
  for (const auto& f : requiredFields()) names.insert(f.first);
  for (const auto& f : optionalFields()) names.insert(f.first);
  return names;
}

std::string joined(const std::set<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

/// A map's keys: each a string, each once, each known; a typo must not pass silently.
void checkKeys(const YAML::Node& map, const std::set<std::string>& known,
               const std::string& where) {
  std::set<std::string> seen;
  for (const auto& kv : map) {
    if (!kv.first.IsScalar()) fail(where, ": a field name is not a string");
    const std::string key = kv.first.Scalar();
    if (!known.count(key)) fail(where, ": unknown field '", key, "' (known: ", joined(known), ")");
    if (!seen.insert(key).second) fail(where, ": field ", key, " is given twice");
  }
}

std::string text(const YAML::Node& node, const std::string& key, const std::string& where) {
  if (!node) fail(where, ": missing field ", key);
  if (!node.IsScalar() || node.Scalar().empty())
    fail(where, ": field ", key, " must be a non-empty string");
  return node.Scalar();
}

double number(const YAML::Node& node, const std::string& key, const std::string& where) {
  if (!node) fail(where, ": missing field ", key);
  if (!node.IsScalar()) fail(where, ": field ", key, " must be a number");
  double v;
  try {
    v = node.as<double>();
  } catch (const YAML::Exception&) {
    fail(where, ": field ", key, " = '", node.Scalar(), "' is not a number");
  }
  if (!std::isfinite(v)) fail(where, ": field ", key, " = ", v, " is not finite");
  return v;
}

PipeType parseEntry(const YAML::Node& e, size_t index, const std::string& file) {
  const std::string at_index = file + ": entry " + std::to_string(index);
  if (!e.IsMap()) fail(at_index, ": expected a map with name, nominal_size, ... (see the header)");
  std::set<std::string> known = geometryFieldNames();
  known.insert(kDescriptive.begin(), kDescriptive.end());
  if (!e["name"]) fail(at_index, " (no name): missing field name");
  PipeType t;
  t.name = text(e["name"], "name", at_index);
  const std::string where = file + ": entry \"" + t.name + "\"";
  static const std::regex name_re("[A-Za-z0-9_.-]+");
  if (!std::regex_match(t.name, name_re))
    fail(where, ": field name must match [A-Za-z0-9_.-]+");
  checkKeys(e, known, where);
  t.nominal_size = text(e["nominal_size"], "nominal_size", where);
  t.connection = text(e["connection"], "connection", where);
  t.grade = text(e["grade"], "grade", where);
  t.weight = number(e["weight"], "weight", where);
  if (!(t.weight > 0)) fail(where, ": field weight = ", t.weight, " must be > 0");

  // Geometry: the required fields, the optional ones over ToolJointDimensions' defaults.
  std::set<std::string> given;
  for (const auto& f : requiredFields()) {
    t.dims.*f.second = number(e[f.first], f.first, where);
    given.insert(f.first);
  }
  for (const auto& f : optionalFields())
    if (e[f.first]) {
      t.dims.*f.second = number(e[f.first], f.first, where);
      given.insert(f.first);
    }
  if (const YAML::Node th = e["threads"]) {
    try {
      t.dims.threads = th.as<bool>();
    } catch (const YAML::Exception&) {
      fail(where, ": field threads must be true or false");
    }
    given.insert("threads");
  }
  validateDimensions(t.dims, where);

  // Provenance: a citation per field, the estimated ones listed; every field set has one of them.
  const std::set<std::string> geometry = geometryFieldNames();
  std::set<std::string> citable = geometry;
  citable.insert("weight");
  const YAML::Node src = e["sources"];
  if (!src) fail(where, ": missing field sources (field -> citation)");
  if (!src.IsMap()) fail(where, ": field sources must be a map from field name to citation");
  checkKeys(src, citable, where + ": sources");
  for (const auto& kv : src)
    t.sources[kv.first.Scalar()] = text(kv.second, kv.first.Scalar(), where + ": sources");
  if (const YAML::Node est = e["estimated"]) {
    if (!est.IsSequence()) fail(where, ": field estimated must be a list of field names");
    for (size_t i = 0; i < est.size(); ++i) {
      const std::string f = text(est[i], "estimated[" + std::to_string(i) + "]", where);
      if (!citable.count(f))
        fail(where, ": estimated: unknown field '", f, "' (known: ", joined(citable), ")");
      for (const auto& g : t.estimated)
        if (g == f) fail(where, ": estimated: field ", f, " is listed twice");
      t.estimated.push_back(f);
    }
  }
  for (const auto& f : given) {
    const bool is_estimated =
        std::find(t.estimated.begin(), t.estimated.end(), f) != t.estimated.end();
    if (!t.sources.count(f) && !is_estimated)
      fail(where, ": field ", f,
           " has no source (cite it under 'sources' or, if its figure is estimated, list it "
           "under 'estimated')");
  }
  return t;
}

}  // namespace

const PipeType* PipeCatalog::find(const std::string& name) const {
  for (const auto& t : types)
    if (t.name == name) return &t;
  return nullptr;
}

const PipeType& PipeCatalog::at(const std::string& name) const {
  if (const PipeType* t = find(name)) return *t;
  std::string known;
  for (const auto& n : names()) known += (known.empty() ? "" : ", ") + n;
  fail(path, ": no pipe type \"", name, "\" (known: ", known, ")");
}

std::vector<std::string> PipeCatalog::names() const {
  std::vector<std::string> n;
  for (const auto& t : types) n.push_back(t.name);
  return n;
}

PipeCatalog parsePipeCatalog(const std::string& yaml_text, const std::string& where) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    fail(where, ": not valid YAML: ", e.what());
  }
  PipeCatalog cat;
  cat.path = where;
  try {
    if (!root.IsMap()) fail(where, ": expected a map with 'pipe_types' (a list of entries)");
    checkKeys(root, {"pipe_types"}, where);
    const YAML::Node list = root["pipe_types"];
    if (!list || !list.IsSequence() || list.size() == 0)
      fail(where, ": 'pipe_types' must be a non-empty list of entries");
    for (size_t i = 0; i < list.size(); ++i) {
      PipeType t = parseEntry(list[i], i, where);
      for (size_t j = 0; j < cat.types.size(); ++j)
        if (cat.types[j].name == t.name)
          fail(where, ": entry \"", t.name, "\": duplicate name (entries ", j, " and ", i, ")");
      cat.types.push_back(std::move(t));
    }
  } catch (const YAML::Exception& e) {  // a node of an unexpected kind deep inside
    fail(where, ": ", e.what());
  }
  return cat;
}

PipeCatalog loadPipeCatalog(const std::string& path) {
  std::ifstream f(path);
  if (!f) fail(path, ": the pipe catalogue cannot be read");
  std::stringstream ss;
  ss << f.rdbuf();
  return parsePipeCatalog(ss.str(), path);
}

std::vector<std::pair<std::string, double ToolJointDimensions::*>> toolJointNumericFields() {
  auto all = requiredFields();
  all.insert(all.end(), optionalFields().begin(), optionalFields().end());
  return all;
}

std::string pipeCatalogPath(const std::string& package_source_dir) {
  return package_source_dir + "/config/pipe_catalog.yaml";
}

}  // namespace drill_pipe_pose
