#include "drill_pipe_pose/core/detector/review_sheet.hpp"

#include <yaml-cpp/yaml.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "drill_pipe_pose/core/errors.hpp"

namespace drill_pipe_pose {

cv::Mat reviewCrop(const cv::Mat& bgr, const DetectionBox& b, int height) {
  const double w = b.x_max - b.x_min, h = b.y_max - b.y_min;
  const double mx = std::max(24.0, w), my = std::max(24.0, h);
  const int x0 = std::max(0, static_cast<int>(std::floor(b.x_min - mx)));
  const int y0 = std::max(0, static_cast<int>(std::floor(b.y_min - my)));
  const int x1 = std::min(bgr.cols, static_cast<int>(std::ceil(b.x_max + mx)) + 1);
  const int y1 = std::min(bgr.rows, static_cast<int>(std::ceil(b.y_max + my)) + 1);
  if (x1 <= x0 || y1 <= y0) return cv::Mat(height, height, CV_8UC3, cv::Scalar(114, 114, 114));
  const double s = double(height) / (y1 - y0);
  cv::Mat crop;
  cv::resize(bgr(cv::Rect(x0, y0, x1 - x0, y1 - y0)), crop,
             cv::Size(std::max(1, static_cast<int>(std::lround((x1 - x0) * s))), height), 0, 0,
             s > 1 ? cv::INTER_NEAREST : cv::INTER_AREA);
  const cv::Scalar colour = b.label == EndLabel::kBoxEnd ? cv::Scalar(255, 80, 0)
                                                         : cv::Scalar(0, 0, 255);
  cv::rectangle(crop, cv::Point2d((b.x_min + 0.5 - x0) * s, (b.y_min + 0.5 - y0) * s),
                cv::Point2d((b.x_max + 0.5 - x0) * s, (b.y_max + 0.5 - y0) * s), colour, 1);
  return crop;
}

namespace {

std::string html(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else if (c == '"') o += "&quot;";
    else o += c;
  }
  return o;
}

}  // namespace

size_t writeReviewSheet(const std::string& dir, std::vector<ReviewEntry> entries,
                        double review_doubt, const std::string& title) {
  std::stable_sort(entries.begin(), entries.end(), [](const ReviewEntry& a, const ReviewEntry& b) {
    return a.item.doubt > b.item.doubt;
  });
  const size_t to_review = static_cast<size_t>(std::count_if(
      entries.begin(), entries.end(),
      [&](const ReviewEntry& e) { return e.item.doubt >= review_doubt; }));
  const std::string path = dir + "/index.html";
  std::ofstream f(path);
  if (!f) fail("cannot write the review sheet '", path, "'");
  f << std::fixed;
  f << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>" << html(title)
    << "</title>\n<style>body{font-family:sans-serif;margin:1em}"
       "figure{display:inline-block;margin:4px;padding:4px;border:2px solid #ccc;"
       "vertical-align:top;font-size:11px;max-width:260px}"
       "figure.doubt{border-color:#e80}figure.rej{opacity:.35;border-color:#d00}"
       "figcaption{word-break:break-all}</style></head><body>\n";
  f << "<h1>" << html(title) << "</h1>\n<p>" << entries.size() << " labels, sorted by doubt. "
    << "<b>Look at the first " << to_review << "</b> (doubt &ge; " << std::setprecision(2)
    << review_doubt << ", orange frame; about " << std::setprecision(1)
    << to_review * 2.0 / 60.0
    << " min at 2 s a crop); the checks accepted the rest. Tick a crop whose box is wrong "
       "(wrong end, not on the joint, not tight), then save the list and rerun label_from_poses "
       "with <code>--rejected rejected.yaml</code>: every image with a rejected label is left "
       "out. To fix a pose instead, add it to corrections.yaml (stamp and pose under each "
       "crop) and rerun with <code>--corrections</code>: it relabels every camera at once.</p>\n"
    << "<p><button onclick=\"save()\">save rejected.yaml</button> <span id=\"n\">0</span> "
       "rejected</p>\n";
  for (const ReviewEntry& e : entries) {
    const LabelItem& it = e.item;
    const Eigen::Vector3d t = e.T_world_end.translation();
    const Eigen::Quaterniond q(e.T_world_end.linear());
    f << "<figure class=\"" << (it.doubt >= review_doubt ? "doubt" : "") << "\"><label><img src=\""
      << html(e.crop) << "\"><br><input type=\"checkbox\" value=\"" << html(it.id)
      << "\" onchange=\"mark(this)\"> reject</label><figcaption>" << html(it.id)
      << "<br>doubt " << std::setprecision(2) << it.doubt << " | " << labelName(it.box.label)
      << " | visible " << std::setprecision(0) << 100 * it.visible_fraction << " % | agree "
      << 100 * it.agree_fraction << " % | cameras " << it.agreeing_cameras << "/"
      << it.in_view_cameras << " | spread " << std::setprecision(1) << it.spread_px << " px"
      << " | sigma " << std::setprecision(1) << it.position_sigma * 1e3
      << " mm, " << std::setprecision(2) << it.axis_sigma_deg << " deg"
      << (it.corrected ? " | corrected" : "") << "<br>stamp " << std::setprecision(6)
      << e.pose_stamp_ns * 1e-9 << ", translation [" << std::setprecision(4) << t.x() << ", "
      << t.y() << ", " << t.z() << "], rotation [" << q.x() << ", " << q.y() << ", " << q.z()
      << ", " << q.w() << "]</figcaption></figure>\n";
  }
  f << "<script>\nfunction mark(c){c.closest('figure').classList.toggle('rej',c.checked);"
       "document.getElementById('n').textContent="
       "document.querySelectorAll('input:checked').length;}\n"
       "function save(){let t='# label_from_poses --rejected: labels a person rejected\\n"
       "rejected:\\n';document.querySelectorAll('input:checked').forEach(c=>{t+='  - '+c.value+"
       "'\\n';});if(!document.querySelector('input:checked'))t+='  []\\n';"
       "const a=document.createElement('a');a.href=URL.createObjectURL(new Blob([t],"
       "{type:'text/yaml'}));a.download='rejected.yaml';a.click();}\n</script>\n</body></html>\n";
  if (!f) fail("cannot write the review sheet '", path, "'");
  return to_review;
}

std::set<std::string> loadRejected(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    fail("rejected labels '", path, "': ", e.what());
  }
  std::set<std::string> out;
  const YAML::Node list = root["rejected"];
  if (!list) fail("rejected labels '", path, "': no key 'rejected' (expected rejected: [id, ...])");
  if (list.IsNull()) return out;
  if (!list.IsSequence()) fail("rejected labels '", path, "': 'rejected' is not a list");
  for (size_t i = 0; i < list.size(); ++i) {
    if (!list[i].IsScalar()) fail("rejected labels '", path, "': entry ", i, " is not an id");
    out.insert(list[i].as<std::string>());
  }
  return out;
}

namespace {

std::vector<double> numbers(const YAML::Node& n, size_t count, const std::string& where) {
  if (!n || !n.IsSequence() || n.size() != count)
    fail(where, ": expected a list of ", count, " numbers");
  std::vector<double> v;
  for (size_t i = 0; i < count; ++i) {
    double x = 0;
    try {
      x = n[i].as<double>();
    } catch (const YAML::Exception&) {
      fail(where, "[", i, "]: not a number");
    }
    if (!std::isfinite(x)) fail(where, "[", i, "] = ", x, " is not finite");
    v.push_back(x);
  }
  return v;
}

}  // namespace

std::vector<PoseSample> loadCorrections(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    fail("corrections '", path, "': ", e.what());
  }
  const YAML::Node list = root["corrections"];
  if (!list || !list.IsSequence())
    fail("corrections '", path, "': expected a list under the key 'corrections'");
  std::vector<PoseSample> out;
  for (size_t i = 0; i < list.size(); ++i) {
    const YAML::Node& c = list[i];
    const std::string where = "corrections '" + path + "', entry " + std::to_string(i);
    if (!c.IsMap()) fail(where, ": not a map");
    for (const auto& kv : c) {
      const std::string k = kv.first.as<std::string>();
      if (k != "stamp" && k != "end" && k != "translation" && k != "rotation")
        fail(where, ": unknown key '", k, "' (stamp, end, translation, rotation)");
    }
    PoseSample p;
    p.corrected = true;
    double stamp = -1.0;
    try {
      if (c["stamp"]) stamp = c["stamp"].as<double>();
    } catch (const YAML::Exception&) {
    }
    if (!(stamp > 0)) fail(where, ": stamp must be a positive number [s]");
    p.stamp_ns = static_cast<int64_t>(std::llround(stamp * 1e9));
    const std::string end = c["end"] ? c["end"].as<std::string>("") : "";
    if (end == "box_end") p.label = EndLabel::kBoxEnd;
    else if (end == "pin_end") p.label = EndLabel::kPinEnd;
    else fail(where, ": end = '", end, "' must be box_end or pin_end");
    const auto t = numbers(c["translation"], 3, where + ", translation");
    const auto q = numbers(c["rotation"], 4, where + ", rotation");
    const Eigen::Quaterniond qq(q[3], q[0], q[1], q[2]);
    if (std::abs(qq.norm() - 1.0) > 1e-3)
      fail(where, ", rotation: quaternion norm ", qq.norm(), " is not 1");
    p.T_world_end = Eigen::Isometry3d::Identity();
    p.T_world_end.linear() = qq.normalized().toRotationMatrix();
    p.T_world_end.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
    p.cameras = 0;
    out.push_back(p);
  }
  return out;
}

}  // namespace drill_pipe_pose
