// Declarative parameter tables: parsing, range checks and Markdown (param_table.hpp).

#include "drill_pipe_pose/core/param_table.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

const char* paramTypeName(ParamType type) {
  switch (type) {
    case ParamType::kBool: return "bool";
    case ParamType::kInt: return "int";
    case ParamType::kDouble: return "double";
    case ParamType::kString: return "string";
    case ParamType::kEnum: return "enum";
    case ParamType::kVec3: return "vec3";
    case ParamType::kStringList: return "string list";
    case ParamType::kDoubleList: return "number list";
  }
  return "?";
}

namespace {

/// The shortest text (at most 10 significant digits) that reads back as `v`.
std::string number(double v) {
  std::string t;
  for (int digits = 1; digits <= 10; ++digits) {
    std::ostringstream s;
    s.precision(digits);
    s << v;
    t = s.str();
    if (std::strtod(t.c_str(), nullptr) == v) break;
  }
  return t;
}

}  // namespace

const char* paramTypeExpected(ParamType type) {
  switch (type) {
    case ParamType::kBool: return "a boolean (true or false)";
    case ParamType::kInt: return "an integer";
    case ParamType::kDouble: return "a number";
    case ParamType::kString: return "a string";
    case ParamType::kEnum: return "a name";
    case ParamType::kVec3: return "a list of 3 numbers [x, y, z]";
    case ParamType::kStringList: return "a list of strings";
    case ParamType::kDoubleList: return "a list of numbers";
  }
  return "?";
}

namespace {

/// "source: " or "" when there is no source.
std::string from(const std::string& source) {
  return source.empty() ? std::string() : source + ": ";
}

[[noreturn]] void failType(const ParamInfo& info, const std::string& text,
                           const std::string& source) {
  fail(from(source), "parameter ", info.name, " = ", text, ": expected ",
       paramTypeExpected(info.type));
}

std::string trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t");
  if (a == std::string::npos) return "";
  return s.substr(a, s.find_last_not_of(" \t") - a + 1);
}

bool parseDouble(const std::string& text, double* v) {
  const std::string t = trim(text);
  if (t.empty()) return false;
  char* end = nullptr;
  errno = 0;
  *v = std::strtod(t.c_str(), &end);
  return errno == 0 && end == t.c_str() + t.size();
}

bool parseInteger(const std::string& text, long long* v) {
  const std::string t = trim(text);
  if (t.empty()) return false;
  char* end = nullptr;
  errno = 0;
  *v = std::strtoll(t.c_str(), &end, 10);
  return errno == 0 && end == t.c_str() + t.size();
}

bool parseBool(const std::string& text, bool* v) {
  const std::string t = trim(text);
  if (t == "true" || t == "True" || t == "1") *v = true;
  else if (t == "false" || t == "False" || t == "0") *v = false;
  else return false;
  return true;
}

/// "a,b,c" or "[a, b, c]" -> {"a", "b", "c"}; "" or "[]" -> {}.
std::vector<std::string> splitList(const std::string& text) {
  std::string t = trim(text);
  if (t.size() >= 2 && t.front() == '[' && t.back() == ']') t = t.substr(1, t.size() - 2);
  std::vector<std::string> out;
  if (trim(t).empty()) return out;
  std::stringstream ss(t);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(trim(item));
  return out;
}

std::vector<double> numbers(const ParamInfo& info, const std::vector<std::string>& items,
                            const std::string& text, const std::string& source) {
  std::vector<double> v(items.size());
  for (size_t i = 0; i < items.size(); ++i)
    if (!parseDouble(items[i], &v[i])) failType(info, text, source);
  return v;
}

void checkNumber(const ParamInfo& info, double v, const std::string& what,
                 const std::string& source) {
  if (info.range.contains(v)) return;
  const std::string r = info.range.text();
  fail(from(source), "parameter ", what, " = ", v, ": must be ",
       r == "any" ? std::string("finite") : (r[0] == '[' || r[0] == '(') ? "in " + r : r);
}

std::string yamlText(const YAML::Node& node) {
  YAML::Emitter e;
  e.SetSeqFormat(YAML::Flow);
  e << node;
  return e.c_str();
}

}  // namespace

double param_detail::floatAsDouble(float f) {
  if (!std::isfinite(f)) return f;
  for (int digits = 1; digits <= 9; ++digits) {
    std::ostringstream s;
    s.precision(digits);
    s << f;
    const double d = std::strtod(s.str().c_str(), nullptr);
    if (static_cast<float>(d) == f) return d;
  }
  return f;
}

bool ParamRange::contains(double v) const {
  if (!std::isfinite(v)) return false;
  if (min_exclusive ? !(v > min) : !(v >= min)) return false;
  if (max_exclusive ? !(v < max) : !(v <= max)) return false;
  return true;
}

std::string ParamRange::text() const {
  const bool has_min = std::isfinite(min), has_max = std::isfinite(max);
  if (has_min && has_max)
    return std::string(min_exclusive ? "(" : "[") + number(min) + ", " + number(max) +
           (max_exclusive ? ")" : "]");
  if (has_min) return std::string(min_exclusive ? "> " : ">= ") + number(min);
  if (has_max) return std::string(max_exclusive ? "< " : "<= ") + number(max);
  return "any";
}

void checkParamValue(const ParamInfo& info, const ParamValue& value, const std::string& source) {
  if (const auto* i = std::get_if<long long>(&value)) {
    checkNumber(info, static_cast<double>(*i), info.name, source);
    if (*i < info.int_min || *i > info.int_max)
      fail(from(source), "parameter ", info.name, " = ", *i, ": out of the range of its integer ",
           "type (", info.int_min, " to ", info.int_max, ")");
  } else if (const auto* d = std::get_if<double>(&value)) {
    checkNumber(info, *d, info.name, source);
  } else if (const auto* v = std::get_if<Eigen::Vector3d>(&value)) {
    for (int k = 0; k < 3; ++k)
      checkNumber(info, (*v)[k], info.name + "[" + std::to_string(k) + "]", source);
  } else if (const auto* l = std::get_if<std::vector<double>>(&value)) {
    for (size_t k = 0; k < l->size(); ++k)
      checkNumber(info, (*l)[k], info.name + "[" + std::to_string(k) + "]", source);
  } else if (const auto* s = std::get_if<std::string>(&value)) {
    if (info.type == ParamType::kEnum &&
        std::find(info.choices.begin(), info.choices.end(), *s) == info.choices.end()) {
      std::string choices;
      for (const auto& c : info.choices) choices += (choices.empty() ? "" : ", ") + c;
      fail(from(source), "parameter ", info.name, " = \"", *s, "\": must be one of ", choices);
    }
  }
}

ParamValue parseParamString(const ParamInfo& info, const std::string& text,
                            const std::string& source) {
  switch (info.type) {
    case ParamType::kBool: {
      bool b;
      if (!parseBool(text, &b)) failType(info, text, source);
      return b;
    }
    case ParamType::kInt: {
      long long i;
      if (!parseInteger(text, &i)) failType(info, text, source);
      return i;
    }
    case ParamType::kDouble: {
      double d;
      if (!parseDouble(text, &d)) failType(info, text, source);
      return d;
    }
    case ParamType::kString:
    case ParamType::kEnum: return trim(text);
    case ParamType::kVec3: {
      const auto v = numbers(info, splitList(text), text, source);
      if (v.size() != 3) failType(info, text, source);
      return Eigen::Vector3d(v[0], v[1], v[2]);
    }
    case ParamType::kStringList: return splitList(text);
    case ParamType::kDoubleList: return numbers(info, splitList(text), text, source);
  }
  failType(info, text, source);
}

ParamValue parseParamYaml(const ParamInfo& info, const YAML::Node& node,
                          const std::string& source) {
  const std::string text = yamlText(node);
  const bool scalar = node.IsScalar();
  switch (info.type) {
    case ParamType::kBool:
    case ParamType::kInt:
    case ParamType::kDouble:
    case ParamType::kString:
    case ParamType::kEnum:
      if (!scalar) failType(info, text, source);
      if (info.type == ParamType::kBool) {
        // YAML 1.1 booleans only (as the ROS parameter server reads them), never 1 / 0.
        const std::string& t = node.Scalar();
        if (t == "true" || t == "True" || t == "TRUE") return true;
        if (t == "false" || t == "False" || t == "FALSE") return false;
        failType(info, text, source);
      }
      return parseParamString(info, node.Scalar(), source);
    case ParamType::kVec3:
    case ParamType::kStringList:
    case ParamType::kDoubleList: {
      if (!node.IsSequence()) failType(info, text, source);
      std::vector<std::string> items;
      for (const auto& e : node) {
        if (!e.IsScalar()) failType(info, text, source);
        items.push_back(e.Scalar());
      }
      if (info.type == ParamType::kStringList) return items;
      const auto v = numbers(info, items, text, source);
      if (info.type == ParamType::kDoubleList) return v;
      if (v.size() != 3) failType(info, text, source);
      return Eigen::Vector3d(v[0], v[1], v[2]);
    }
  }
  failType(info, text, source);
}

std::string formatParamValue(const ParamValue& value) {
  struct Visitor {
    std::string operator()(bool b) const { return b ? "true" : "false"; }
    std::string operator()(long long i) const { return std::to_string(i); }
    std::string operator()(double d) const { return number(d); }
    std::string operator()(const std::string& s) const { return "\"" + s + "\""; }
    std::string operator()(const Eigen::Vector3d& v) const {
      return "[" + number(v.x()) + ", " + number(v.y()) + ", " + number(v.z()) + "]";
    }
    std::string operator()(const std::vector<std::string>& l) const {
      std::string s;
      for (const auto& e : l) s += (s.empty() ? "" : ", ") + e;
      return "[" + s + "]";
    }
    std::string operator()(const std::vector<double>& l) const {
      std::string s;
      for (double e : l) s += (s.empty() ? "" : ", ") + number(e);
      return "[" + s + "]";
    }
  };
  return std::visit(Visitor(), value);
}

std::string paramsMarkdown(const std::vector<ParamInfo>& rows,
                           const std::vector<std::string>& defaults) {
  std::ostringstream s;
  s << "| parameter | type | default | unit | range | description |\n";
  s << "|---|---|---|---|---|---|\n";
  auto cell = [](std::string t) {
    for (size_t p = 0; (p = t.find('|', p)) != std::string::npos; p += 2) t.replace(p, 1, "\\|");
    return t;
  };
  for (size_t i = 0; i < rows.size(); ++i) {
    const ParamInfo& r = rows[i];
    std::string range;
    if (r.type == ParamType::kEnum) {
      for (const auto& c : r.choices) range += (range.empty() ? "" : ", ") + ("`" + c + "`");
    } else if (r.type == ParamType::kInt || r.type == ParamType::kDouble ||
               r.type == ParamType::kVec3 || r.type == ParamType::kDoubleList) {
      range = r.range.text();
    }
    s << "| `" << r.name << "` | " << paramTypeName(r.type) << " | "
      << cell(i < defaults.size() ? defaults[i] : "") << " | " << cell(r.unit) << " | "
      << cell(range) << " | " << cell(r.doc) << " |\n";
  }
  return s.str();
}

namespace {
void flatten(const YAML::Node& node, const std::string& prefix,
             std::vector<std::pair<std::string, YAML::Node>>* out) {
  if (node.IsMap() && !node.IsNull()) {
    for (const auto& kv : node)
      flatten(kv.second, prefix.empty() ? kv.first.as<std::string>()
                                        : prefix + "/" + kv.first.as<std::string>(),
              out);
    return;
  }
  out->emplace_back(prefix, node);
}

/// Edit distance, for "did you mean".
size_t distance(const std::string& a, const std::string& b) {
  std::vector<size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] != b[j - 1])});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}
}  // namespace

std::vector<std::pair<std::string, YAML::Node>> flattenYamlFile(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    fail(path, ": cannot read YAML: ", e.what());
  }
  std::vector<std::pair<std::string, YAML::Node>> out;
  if (root.IsNull()) return out;
  if (!root.IsMap()) fail(path, ": expected a map of parameters at the top level");
  try {
    flatten(root, "", &out);
  } catch (const YAML::Exception& e) {  // a key that is a list or a map: `{a: 1}: 2`
    fail(path, ": every key must be a name: ", e.what());
  }
  return out;
}

namespace {
/// [begin, end) of the section's content (after the BEGIN line, up to the END line).
std::pair<size_t, size_t> sectionBounds(const std::string& text, const std::string& name) {
  const std::string begin = "<!-- BEGIN GENERATED " + name + " -->\n";
  const std::string end = "<!-- END GENERATED " + name + " -->";
  const size_t b = text.find(begin);
  if (b == std::string::npos) fail("no line '", begin.substr(0, begin.size() - 1), "'");
  const size_t e = text.find(end, b);
  if (e == std::string::npos)
    fail("no line '", end, "' after '", begin.substr(0, begin.size() - 1), "'");
  return {b + begin.size(), e};
}
}  // namespace

std::string generatedSection(const std::string& text, const std::string& name) {
  const auto [b, e] = sectionBounds(text, name);
  return text.substr(b, e - b);
}

std::string replaceGeneratedSection(const std::string& text, const std::string& name,
                                    const std::string& content) {
  const auto [b, e] = sectionBounds(text, name);
  return text.substr(0, b) + content + text.substr(e);
}

void failUnknownParam(const std::vector<std::string>& names, const std::string& key,
                      const std::string& source) {
  std::vector<std::pair<size_t, std::string>> near;
  for (const auto& n : names) near.emplace_back(distance(key, n), n);
  std::sort(near.begin(), near.end());
  std::string hint;
  for (size_t i = 0; i < near.size() && i < 3 && near[i].first <= key.size() / 2 + 2; ++i)
    hint += (hint.empty() ? "" : ", ") + near[i].second;
  fail(from(source), "unknown parameter '", key, "'",
       hint.empty() ? std::string() : " (did you mean " + hint + "?)");
}

}  // namespace drill_pipe_pose
