#pragma once
// The review sheet of label_from_poses: one HTML page of crops, each with its generated box,
// sorted by doubt (labelDoubt), most doubtful first, so that a person looks at the top of the
// page and accepts the rest. Ticking a crop marks it rejected; the page's button saves the ticked
// ids as rejected.yaml, which label_from_poses --rejected reads (an image with a rejected label
// is left out of the dataset). Corrected poses (corrections.yaml) relabel every camera at once;
// each crop shows the stamp and the pose to start a correction from.

#include <opencv2/core.hpp>

#include <set>
#include <string>
#include <vector>

#include "drill_pipe_pose/core/detector/pose_labels.hpp"

namespace drill_pipe_pose {

struct ReviewEntry {
  LabelItem item;
  std::string crop;   ///< crop file, relative to the sheet's folder
  std::string image;  ///< the dataset image's name
  Eigen::Isometry3d T_world_end = Eigen::Isometry3d::Identity();  ///< the pose labelled from
  int64_t pose_stamp_ns = 0;
};

/// The crop of one label: the box with a margin of its own size (at least 24 px), the box drawn,
/// scaled to `height` px.
cv::Mat reviewCrop(const cv::Mat& bgr, const DetectionBox& box, int height = 160);

/// Labels at or above this doubt are the ones a person must look at (the sheet says how many).
/// Seed 110 (thesis_vertical, thesis_angled, stabbing, 4 s): correct labels' spread reaches
/// 0.046 of the box side, so none of the 220 is to review; with 30 % of the poses moved 2-10 cm
/// (--perturb 0.3) every bad box (IoU < 0.5, gates open) and every poor one (IoU < 0.7, gates on)
/// is at or above 0.1 (docs/results.md).
constexpr double kDefaultReviewDoubt = 0.1;

/// Writes DIR/index.html for the entries (sorted by doubt, most doubtful first). Returns how many
/// are at or above `review_doubt`. Throws InputError naming the file when it cannot be written.
size_t writeReviewSheet(const std::string& dir, std::vector<ReviewEntry> entries,
                        double review_doubt, const std::string& title);

/// The ids of a rejected.yaml (`rejected: [id, ...]`). Throws InputError naming the file.
std::set<std::string> loadRejected(const std::string& path);

/// The corrected poses of a corrections.yaml:
///   corrections:
///     - {stamp: 1.533333, end: box_end, translation: [x, y, z], rotation: [qx, qy, qz, qw]}
/// stamp [s, ROS time] of the moment (a crop's stamp), the pose in the world frame. Throws
/// InputError naming the file, the entry and the field.
std::vector<PoseSample> loadCorrections(const std::string& path);

}  // namespace drill_pipe_pose
