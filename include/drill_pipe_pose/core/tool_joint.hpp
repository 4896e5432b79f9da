#pragma once
// Parametric tool-joint geometry (box-end, pin-end) as bodies of revolution, in the pipe-end frame
// (docs/conventions.md): origin on the axis at the make-up shoulder (box: the box's end face; pin:
// the shoulder from which the pin cone starts), z along the axis pointing out of the joint toward
// its mate (box: out of the box opening; pin: toward the pin nose). Metres.
//
// Defaults are the pipe catalogue's 5" NC50 (config/pipe_catalog.yaml). Models are truncated like the thesis's lab samples: a short piece of tube below
// the elevator taper, closed by a flat annulus.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/conventions.hpp"

namespace drill_pipe_pose {

/// Dimensions of one drill pipe's tool joints [m, deg]. Defaults: the pipe catalogue's
/// 5in_NC50_6.625od (config/pipe_catalog.yaml, docs/pipe_catalog.md: API Spec 7-2 Table B.1 for
/// the connection, a Grant Prideco data sheet for the joint; a test holds them equal).
struct ToolJointDimensions {
  double tube_od = 0.127;              ///< pipe body OD (5")
  double tube_id = 0.10861;            ///< pipe body ID (5" 19.5 lb/ft: 4.276")
  double tool_joint_od = 0.168275;     ///< tool-joint OD (6 5/8")
  double tool_joint_id = 0.08255;      ///< tool-joint bore (3 1/4")
  double elevator_taper_deg = 18.0;    ///< angle between the elevator taper and the axis
  double pin_tong_length = 0.2286;     ///< pin tool joint: shoulder to start of the taper (9")
  double box_tong_length = 0.3048;     ///< box tool joint: end face to start of the taper (12")
  double pin_length = 0.11431;         ///< pin cone: shoulder to nose (LPC)
  double pin_large_diameter = 0.13335; ///< pin cone diameter at the shoulder (DL)
  double pin_taper = 1.0 / 6.0;        ///< diameter change per length of the pin cone (2"/ft)
  double box_counterbore_diameter =
      0.13495;                        ///< box bore at the end face (Qc)
  double box_thread_depth = 0.11748;  ///< depth of the box's threaded cone from the end face (LBT)
  bool threads = false;             ///< model the 4 TPI thread ridges on the pin / in the box
  double threads_per_inch = 4.0;
  double thread_height = 0.0031;  ///< radial height of a thread ridge
  double tube_length = 0.25;      ///< truncated tube below the taper (lab-sample style)

  /// Axial length of the 18 deg taper from tool-joint OD to tube OD [m].
  double taperLength() const;
};

/// Checks a geometry: every length finite and > 0 (pin_taper >= 0; threads_per_inch and
/// thread_height only with `threads`), the elevator taper below 90 deg, ID < OD for the tube and
/// the joint, tube OD < joint OD, pin large diameter < joint OD, the pin cone's small end > joint
/// ID, and the box counterbore between the pin large diameter and the joint OD. Throws InputError
/// "<where>: field <name> = <value> must be ..." naming the field (and the one it is compared to).
void validateDimensions(const ToolJointDimensions& d, const std::string& where);

/// A point of a profile in the (z, r) half-plane of the pipe-end frame [m].
struct ProfilePoint {
  double z = 0.0;
  double r = 0.0;
};

/// The closed outline of the tool joint's cross-section in the (z, r) half plane (r > 0), as a
/// polygon whose revolution about z is the solid (a tube-like body: the bore is part of the
/// outline). Consecutive points are edges; the last point joins the first. Counter-clockwise with
/// z as the first and r as the second coordinate: the solid lies left of each edge, so the outward
/// normal of edge a -> b is (dr, -dz) / |(dz, dr)| in (z, r) components (profileNormal()).
/// Throws InputError from validateDimensions(dims, "tool joint dimensions") on a bad geometry.
std::vector<ProfilePoint> toolJointProfile(EndLabel end, const ToolJointDimensions& dims);

/// Outward unit normal (in (z, r) components) of the profile edge a -> b.
Eigen::Vector2d profileNormal(const ProfilePoint& a, const ProfilePoint& b);

/// A surface point with its outward unit normal, in the pipe-end frame [m].
struct OrientedPoint {
  Eigen::Vector3f p;
  Eigen::Vector3f n;
};

/// Samples the surface of revolution of `profile` uniformly by area with about `spacing` [m]
/// between neighbours (deterministic for a seed). Inner (bore) surfaces are included; use
/// `outer_only` to keep only surfaces that face away from the axis or along it (what a camera
/// outside the pipe can see).
std::vector<OrientedPoint> sampleProfileSurface(const std::vector<ProfilePoint>& profile,
                                                double spacing, uint32_t seed,
                                                bool outer_only = false);

/// A triangle mesh [m].
struct TriangleMesh {
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Eigen::Vector3i> triangles;  ///< counter-clockwise seen from outside
};

/// Revolves the profile into a closed triangle mesh with `segments` facets around the axis.
TriangleMesh revolveProfile(const std::vector<ProfilePoint>& profile, int segments = 64);

/// Writes a binary STL file; throws InputError naming the path on failure.
void writeStl(const TriangleMesh& mesh, const std::string& path);

}  // namespace drill_pipe_pose
