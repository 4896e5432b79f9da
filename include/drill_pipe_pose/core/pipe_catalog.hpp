#pragma once
// The drill-pipe catalogue (config/pipe_catalog.yaml, docs/pipe_catalog.md): one entry per pipe
// type (nominal size, weight, grade, connection, tool-joint OD) with its tool-joint geometry in SI
// units and, per field, the source of its figure or a mark that the figure is estimated.
//
//   pipe_types:
//     - name: 5in_NC50_6.625od        # unique, [A-Za-z0-9_.-]+
//       nominal_size: '5"'
//       weight: 19.5                  # [lb/ft] nominal
//       grade: S-135
//       connection: NC50
//       tube_od: 0.127                # every ToolJointDimensions field it sets [m, deg]
//       ...
//       sources: {tube_od: "...", ...}   # field -> citation
//       estimated: [pin_tong_length]     # fields whose figure is estimated (optional)
//
// Required per entry: name, nominal_size, weight, grade, connection, sources and the twelve
// geometry fields tube_od, tube_id, tool_joint_od, tool_joint_id, elevator_taper_deg,
// pin_tong_length, box_tong_length, pin_length, pin_large_diameter, pin_taper,
// box_counterbore_diameter, box_thread_depth. Optional: tube_length (default 0.25), threads,
// threads_per_inch, thread_height, estimated. Every geometry field an entry sets needs a source
// or an `estimated` mark. ROS-free.

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "drill_pipe_pose/core/tool_joint.hpp"

namespace drill_pipe_pose {

struct PipeType {
  std::string name, nominal_size, connection, grade;
  double weight = 0;                            ///< [lb/ft] nominal
  ToolJointDimensions dims;                     ///< every field from the entry
  std::map<std::string, std::string> sources;  ///< field -> citation
  std::vector<std::string> estimated;           ///< fields whose figure was estimated
};

struct PipeCatalog {
  std::string path;
  std::vector<PipeType> types;  ///< in file order
  /// The entry named `name`, or nullptr.
  const PipeType* find(const std::string& name) const;
  /// The entry named `name`; throws InputError naming the catalogue file, the name and the known
  /// names.
  const PipeType& at(const std::string& name) const;
  std::vector<std::string> names() const;
};

/// Loads and validates a catalogue file. Throws InputError naming the file, the entry (by name,
/// or by index when it has none) and the field: unreadable file, not YAML, no entries, duplicate
/// names, unknown or duplicate fields, a missing required field, a non-number, a geometry that
/// validateDimensions() rejects, a field with neither a source nor an `estimated` mark.
PipeCatalog loadPipeCatalog(const std::string& path);
/// The same from YAML text; `where` names it in errors (and becomes PipeCatalog::path).
PipeCatalog parsePipeCatalog(const std::string& yaml_text, const std::string& where);

/// Every numeric ToolJointDimensions field with its key (the catalogue's and tool_joint/*'s
/// names), the required ones first.
std::vector<std::pair<std::string, double ToolJointDimensions::*>> toolJointNumericFields();

/// The path of the package's catalogue (config/pipe_catalog.yaml), given the package source dir.
std::string pipeCatalogPath(const std::string& package_source_dir);

}  // namespace drill_pipe_pose
