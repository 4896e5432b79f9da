#pragma once
// Declarative parameter tables: one row per parameter (name, type, unit, allowed range, one line
// of documentation, accessor to the configuration field). The default of a row is the field's
// value in a default-constructed configuration, so the struct's initialisers are the one place
// defaults live. Loading (ROS, YAML, `key=value` strings), validation and the parameter reference's
// tables all come from the table; the same rows could generate a dynamic_reconfigure `.cfg`
// (name, type, default, min, max, doc).
//
// Adding a parameter: add the field (with its default) to the configuration struct and one
// DPP_PARAM line to its table; then use the field.

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <functional>
#include <limits>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

namespace drill_pipe_pose {

/// The type of a parameter as seen from outside (ROS parameter server, YAML, command line).
enum class ParamType { kBool, kInt, kDouble, kString, kEnum, kVec3, kStringList, kDoubleList };

/// "bool", "int", "double", "string", "enum", "vec3", "string list", "number list".
const char* paramTypeName(ParamType type);
/// "a boolean (true or false)", "an integer", ..., "a list of 3 numbers [x, y, z]".
const char* paramTypeExpected(ParamType type);

/// A parameter's value; the alternative in use follows ParamType (kEnum holds the name).
using ParamValue = std::variant<bool, long long, double, std::string, Eigen::Vector3d,
                                std::vector<std::string>, std::vector<double>>;

/// Allowed range of a number (of each element of a vec3 / number list). Numbers must be finite.
struct ParamRange {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_exclusive = false;
  bool max_exclusive = false;

  bool contains(double v) const;
  /// "any", ">= 1", "> 0", "[0, 1]", "[0, 1)", "<= 5".
  std::string text() const;
};

inline ParamRange anyValue() {
  return {};
}
inline ParamRange atLeast(double min) {
  ParamRange r;
  r.min = min;
  return r;
}
/// > 0.
inline ParamRange positive() {
  ParamRange r;
  r.min = 0.0;
  r.min_exclusive = true;
  return r;
}
/// [min, max], or [min, max) with max_exclusive.
inline ParamRange between(double min, double max, bool max_exclusive = false) {
  ParamRange r;
  r.min = min;
  r.max = max;
  r.max_exclusive = max_exclusive;
  return r;
}

/// Everything about a parameter except how to reach its field.
struct ParamInfo {
  std::string name;  ///< key, '/'-separated (ROS parameter path below the node's namespace)
  ParamType type = ParamType::kDouble;
  std::string unit;                  ///< "m", "rad", "s", "px", ... ; empty: dimensionless
  ParamRange range;                  ///< numbers only
  std::vector<std::string> choices;  ///< kEnum only
  std::string doc;                   ///< one line
  /// kInt only: the limits of the field's C++ type (a value outside would be cut to another).
  long long int_min = std::numeric_limits<long long>::min();
  long long int_max = std::numeric_limits<long long>::max();
};

/// One row of a table: the description and the accessors of the configuration's field.
template <class Config>
struct ParamSpec {
  ParamInfo info;
  std::function<ParamValue(const Config&)> get;
  /// Stores a value of the row's type (already checked against the range).
  std::function<void(Config&, const ParamValue&)> set;
};

template <class Config>
using ParamTable = std::vector<ParamSpec<Config>>;

// ---- parsing and checking (all throw InputError naming `source` and the key) -----------------

/// "key = value: must be RANGE" when a number (or element) is out of range or not finite; an
/// unknown enum name lists the choices.
void checkParamValue(const ParamInfo& info, const ParamValue& value, const std::string& source);

/// Parses a command-line string: bool true/false/1/0, integers, numbers, enum names, vec3 and
/// lists as "a,b,c" or "[a, b, c]". Throws InputError naming the key and the expected type.
ParamValue parseParamString(const ParamInfo& info, const std::string& text,
                            const std::string& source);

/// Converts a YAML node (scalar or sequence) to the row's type; throws naming the key.
ParamValue parseParamYaml(const ParamInfo& info, const YAML::Node& node, const std::string& source);

/// The value as written in a table or a YAML file: true, 3, 0.25, "ours", [1, 2, 3].
std::string formatParamValue(const ParamValue& value);

/// The Markdown table of `rows` with the given defaults (one per row, formatted):
/// | parameter | type | default | unit | range | description |
std::string paramsMarkdown(const std::vector<ParamInfo>& rows,
                           const std::vector<std::string>& defaults);

/// Flattens a YAML map into '/'-separated keys: {a: {b: 1}, c: [1, 2]} -> a/b, c (sequences are
/// leaves). Throws InputError naming the file when it cannot be read, is not a map or has a key
/// that is not a name (a list or a map as a key).
std::vector<std::pair<std::string, YAML::Node>> flattenYamlFile(const std::string& path);

/// Generated sections of a text file (docs/parameters.md): the lines between
/// "<!-- BEGIN GENERATED name -->" and "<!-- END GENERATED name -->". Throws InputError when the
/// markers are missing.
std::string generatedSection(const std::string& text, const std::string& name);
/// `text` with the section's content replaced by `content`.
std::string replaceGeneratedSection(const std::string& text, const std::string& name,
                                    const std::string& content);

// ---- building rows --------------------------------------------------------------------------

namespace param_detail {
template <class T>
constexpr ParamType typeOf() {
  if constexpr (std::is_same_v<T, bool>) return ParamType::kBool;
  else if constexpr (std::is_integral_v<T>) return ParamType::kInt;
  else if constexpr (std::is_floating_point_v<T>) return ParamType::kDouble;
  else if constexpr (std::is_same_v<T, std::string>) return ParamType::kString;
  else if constexpr (std::is_same_v<T, Eigen::Vector3d>) return ParamType::kVec3;
  else if constexpr (std::is_same_v<T, std::vector<std::string>>) return ParamType::kStringList;
  else {
    static_assert(std::is_same_v<T, std::vector<double>>, "unsupported parameter type");
    return ParamType::kDoubleList;
  }
}
/// The double nearest the shortest decimal that reads back as `f` (0.45f -> 0.45, not
/// 0.449999988), so that float fields show and round-trip as written.
double floatAsDouble(float f);
template <class T>
ParamValue toValue(const T& v) {
  if constexpr (std::is_same_v<T, bool>) return v;
  else if constexpr (std::is_integral_v<T>) return static_cast<long long>(v);
  else if constexpr (std::is_same_v<T, float>) return floatAsDouble(v);
  else if constexpr (std::is_floating_point_v<T>) return static_cast<double>(v);
  else return v;
}
template <class T>
T fromValue(const ParamValue& v) {
  if constexpr (std::is_same_v<T, bool>) return std::get<bool>(v);
  else if constexpr (std::is_integral_v<T>) return static_cast<T>(std::get<long long>(v));
  else if constexpr (std::is_floating_point_v<T>) return static_cast<T>(std::get<double>(v));
  else return std::get<T>(v);
}
}  // namespace param_detail

/// A row for a bool / integer / floating / string / Vector3d / list field reached by `access`
/// (a generic lambda returning a reference to the field of a Config).
template <class Config, class Access>
ParamSpec<Config> paramField(std::string name, std::string unit, ParamRange range,
                             std::string doc, Access access) {
  using T = std::decay_t<decltype(access(std::declval<Config&>()))>;
  ParamSpec<Config> s;
  s.info.name = std::move(name);
  s.info.type = param_detail::typeOf<T>();
  s.info.unit = std::move(unit);
  s.info.range = range;
  s.info.doc = std::move(doc);
  if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
    static_assert(sizeof(T) <= sizeof(long long), "integer parameter wider than long long");
    s.info.int_min = static_cast<long long>(std::numeric_limits<T>::min());
    s.info.int_max = std::numeric_limits<T>::max() > static_cast<unsigned long long>(
                                                         std::numeric_limits<long long>::max())
                         ? std::numeric_limits<long long>::max()
                         : static_cast<long long>(std::numeric_limits<T>::max());
  }
  s.get = [access](const Config& c) { return param_detail::toValue<T>(access(c)); };
  s.set = [access](Config& c, const ParamValue& v) { access(c) = param_detail::fromValue<T>(v); };
  return s;
}

/// A row for an enum field: `to_name` / `from_name` convert (from_name may throw InputError).
template <class Config, class Access, class ToName, class FromName>
ParamSpec<Config> paramEnum(std::string name, std::vector<std::string> choices, std::string doc,
                            Access access, ToName to_name, FromName from_name) {
  ParamSpec<Config> s;
  s.info.name = std::move(name);
  s.info.type = ParamType::kEnum;
  s.info.choices = std::move(choices);
  s.info.doc = std::move(doc);
  s.get = [access, to_name](const Config& c) {
    return ParamValue(std::string(to_name(access(c))));
  };
  s.set = [access, from_name](Config& c, const ParamValue& v) {
    access(c) = from_name(std::get<std::string>(v));
  };
  return s;
}

/// The rows of `inner` (a table of a member struct) as rows of Outer, with keys prefixed by
/// `prefix` ("" keeps them).
template <class Outer, class Inner, class Access>
ParamTable<Outer> nestParams(const ParamTable<Inner>& inner, const std::string& prefix,
                             Access access) {
  ParamTable<Outer> out;
  for (const auto& r : inner) {
    ParamSpec<Outer> s;
    s.info = r.info;
    s.info.name = prefix + r.info.name;
    auto get = r.get;
    auto set = r.set;
    s.get = [get, access](const Outer& o) { return get(access(o)); };
    s.set = [set, access](Outer& o, const ParamValue& v) { set(access(o), v); };
    out.push_back(std::move(s));
  }
  return out;
}

/// One table row: DPP_PARAM(Config, "carving/vote_fraction", carving.vote_fraction, "",
/// between(0, 1), "doc").
#define DPP_PARAM(Config, key, field, unit, range, doc)                                        \
  ::drill_pipe_pose::paramField<Config>(key, unit, range, doc,                                 \
                                        [](auto& c) -> auto& { return c.field; })

// ---- operations on a table ------------------------------------------------------------------

/// The row named `key`, or nullptr.
template <class Config>
const ParamSpec<Config>* findParam(const ParamTable<Config>& table, const std::string& key) {
  for (const auto& s : table)
    if (s.info.name == key) return &s;
  return nullptr;
}

/// Throws InputError: "<source>: unknown parameter 'key'" with the closest names.
[[noreturn]] void failUnknownParam(const std::vector<std::string>& names, const std::string& key,
                                   const std::string& source);

template <class Config>
std::vector<std::string> paramNames(const ParamTable<Config>& table) {
  std::vector<std::string> n;
  for (const auto& s : table) n.push_back(s.info.name);
  return n;
}

/// Sets `key` from a string (command line); throws InputError on an unknown key, a value of the
/// wrong type or out of range, naming the key and the allowed range.
template <class Config>
void applyParamString(const ParamTable<Config>& table, Config* config, const std::string& key,
                      const std::string& value, const std::string& source) {
  const ParamSpec<Config>* s = findParam(table, key);
  if (!s) failUnknownParam(paramNames(table), key, source);
  const ParamValue v = parseParamString(s->info, value, source);
  checkParamValue(s->info, v, source);
  s->set(*config, v);
}

/// Sets every key of the YAML file `path` (nested maps give '/'-separated keys) that the table
/// has; keys listed in `other_keys` (read by someone else, e.g. the node) are skipped; any other
/// key is an error, as are values of the wrong type or out of range (InputError naming the file
/// and the key).
template <class Config>
void applyParamYaml(const ParamTable<Config>& table, Config* config, const std::string& path,
                    const std::vector<std::string>& other_keys = {}) {
  for (const auto& [key, node] : flattenYamlFile(path)) {
    const ParamSpec<Config>* s = findParam(table, key);
    if (!s) {
      bool other = false;
      for (const auto& k : other_keys) other = other || k == key;
      if (other) continue;
      std::vector<std::string> names = paramNames(table);
      names.insert(names.end(), other_keys.begin(), other_keys.end());
      failUnknownParam(names, key, path);
    }
    const ParamValue v = parseParamYaml(s->info, node, path);
    checkParamValue(s->info, v, path);
    s->set(*config, v);
  }
}

/// Checks every row's current value against its range (throws naming the key).
template <class Config>
void checkParamRanges(const ParamTable<Config>& table, const Config& config,
                      const std::string& source) {
  for (const auto& s : table) checkParamValue(s.info, s.get(config), source);
}

/// The Markdown table of `table` with the defaults of a default-constructed Config.
template <class Config>
std::string paramTableMarkdown(const ParamTable<Config>& table, const Config& defaults = Config()) {
  std::vector<ParamInfo> rows;
  std::vector<std::string> values;
  for (const auto& s : table) {
    rows.push_back(s.info);
    values.push_back(formatParamValue(s.get(defaults)));
  }
  return paramsMarkdown(rows, values);
}

}  // namespace drill_pipe_pose
