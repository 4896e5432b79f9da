#include "drill_pipe_pose/core/detector/dataset_writer.hpp"

#include <opencv2/imgcodecs.hpp>

#include <cmath>

#include "drill_pipe_pose/core/errors.hpp"

namespace fs = std::filesystem;

namespace drill_pipe_pose {

namespace {

void makeDirs(const fs::path& p, const std::string& tool) {
  std::error_code ec;
  fs::create_directories(p, ec);
  if (ec) fail(tool, ": cannot create the folder ", p.string(), ": ", ec.message());
}

}  // namespace

DatasetWriter::DatasetWriter(const DatasetWriterOptions& options) : o_(options) {
  if (o_.format != "voc") {
    yolo_ = fs::path(o_.out) / "yolo";
    makeDirs(yolo_ / "images" / o_.split, o_.tool);
    makeDirs(yolo_ / "labels" / o_.split, o_.tool);
    std::ofstream(yolo_ / "classes.txt") << "box_end\npin_end\n";
    yolo_list_.open(yolo_ / (o_.split + ".txt"), std::ios::app);
  }
  if (o_.format != "yolo") {
    voc_ = fs::path(o_.out) / "voc";
    makeDirs(voc_ / "JPEGImages", o_.tool);
    makeDirs(voc_ / "Annotations", o_.tool);
    makeDirs(voc_ / "ImageSets" / "Main", o_.tool);
    voc_list_.open(voc_ / "ImageSets" / "Main" / (o_.split + ".txt"), std::ios::app);
  }
}

void DatasetWriter::write(const std::string& name, const cv::Mat& img,
                          const std::vector<DetectionBox>& bs) {
  const std::vector<int> params{cv::IMWRITE_JPEG_QUALITY, o_.jpeg_quality};
  if (!yolo_.empty()) {
    const fs::path ip = yolo_ / "images" / o_.split / (name + ".jpg");
    if (!cv::imwrite(ip.string(), img, params)) fail(o_.tool, ": cannot write ", ip);
    std::ofstream l(yolo_ / "labels" / o_.split / (name + ".txt"));
    for (const DetectionBox& b : bs)
      l << static_cast<int>(b.label) << " " << (b.x_min + b.x_max) / 2 / img.cols << " "
        << (b.y_min + b.y_max) / 2 / img.rows << " " << (b.x_max - b.x_min) / img.cols << " "
        << (b.y_max - b.y_min) / img.rows << "\n";
    if (!l) fail(o_.tool, ": cannot write ", yolo_ / "labels" / o_.split / (name + ".txt"));
    yolo_list_ << fs::absolute(ip).string() << "\n";
  }
  if (!voc_.empty()) {
    const fs::path ip = voc_ / "JPEGImages" / (name + ".jpg");
    if (!yolo_.empty())
      fs::copy_file(yolo_ / "images" / o_.split / (name + ".jpg"), ip,
                    fs::copy_options::overwrite_existing);
    else if (!cv::imwrite(ip.string(), img, params))
      fail(o_.tool, ": cannot write ", ip);
    std::ofstream x(voc_ / "Annotations" / (name + ".xml"));
    x << "<annotation>\n  <folder>JPEGImages</folder>\n  <filename>" << name
      << ".jpg</filename>\n  <source><database>" << o_.source
      << "</database></source>\n  <size><width>" << img.cols << "</width><height>" << img.rows
      << "</height><depth>3</depth></size>\n  <segmented>0</segmented>\n";
    for (const DetectionBox& b : bs)
      x << "  <object>\n    <name>" << labelName(b.label)
        << "</name>\n    <pose>Unspecified</pose>\n    <truncated>0</truncated>\n"
           "    <difficult>0</difficult>\n    <bndbox><xmin>"
        << std::lround(b.x_min) + 1 << "</xmin><ymin>" << std::lround(b.y_min) + 1
        << "</ymin><xmax>" << std::lround(b.x_max) << "</xmax><ymax>" << std::lround(b.y_max)
        << "</ymax></bndbox>\n  </object>\n";
    x << "</annotation>\n";
    voc_list_ << name << "\n";
  }
  ++images_;
  for (const DetectionBox& b : bs) ++boxes_[static_cast<int>(b.label)];
}

}  // namespace drill_pipe_pose
