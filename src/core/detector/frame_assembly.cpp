// The sensor node's frame assembly (frame_assembly.hpp).

#include "drill_pipe_pose/core/detector/frame_assembly.hpp"

#include "drill_pipe_pose/core/conventions.hpp"
#include "drill_pipe_pose/core/depth_image.hpp"
#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose::detector {

FrameSources kinectSources(const std::string& camera, const std::string& prefix) {
  FrameSources s;
  s.color = prefix + conventions::colorImageTopic(camera);
  s.color_info = prefix + conventions::colorInfoTopic(camera);
  s.depth = prefix + conventions::depthImageTopic(camera);
  s.depth_info = prefix + conventions::depthInfoTopic(camera);
  return s;
}

SensorFrameData assembleSensorFrame(YoloDetector& detector, SensorFrameData f,
                                    const ColorPixels& color,
                                    const Eigen::Isometry3d* T_color_depth,
                                    const FrameAssemblyOptions& options,
                                    const FrameSources& src, cv::Mat* bgr_out) {
  checkSameCamera(f.camera, f.frame_id, src.color, f.depth_frame_id, src.depth);
  if (f.color_info.frame_id != f.frame_id)
    fail(src.color_info, ": frame_id '", f.color_info.frame_id, "' differs from ", src.color,
         "'s '", f.frame_id, "'");
  if (f.depth_info.frame_id != f.depth_frame_id)
    fail(src.depth_info, ": frame_id '", f.depth_info.frame_id, "' differs from ", src.depth,
         "'s '", f.depth_frame_id, "'");
  const PinholeCamera color_cam = PinholeCamera::fromCameraInfo(f.color_info, src.color_info);
  if (color.width != color_cam.imageWidth() || color.height != color_cam.imageHeight())
    fail(src.color, ": image is ", color.width, " x ", color.height, " px, ", src.color_info,
         " says ", color_cam.imageWidth(), " x ", color_cam.imageHeight());
  validateDepthImage(f.depth, PinholeCamera::fromCameraInfo(f.depth_info, src.depth_info),
                     src.depth);
  const cv::Mat bgr = colorImageToBgr(color.encoding, color.width, color.height, color.step,
                                      color.data, color.size, src.color);
  checkRoi(detector.config().roi, color.width, color.height, src.roi);
  f.boxes = detector.detect(bgr);
  if (options.crop_depth && T_color_depth) f = cropDepthToBoxes(f, *T_color_depth, options.crop);
  if (bgr_out) *bgr_out = bgr;
  return f;
}

}  // namespace drill_pipe_pose::detector
