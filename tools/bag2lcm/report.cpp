#include "report.hpp"

#include <cmath>

#include "tool_output.hpp"

namespace loopd::bag2lcm {
namespace {

using tools::fmt;

std::string megabytes(std::int64_t bytes) { return fmt(static_cast<double>(bytes) / 1e6, 1) + " MB"; }

std::string joined(const std::set<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "'" : ", '") + n + "'";
  return out;
}

double mb_per_s(const Report& r) { return r.seconds > 0.0 ? static_cast<double>(r.bag_bytes) / 1e6 / r.seconds : 0.0; }

/// x y z [m] and roll pitch yaw [deg] of a transform.
std::string pose_text(const Eigen::Isometry3d& T) {
  const Eigen::Vector3d t = T.translation(), rpy = T.linear().eulerAngles(2, 1, 0).reverse() * 180.0 / M_PI;
  return "xyz " + fmt(t.x()) + " " + fmt(t.y()) + " " + fmt(t.z()) + " m, rpy " + fmt(rpy.x(), 2) + " " + fmt(rpy.y(), 2) + " " + fmt(rpy.z(), 2) +
         " deg";
}

}  // namespace

std::string report_table(const Report& r) {
  tools::Table topics({"topic", "role", "type", "channel", "in", "out", "skipped"});
  for (const TopicStats& t : r.topics)
    topics.add({t.topic, t.role, t.type, t.channel, std::to_string(t.in), t.channel == "-" ? "-" : std::to_string(t.out),
                std::to_string(t.skipped_total())});
  std::string out = topics.str();
  tools::Table skipped({"topic", "skipped because", "messages", "first"});
  bool any = false;
  for (const TopicStats& t : r.topics) {
    for (const auto& [reason, s] : t.skipped) skipped.add({t.topic, reason, std::to_string(s.count), s.first});
    for (const auto& [reason, s] : t.noted) skipped.add({t.topic, "(written " + reason + ")", std::to_string(s.count), s.first});
    any = any || !t.skipped.empty() || !t.noted.empty();
  }
  if (any) out += "\n" + skipped.str();
  tools::Table figures({"bag2lcm", "value"});
  figures.add({"bag", r.bag + " (" + megabytes(r.bag_bytes) + ")"});
  figures.add({"output", r.out + " (" + megabytes(r.out_bytes) + ")"});
  figures.add({"points in / written / non-finite dropped",
               std::to_string(r.points_in) + " / " + std::to_string(r.points_out) + " / " + std::to_string(r.points_nonfinite)});
  figures.add({"rings",
               r.ring_fields.empty() ? "none (no ring or laser_id field)" : std::to_string(r.num_rings) + " (fields " + joined(r.ring_fields) + ")"});
  figures.add({"intensity", r.intensity_fields.empty() ? "none (written as 0)" : "fields " + joined(r.intensity_fields)});
  figures.add(
      {"per-point times", r.time_fields.empty() ? "none" : std::to_string(r.scans_with_times) + " scans (fields " + joined(r.time_fields) + ")"});
  figures.add({"sensor frame", r.sensor_frame});
  figures.add({"odometry base frame", r.base_frame});
  figures.add({"T_base_sensor", pose_text(r.T_base_sensor)});
  figures.add({"seconds", fmt(r.seconds, 2)});
  figures.add({"MB/s (bag bytes / seconds)", fmt(mb_per_s(r), 1)});
  return out + "\n" + figures.str();
}

nlohmann::json report_json(const Report& r) {
  nlohmann::json topics = nlohmann::json::array();
  for (const TopicStats& t : r.topics) {
    nlohmann::json reasons = nlohmann::json::object();
    nlohmann::json notes = nlohmann::json::object();
    for (const auto& [reason, s] : t.skipped) reasons[reason] = {{"count", s.count}, {"first", s.first}};
    for (const auto& [reason, s] : t.noted) notes[reason] = {{"count", s.count}, {"first", s.first}};
    topics.push_back({{"topic", t.topic},
                      {"role", t.role},
                      {"type", t.type},
                      {"channel", t.channel},
                      {"in", t.in},
                      {"out", t.out},
                      {"unused", t.unused},
                      {"skipped", t.skipped_total()},
                      {"skipped_by_reason", reasons},
                      {"written_with_notes", notes}});
  }
  double T[16];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) T[4 * i + j] = r.T_base_sensor.matrix()(i, j);
  return {{"ok", r.ok},
          {"error", r.error},
          {"bag", r.bag},
          {"out", r.out},
          {"bag_bytes", r.bag_bytes},
          {"out_bytes", r.out_bytes},
          {"seconds", r.seconds},
          {"mb_per_s", mb_per_s(r)},
          {"scans", r.topics.empty() ? 0 : r.topics[0].out},
          {"poses", r.topics.size() < 2 ? 0 : r.topics[1].out},
          {"ground_truth", r.topics.size() < 4 ? 0 : r.topics[3].out},
          {"points_in", r.points_in},
          {"points_out", r.points_out},
          {"points_nonfinite", r.points_nonfinite},
          {"num_rings", r.num_rings},
          {"ring_fields", r.ring_fields},
          {"intensity_fields", r.intensity_fields},
          {"time_fields", r.time_fields},
          {"scans_with_times", r.scans_with_times},
          {"sensor_frame", r.sensor_frame},
          {"base_frame", r.base_frame},
          {"T_base_sensor", std::vector<double>(T, T + 16)},
          {"topics", topics}};
}

}  // namespace loopd::bag2lcm
