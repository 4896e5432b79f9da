#pragma once
// Labels from 3D poses (assisted annotation): the detector's training boxes of every camera's
// colour image from the estimator's pose of each tool joint, checked against the depth images.
// ROS-free (label_from_poses reads the bags; README "Teach the detector a new rig").
//
// For one camera image and one end: the tool-joint model's outer surface (the detector's box
// region: end face or pin nose to the end of the elevator taper, docs/conventions.md
// "SensorFrame") is sampled, placed at the pose, back faces and points hidden by the joint itself
// dropped, and each remaining point compared with the measured depth at its depth pixel:
//   - agree: measured within depth_tolerance of the model;
//   - occluded: measured nearer by more than depth_tolerance (something in front of the joint);
//   - behind: measured farther (the camera sees through where the model is: a wrong pose, or the
//     silhouette's edge);
//   - no depth: no reading (dropout) or outside the depth image.
// The box is the colour-image bounds of the points that are not occluded: a partly hidden joint
// gets the box of its visible part, as the simulator's true boxes (and a person) draw it.
//
// Per image (labelImages), every end the poses report needs a decision, or the image is left out
// (an unlabelled joint in a kept image would teach the detector that it is background):
//   - the pose (interpolated to the image's stamp) passes the covariance gate, was fitted from at
//     least min_pose_cameras cameras, and at least min_agreeing_cameras cameras' depth confirms
//     it at that moment; a person's corrected pose passes without these checks;
//   - then: not in the image (no label), hidden (visible share below hidden_fraction: no label),
//     or boxed (visible share at least min_visible_fraction); in between, or a box smaller than
//     min_box_area, or this camera's own depth contradicting the pose: the image is left out.

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/camera_model.hpp"
#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/depth_image.hpp"
#include "drill_pipe_pose/core/sensor_frame.hpp"
#include "drill_pipe_pose/core/tool_joint.hpp"

namespace drill_pipe_pose {

/// The labeller's parameters. First look on seed 115 (thesis_vertical, 2 s: the rostest's
/// recording); the gates below were then chosen on seed 110 (scripts/bench_labels --seeds 110
/// --keep: thesis_vertical, thesis_angled, stabbing, 4 s, every check but the one measured
/// switched off; docs/results.md "Labels from 3D poses"); the targets are reported on seeds
/// 111-114.
struct LabelParams {
  /// [m] largest position standard deviation of the pose (sqrt of the largest eigenvalue of the
  /// covariance's position block). The estimator's covariance is conservative (it includes the
  /// rig calibration): its poses report 10-13 mm while their error is 3-5 mm. Seed 110, gates
  /// open: correct labels (IoU >= 0.7) came from poses reporting up to 26.4 mm (stabbing's pin
  /// end); 30 mm leaves out only poses the estimator itself doubts. The depth agreement below is
  /// the check that catches wrong poses.
  double max_position_sigma = 0.030;
  /// [deg] largest standard deviation of the axis direction (the rotation block projected
  /// perpendicular to the end's axis; roll is never observable). Not a measure of the error:
  /// seed 110, gates open, correct labels came from poses reporting up to 78 deg (thesis_angled's
  /// box end, every label of it IoU >= 0.7), and the 15 deg gate first chosen on seed 115 left
  /// most of thesis_angled out. 90 deg leaves out only a degenerate covariance.
  double max_axis_sigma_deg = 90.0;
  /// Cameras that contributed points to the pose (PipeEnd.cameras): one camera's points alone
  /// leave the depth along its rays poorly fixed.
  int min_pose_cameras = 2;
  /// Cameras whose own depth confirms the pose at the image's moment (an independent check of
  /// the pose in each camera: confirmsPose).
  int min_agreeing_cameras = 2;
  /// [m] a model point agrees with the measured depth within this: the Kinect v2's noise at 7 m
  /// (12.7 mm head-on, more at grazing incidence) plus the worn joints' up to 1 mm smaller radius.
  double depth_tolerance = 0.03;
  /// A camera confirms a pose when at least this share of the model points it measures (agree or
  /// behind) agree, from at least min_agree_points points. At the silhouette's edges the depth
  /// pixel often holds the background; a pose 2 cm off leaves well under half.
  double agree_fraction = 0.6;
  int min_agree_points = 20;
  /// The image's own camera must measure at least this share agreeing (when it measures
  /// min_agree_points), or the image is left out. Lower than agree_fraction: seed 110's correct
  /// labels go down to 0.29 (thesis_angled's tilted box end).
  double own_agree_fraction = 0.2;
  /// Share of the end's in-image model points not occluded. Below hidden_fraction the end is
  /// hidden (no label, image kept); at least min_visible_fraction: boxed; in between: doubtful,
  /// the image is left out.
  double hidden_fraction = 0.1;
  double min_visible_fraction = 0.3;
  /// [px^2] a box smaller than this is too small to be sure of (the simulator's detector boxes
  /// ends of 12 px and more): the image is left out.
  double min_box_area = 60.0;
  /// [m] the model's sample spacing: 3 mm is a third of a colour pixel at 5 m.
  double point_spacing = 0.003;
  /// [m] a model point farther than the model's own nearest point on its depth pixel by this is
  /// hidden by the joint itself (and not compared with the measured depth).
  double self_occlusion_tolerance = 0.01;
  /// [s] frames of other cameras within this of an image's stamp are the same moment for the
  /// camera agreement (30 Hz cameras with their own phase: half a period).
  double sync_window = 0.017;
  /// [s] a pose is interpolated between two estimates at most this far apart, or taken from the
  /// nearest estimate within half of it.
  double max_pose_gap = 0.1;
  /// [s] a corrected pose applies to each camera's image nearest its stamp, within this.
  double correction_window = 0.05;
};

/// An end's pose as the estimator (or a person) gives it, world frame.
struct PoseSample {
  int64_t stamp_ns = 0;  ///< time of the data behind the pose (cycle stamp - age)
  EndLabel label = EndLabel::kBoxEnd;
  Eigen::Isometry3d T_world_end = Eigen::Isometry3d::Identity();
  /// 6x6 over (x, y, z [m], rotation about world x, y, z [rad]), PipeEnd's convention.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  int cameras = 0;         ///< cameras that contributed points
  bool corrected = false;  ///< a person's pose: passes the gates
  /// The two estimates the pose was taken between (PoseTrack::at; both T_world_end when there is
  /// no neighbour): how far they are apart in an image is the doubt's pose spread.
  Eigen::Isometry3d T_prev = Eigen::Isometry3d::Identity(), T_next = Eigen::Isometry3d::Identity();
};

/// The covariance gate's figures.
struct PoseGate {
  bool ok = false;
  double position_sigma = 0;  ///< [m]
  double axis_sigma_deg = 0;  ///< [deg]
  std::string why;            ///< why not ok
};
PoseGate gatePose(const PoseSample& pose, const LabelParams& params);

/// One end's model: outer surface points of the box region in the pipe-end frame.
struct LabelModel {
  EndLabel label = EndLabel::kBoxEnd;
  std::vector<OrientedPoint> points;
  double z_min = 0, z_max = 0;  ///< [m] the region's extent along the end's axis
};
LabelModel makeLabelModel(EndLabel label, const ToolJointDimensions& dims, double spacing);

/// One camera image: the colour camera, the depth camera and image (optional: width 0 means no
/// occlusion check), and where they are.
struct LabelView {
  std::string camera;
  int64_t stamp_ns = 0;
  PinholeCamera color;
  PinholeCamera depth;
  DepthImage depth_image;
  Eigen::Isometry3d T_world_color = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_world_depth = Eigen::Isometry3d::Identity();
};

/// One end projected into one camera image.
struct EndInView {
  int in_image = 0;  ///< front-facing model points, not hidden by the joint itself, in the image
  int agree = 0, occluded = 0, behind = 0, no_depth = 0;  ///< of those (sum: in_image)
  bool has_box = false;
  DetectionBox box;  ///< [px] bounds of the points that are not occluded, clipped to the image
  double spread_px = 0;  ///< [px] poseSpreadPx of the pose in this image
  double visibleFraction() const { return in_image ? 1.0 - double(occluded) / in_image : 0.0; }
  /// Of the points the depth measures (agree + behind), the share that agree (1 if none).
  double agreeFraction() const {
    return agree + behind ? double(agree) / (agree + behind) : 1.0;
  }
  double boxArea() const {
    return has_box ? double(box.x_max - box.x_min) * double(box.y_max - box.y_min) : 0.0;
  }
};

/// Projects `model` at T_world_end into `view` (see the file comment).
EndInView projectEnd(const LabelModel& model, const Eigen::Isometry3d& T_world_end,
                     const LabelView& view, const LabelParams& params);

/// [px] How far the region's axis end points (model z_min and z_max on the axis) move in the
/// colour image between the two estimates around the pose (PoseSample::T_prev, T_next): the
/// estimator's own frame-to-frame disagreement, seen in this image.
double poseSpreadPx(const LabelModel& model, const PoseSample& pose, const LabelView& view);

/// Whether this camera's depth confirms the pose: enough measured points, most of them agreeing.
bool confirmsPose(const EndInView& e, const LabelParams& params);

/// The poses of one end over time; at(): interpolated (position linear, rotation slerp) between
/// the estimates around the stamp, covariance the larger of the two (element-wise), cameras the
/// fewer.
class PoseTrack {
 public:
  void add(const PoseSample& s) { samples_[s.stamp_ns] = s; }
  std::optional<PoseSample> at(int64_t stamp_ns, double max_gap) const;
  bool empty() const { return samples_.empty(); }
  size_t size() const { return samples_.size(); }

 private:
  std::map<int64_t, PoseSample> samples_;
};

/// One generated label.
struct LabelItem {
  std::string id;  ///< <camera>_<stamp_ns>_<end>: unique, for review
  DetectionBox box;
  double doubt = 0;  ///< labelDoubt
  double visible_fraction = 0, agree_fraction = 0, position_sigma = 0, axis_sigma_deg = 0;
  double spread_px = 0;  ///< EndInView::spread_px
  /// Cameras within the sync window that confirm the pose, that measure it (at least
  /// min_agree_points model points with a depth reading at or behind the model), that see it.
  int agreeing_cameras = 0, measured_cameras = 0, in_view_cameras = 0;
  bool corrected = false;
};

/// One camera image's outcome.
struct ImageLabels {
  std::string camera;
  int64_t stamp_ns = 0;
  bool keep = false;   ///< goes into the dataset (possibly with no labels: every end absent)
  std::string why;     ///< why it is left out
  std::vector<LabelItem> labels;
  std::array<std::optional<PoseSample>, kNumEnds> poses;  ///< used, for the review sheet
};

/// The measured parts of a label's doubt, each in [0, 1] (1: as bad as it gets):
///   - disagree: of this camera's model points that the depth measures, the share it sees through
///     (measured behind the model by more than depth_tolerance);
///   - unconfirmed: of the cameras that measure the end at this moment, the share whose depth does
///     not confirm the pose (1 when none measures it);
///   - spread: poseSpreadPx over the box's smaller side (the estimates around the image disagree
///     by a box's width: 1).
struct DoubtParts {
  double disagree = 0, unconfirmed = 0, spread = 0;
};
DoubtParts doubtParts(const LabelItem& item);

/// Doubt of a label in [0, 1]: its spread (0 for a person's corrected pose); the review sheet
/// sorts by it. Chosen by measurement on seed 110 with perturbed poses (scripts/bench_labels
/// --seeds 110 --perturb 0.3, gates open, docs/results.md): the spread ranked the 3 bad boxes
/// (IoU < 0.5) of 218 crops 4th, 5th and 7th; this camera's disagreement ranked them 27th, 41st
/// and 122nd (correct labels reach 0.71 unperturbed, on thesis_angled), the unconfirmed share
/// 28th, 29th and 107th (correct labels reach 0.6 unperturbed). The covariance is several times
/// the error and not tied to it.
double labelDoubt(const LabelItem& item, const LabelParams& params);

/// Labels every view from the poses. `views` are the projections of every end into every image
/// (projections[v][e], nullopt: no pose for that end at that image); `poses[v][e]` the pose used.
/// `expected[e]`: the end appears in the recording (label_from_poses: the estimator reported it
/// with a pose that passes gatePose in at least --min-end-share of its cycles): an image needs a
/// decision for it. Counts every reason an image is left out.
struct LabelInputs {
  std::vector<std::string> cameras;  ///< per view
  std::vector<int64_t> stamps_ns;    ///< per view
  std::vector<std::array<std::optional<PoseSample>, kNumEnds>> poses;
  std::vector<std::array<EndInView, kNumEnds>> projections;
  std::array<bool, kNumEnds> expected{{true, true}};
};
std::vector<ImageLabels> labelImages(const LabelInputs& in, const LabelParams& params);

/// The id of a label: <camera>_<stamp_ns>_<end>.
std::string labelId(const std::string& camera, int64_t stamp_ns, EndLabel end);

}  // namespace drill_pipe_pose
