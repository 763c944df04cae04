#include "converter.hpp"

#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>

#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <optional>
#include <set>

#include "bag_check.hpp"
#include "frame_tree.hpp"
#include "lcm_log.hpp"
#include "message_convert.hpp"
#include "ros_convert.hpp"
#include "tool_output.hpp"

namespace loopd::bag2lcm {
namespace {

/// A problem of the bag (not of one message) that ends the conversion; the text names the topic and message.
struct Fatal : std::runtime_error {
  using std::runtime_error::runtime_error;
};

enum Role : std::size_t { kScans = 0, kOdometry = 1, kStatic = 2, kGroundTruth = 3 };

std::string at(const std::string& topic, std::int64_t index) { return "topic " + topic + " message " + std::to_string(index); }

void copy_text(char* dst, std::size_t size, const std::string& s) {
  std::strncpy(dst, s.c_str(), size - 1);
  dst[size - 1] = '\0';
}

/// TF frame ids without their leading '/' ("/odom" and "odom" are one frame, as tf2 has it).
std::string frame_name(const std::string& id) { return !id.empty() && id[0] == '/' ? id.substr(1) : id; }

/// What to tell the user about a rosbag_storage error text.
std::string hint(const std::string& what) {
  if (what.find("Unknown compression") != std::string::npos) return " (this rosbag_storage reads chunks stored as none, bz2 or lz4)";
  if (what.find("Buffer Overrun") != std::string::npos) return " (the message is shorter than its type: fields are missing)";
  if (what.find("Error reading from file") != std::string::npos || what.find("Error seeking") != std::string::npos)
    return " (the file ends inside a record or a length in it is damaged)";
  return "";
}

/// Reads a message of type T, or throws Fatal naming the topic and index (wrong type, unreadable bytes).
template <typename T>
boost::shared_ptr<T> instantiate(const rosbag::MessageInstance& m, std::int64_t index, Position* where) {
  copy_text(where->topic, sizeof(where->topic), m.getTopic());
  where->index = index;
  const std::string want = ros::message_traits::DataType<T>::value(), md5 = ros::message_traits::MD5Sum<T>::value();
  if (m.getMD5Sum() != md5) {  // tf/tfMessage and tf2_msgs/TFMessage share one definition (one MD5): both read
    if (m.getDataType() != want) throw Fatal(at(m.getTopic(), index) + ": " + m.getDataType() + ", expected " + want);
    throw Fatal(at(m.getTopic(), index) + ": " + want + " of another definition (MD5 " + m.getMD5Sum() + "; this build reads " + md5 + ")");
  }
  boost::shared_ptr<T> msg;
  try {
    msg = m.instantiate<T>();
  } catch (const std::bad_alloc&) {
    throw Fatal(at(m.getTopic(), index) + ": out of memory reading it (a damaged length in the bag?)");
  } catch (const std::exception& e) {
    throw Fatal(at(m.getTopic(), index) + ": cannot read it from the bag: " + e.what() + hint(e.what()));
  }
  if (!msg) throw Fatal(at(m.getTopic(), index) + ": rosbag_storage returned no " + want);
  return msg;
}

TopicStats topic_stats(const std::string& topic, const std::string& role, const std::string& type, const std::string& channel) {
  TopicStats t;
  t.topic = topic;
  t.role = role;
  t.type = type;
  t.channel = channel;
  return t;
}

int rings_for(int max_ring) { return (max_ring + 1 + 7) / 8 * 8; }

class Converter {
 public:
  Converter(const Options& o, Position* where) : o_(o), where_(where) {}
  Report run();

 private:
  void open();
  void read_static();
  void find_frames();
  Eigen::Isometry3d extrinsic(const std::string& body, const std::string& what) const;
  void main_pass();
  void on_cloud(const rosbag::MessageInstance& m, std::int64_t index);
  void on_odometry(const rosbag::MessageInstance& m, std::int64_t index);
  void on_tf(const rosbag::MessageInstance& m, std::int64_t index);
  void on_ground_truth(const rosbag::MessageInstance& m, std::int64_t index);
  void on_imu(const rosbag::MessageInstance& m, std::int64_t index);
  void skip(Role role, const std::string& reason, std::int64_t index, const std::string& detail);
  void note(Role role, const std::string& reason, std::int64_t index, const std::string& detail);
  void write_pose(Role role, const rosbag::MessageInstance& m, const ros::Time& stamp, std::uint32_t seq, const Eigen::Isometry3d& T);
  TopicStats& stats(Role role) { return r_.topics[role]; }
  template <typename T>
  boost::shared_ptr<T> first_message(const std::string& topic);

  Options o_;
  Position* where_;
  Report r_;
  rosbag::Bag bag_;
  LogWriter writer_;
  FrameTree static_, tf_;
  std::set<std::string> moved_;                                         ///< child frames /tf has moved
  std::string child_frame_;                                             ///< the first odometry message's child_frame_id
  std::map<std::string, Eigen::Isometry3d> T_body_sensor_;              ///< ground-truth bodies' extrinsics
  std::map<std::string, std::optional<Eigen::Matrix3d>> R_sensor_imu_;  ///< by IMU frame; nullopt: not connected to the scans' frame
  std::optional<Role> imu_;                                             ///< the IMU topic's entry in r_.topics (after the others)
};

void Converter::skip(Role role, const std::string& reason, std::int64_t index, const std::string& detail) {
  TopicStats::Skip& s = stats(role).skipped[reason];
  if (s.count++ == 0) {
    s.first = "message " + std::to_string(index) + ": " + detail;
    std::cerr << (o_.progress && isatty(2) ? "\n" : "") << "bag2lcm: " << at(stats(role).topic, index) << " skipped (" << reason << "): " << detail
              << "; further messages with this problem are counted, not shown\n";
  }
}

void Converter::note(Role role, const std::string& reason, std::int64_t index, const std::string& detail) {
  TopicStats::Skip& s = stats(role).noted[reason];
  if (s.count++ == 0) {
    s.first = "message " + std::to_string(index) + ": " + detail;
    std::cerr << (o_.progress && isatty(2) ? "\n" : "") << "bag2lcm: " << at(stats(role).topic, index) << " written, " << reason << ": " << detail
              << "; further messages with this problem are counted, not shown\n";
  }
}

void Converter::open() {
  copy_text(where_->phase, sizeof(where_->phase), "opening the bag");
  const BagCheck check = check_bag_file(o_.bag);
  r_.bag_bytes = check.file_bytes;
  if (!check.ok) throw Fatal(check.error);
  try {
    bag_.open(o_.bag, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    throw Fatal(o_.bag + ": rosbag_storage cannot open it: " + e.what() + hint(e.what()));
  }
  std::set<std::string> present;
  std::string listing;
  rosbag::View all(bag_);
  for (const rosbag::ConnectionInfo* c : all.getConnections())
    if (present.insert(c->topic).second) listing += (listing.empty() ? "" : ", ") + c->topic + " (" + c->datatype + ")";
  for (Role role : {kScans, kOdometry, kGroundTruth}) {
    if (role >= r_.topics.size() || role == kStatic || (imu_ && role == *imu_)) continue;
    if (!present.count(stats(role).topic))
      throw Fatal("topic " + stats(role).topic + " is not in " + o_.bag + " (its topics: " + (listing.empty() ? "none" : listing) + ")");
  }
  if (imu_ && !present.count(stats(*imu_).topic))
    throw Fatal("topic " + stats(*imu_).topic + " is not in " + o_.bag + " (its topics: " + (listing.empty() ? "none" : listing) + ")");
}

template <typename T>
boost::shared_ptr<T> Converter::first_message(const std::string& topic) {
  rosbag::View view(bag_, rosbag::TopicQuery(topic));
  auto it = view.begin();
  if (it == view.end()) throw Fatal("topic " + topic + " holds no message");
  return instantiate<T>(*it, 0, where_);
}

void Converter::read_static() {
  copy_text(where_->phase, sizeof(where_->phase), "reading the static transforms");
  rosbag::View view(bag_, rosbag::TopicQuery(o_.tf_static_topic));
  std::int64_t index = 0;
  for (const rosbag::MessageInstance& m : view) {
    const auto msg = instantiate<tf2_msgs::TFMessage>(m, index, where_);
    ++stats(kStatic).in;
    for (const auto& t : msg->transforms) {
      Eigen::Isometry3d T;
      std::string why;
      const std::string parent = frame_name(t.header.frame_id), child = frame_name(t.child_frame_id);
      if (!to_isometry(t.transform, &T, &why) || !static_.set(parent, child, T)) {
        skip(kStatic, "bad transform", index, parent + " -> " + child + ": " + (why.empty() ? "a frame to itself" : why));
        continue;
      }
      tf_.set(parent, child, T);
    }
    ++index;
  }
}

Eigen::Isometry3d Converter::extrinsic(const std::string& body, const std::string& what) const {
  const auto T = static_.lookup(body, r_.sensor_frame);
  if (!T)
    throw Fatal("no transform between " + what + " frame '" + body + "' and the scans' frame '" + r_.sensor_frame + "' on " + o_.tf_static_topic +
                " (its transforms: " + static_.describe() + "); give --base-frame " + r_.sensor_frame +
                " when the odometry already gives the sensor's pose");
  return *T;
}

void Converter::find_frames() {
  copy_text(where_->phase, sizeof(where_->phase), "reading the first messages");
  r_.sensor_frame = frame_name(o_.sensor_frame);
  if (r_.sensor_frame.empty()) r_.sensor_frame = frame_name(first_message<sensor_msgs::PointCloud2>(o_.cloud_topic)->header.frame_id);
  if (r_.sensor_frame.empty()) throw Fatal(at(o_.cloud_topic, 0) + ": the scan's frame_id is empty; give --sensor-frame");
  r_.base_frame = frame_name(o_.base_frame);
  if (!o_.odom_topic.empty()) {
    child_frame_ = frame_name(first_message<nav_msgs::Odometry>(o_.odom_topic)->child_frame_id);
    if (r_.base_frame.empty()) r_.base_frame = child_frame_;
    if (r_.base_frame.empty()) throw Fatal(at(o_.odom_topic, 0) + ": child_frame_id is empty; give --base-frame");
  } else if (r_.base_frame.empty()) {
    r_.base_frame = frame_name(o_.tf_child);
  }
  r_.T_base_sensor = extrinsic(r_.base_frame, "the odometry's");
  r_.gt_frame = o_.gt_frame.empty() ? r_.base_frame : frame_name(o_.gt_frame);
}

void Converter::write_pose(Role role, const rosbag::MessageInstance& m, const ros::Time& stamp, std::uint32_t seq, const Eigen::Isometry3d& T) {
  StampedPose p;
  p.utime = to_utime(stamp);
  p.T_world_sensor = T;
  if (!writer_.write_message(stats(role).channel, to_utime(m.getTime()), to_message(p, seq))) throw Fatal("cannot write to " + o_.out);
  ++stats(role).out;
}

void Converter::on_cloud(const rosbag::MessageInstance& m, std::int64_t index) {
  const auto msg = instantiate<sensor_msgs::PointCloud2>(m, index, where_);
  ++stats(kScans).in;
  const std::string frame = frame_name(msg->header.frame_id);
  if (o_.sensor_frame.empty() && frame != r_.sensor_frame)
    return skip(kScans, "frame_id differs", index, "frame_id '" + frame + "', the first scan's is '" + r_.sensor_frame + "'");
  PointCloud2Options options;
  options.max_points = o_.max_points;
  options.stamp = static_cast<double>(msg->header.stamp.sec) + 1e-9 * static_cast<double>(msg->header.stamp.nsec);
  options.max_time_offset = kMaxPointTimeOffset;  // what loopd accepts in point_cloud_t.time_offset
  PointCloud2Decoded d = decode_cloud(*msg, options);
  if (!d.ok) return skip(kScans, "bad layout", index, d.error);
  r_.points_in += static_cast<std::int64_t>(d.points_in);
  r_.points_nonfinite += static_cast<std::int64_t>(d.dropped_nonfinite);
  if (d.cloud.empty()) return skip(kScans, "no finite points", index, std::to_string(d.points_in) + " points, none with finite x, y and z");
  if (!d.ring_field.empty()) {
    if (o_.rings > 0 && d.max_ring >= o_.rings)
      return skip(kScans, "ring beyond --rings", index, "ring index " + std::to_string(d.max_ring) + " with --rings " + std::to_string(o_.rings));
    r_.num_rings = o_.rings > 0 ? o_.rings : std::max(r_.num_rings, rings_for(d.max_ring));
    d.cloud.num_rings = r_.num_rings;
    r_.ring_fields.insert(d.ring_field);
  }
  if (!d.intensity_field.empty()) r_.intensity_fields.insert(d.intensity_field);
  if (!d.time_error.empty()) note(kScans, "without per-point times", index, d.time_error);
  if (!d.time.empty()) {
    d.cloud.time = std::move(d.time);
    r_.time_fields.insert(d.time_field);
    ++r_.scans_with_times;
  }
  r_.points_out += static_cast<std::int64_t>(d.cloud.size());
  const std::int64_t utime = to_utime(msg->header.stamp);
  if (!writer_.write_message(stats(kScans).channel, to_utime(m.getTime()), to_message(d.cloud, utime, msg->header.seq, r_.sensor_frame)))
    throw Fatal("cannot write to " + o_.out);
  ++stats(kScans).out;
}

void Converter::on_odometry(const rosbag::MessageInstance& m, std::int64_t index) {
  const auto msg = instantiate<nav_msgs::Odometry>(m, index, where_);
  ++stats(kOdometry).in;
  const std::string child = frame_name(msg->child_frame_id);
  if (child != child_frame_)
    return skip(kOdometry, "child_frame_id differs", index, "child_frame_id '" + child + "', the first message's is '" + child_frame_ + "'");
  Eigen::Isometry3d T_world_base;
  std::string why;
  if (!to_isometry(msg->pose.pose, &T_world_base, &why)) return skip(kOdometry, "bad pose", index, why);
  write_pose(kOdometry, m, msg->header.stamp, msg->header.seq, T_world_base * r_.T_base_sensor);
}

void Converter::on_tf(const rosbag::MessageInstance& m, std::int64_t index) {
  const auto msg = instantiate<tf2_msgs::TFMessage>(m, index, where_);
  ++stats(kOdometry).in;
  std::map<std::string, const geometry_msgs::TransformStamped*> moved;
  for (const auto& t : msg->transforms) {
    Eigen::Isometry3d T;
    std::string why;
    const std::string parent = frame_name(t.header.frame_id), child = frame_name(t.child_frame_id);
    if (!to_isometry(t.transform, &T, &why) || !tf_.set(parent, child, T)) {
      skip(kOdometry, "bad transform", index, parent + " -> " + child + ": " + (why.empty() ? "a frame to itself" : why));
      continue;
    }
    moved_.insert(child);
    moved[child] = &t;
  }
  const std::string parent = frame_name(o_.tf_parent), child = frame_name(o_.tf_child);
  const auto path = tf_.path(parent, child);
  if (!path) {
    if (moved.count(child))
      skip(kOdometry, "chain incomplete", index, "no chain " + parent + " -> " + child + " yet (transforms: " + tf_.describe() + ")");
    else
      ++stats(kOdometry).unused;
    return;
  }
  // A pose for each move of the chain's edge nearest the child frame that /tf moves (the latest of every other edge).
  const std::string* trigger = nullptr;
  for (const std::string& c : *path)
    if (moved_.count(c)) {
      trigger = &c;
      break;
    }
  const auto it = trigger ? moved.find(*trigger) : moved.end();
  if (it == moved.end()) {
    ++stats(kOdometry).unused;
    return;
  }
  write_pose(kOdometry, m, it->second->header.stamp, it->second->header.seq, *tf_.lookup(parent, child) * r_.T_base_sensor);
}

void Converter::on_ground_truth(const rosbag::MessageInstance& m, std::int64_t index) {
  geometry_msgs::Pose pose;
  ros::Time stamp;
  std::uint32_t seq = 0;
  std::string body = r_.gt_frame;
  if (m.getDataType() == "geometry_msgs/PoseStamped") {
    const auto msg = instantiate<geometry_msgs::PoseStamped>(m, index, where_);
    pose = msg->pose;
    stamp = msg->header.stamp;
    seq = msg->header.seq;
  } else if (m.getDataType() == "nav_msgs/Odometry") {
    const auto msg = instantiate<nav_msgs::Odometry>(m, index, where_);
    pose = msg->pose.pose;
    stamp = msg->header.stamp;
    seq = msg->header.seq;
    if (o_.gt_frame.empty() && !msg->child_frame_id.empty()) body = frame_name(msg->child_frame_id);
  } else {
    throw Fatal(at(m.getTopic(), index) + ": " + m.getDataType() + ", expected nav_msgs/Odometry or geometry_msgs/PoseStamped");
  }
  ++stats(kGroundTruth).in;
  if (stats(kGroundTruth).type.empty()) stats(kGroundTruth).type = m.getDataType();
  auto T = T_body_sensor_.find(body);
  if (T == T_body_sensor_.end()) T = T_body_sensor_.emplace(body, extrinsic(body, "the ground truth's")).first;
  Eigen::Isometry3d T_world_body;
  std::string why;
  if (!to_isometry(pose, &T_world_body, &why)) return skip(kGroundTruth, "bad pose", index, why);
  write_pose(kGroundTruth, m, stamp, seq, T_world_body * T->second);
}

void Converter::on_imu(const rosbag::MessageInstance& m, std::int64_t index) {
  const auto msg = instantiate<sensor_msgs::Imu>(m, index, where_);
  ++stats(*imu_).in;
  const std::string frame = frame_name(msg->header.frame_id);
  auto R = R_sensor_imu_.find(frame);
  if (R == R_sensor_imu_.end()) {
    const auto T = frame.empty() ? std::nullopt : static_.lookup(r_.sensor_frame, frame);
    R = R_sensor_imu_.emplace(frame, T ? std::optional<Eigen::Matrix3d>(T->linear()) : std::nullopt).first;
  }
  const Eigen::Vector3d w(msg->angular_velocity.x, msg->angular_velocity.y, msg->angular_velocity.z);
  const Eigen::Vector3d a(msg->linear_acceleration.x, msg->linear_acceleration.y, msg->linear_acceleration.z);
  if (!w.allFinite()) return skip(*imu_, "turn rate not finite", index, "angular_velocity " + std::to_string(w.x()) + " ...");
  if (!R->second)
    note(*imu_, "in the IMU's frame", index,
         "no transform between frame '" + frame + "' and the scans' frame '" + r_.sensor_frame + "' on " + o_.tf_static_topic +
             ": written as measured (set loopd's imu.rpy_deg to the IMU's mounting)");
  const Eigen::Matrix3d rotate = R->second ? *R->second : Eigen::Matrix3d::Identity();
  imu_t out = to_message(ImuSample{to_utime(msg->header.stamp), rotate * w}, msg->header.seq);
  const Eigen::Vector3d f = rotate * a;
  for (int i = 0; i < 3; ++i) out.linear_acceleration[i] = f[i];
  if (!writer_.write_message(stats(*imu_).channel, to_utime(m.getTime()), out)) throw Fatal("cannot write to " + o_.out);
  ++stats(*imu_).out;
}

void Converter::main_pass() {
  copy_text(where_->phase, sizeof(where_->phase), "converting");
  std::vector<std::string> topics;
  for (const TopicStats& t : r_.topics)
    if (&t != &stats(kStatic)) topics.push_back(t.topic);
  rosbag::View view(bag_, rosbag::TopicQuery(topics));
  tools::Progress bar("bag2lcm", static_cast<std::int64_t>(view.size()), o_.progress);
  std::map<std::string, std::int64_t> next_index;
  std::int64_t done = 0;
  for (const rosbag::MessageInstance& m : view) {
    const std::string& topic = m.getTopic();
    const std::int64_t index = next_index[topic]++;
    if (topic == o_.cloud_topic) {
      on_cloud(m, index);
    } else if (imu_ && topic == stats(*imu_).topic) {
      on_imu(m, index);
    } else if (topic == stats(kOdometry).topic) {
      if (o_.odom_topic.empty()) {
        on_tf(m, index);
      } else {
        on_odometry(m, index);
      }
    } else {
      on_ground_truth(m, index);
    }
    bar.update(++done);
  }
  bar.finish();
  r_.converted = true;
}

Report Converter::run() {
  const auto start = std::chrono::steady_clock::now();
  r_.bag = o_.bag;
  r_.out = o_.out;
  const bool odom = !o_.odom_topic.empty();
  r_.topics.resize(o_.gt_topic.empty() ? 3 : 4);
  stats(kScans) = topic_stats(o_.cloud_topic, "scans", "sensor_msgs/PointCloud2", o_.scan_channel);
  stats(kOdometry) = topic_stats(odom ? o_.odom_topic : o_.tf_topic, odom ? "odometry" : "odometry (TF " + o_.tf_parent + " -> " + o_.tf_child + ")",
                                 odom ? "nav_msgs/Odometry" : "tf2_msgs/TFMessage", o_.odom_channel);
  stats(kStatic) = topic_stats(o_.tf_static_topic, "static transforms", "tf2_msgs/TFMessage", "-");
  if (!o_.gt_topic.empty()) stats(kGroundTruth) = topic_stats(o_.gt_topic, "ground truth", "", o_.gt_channel);
  if (!o_.imu_topic.empty()) {  // after the others (index 3 without ground truth)
    imu_ = static_cast<Role>(r_.topics.size());
    r_.topics.push_back(topic_stats(o_.imu_topic, "gyro", "sensor_msgs/Imu", o_.imu_channel));
  }
  std::string error;
  try {
    open();
    read_static();
    find_frames();
    if (!writer_.open(o_.out, &error)) throw Fatal(error);
    main_pass();
    if (stats(kScans).out == 0) throw Fatal("no scan written: " + o_.cloud_topic + " gave none that converts (see the skipped messages)");
    if (stats(kOdometry).out == 0) throw Fatal("no odometry pose written from " + stats(kOdometry).topic + " (see the skipped messages)");
    r_.ok = true;
  } catch (const Fatal& e) {
    r_.error = e.what();
  } catch (const std::bad_alloc&) {
    r_.error = std::string("out of memory at topic ") + where_->topic + " message " + std::to_string(where_->index) + " (" + where_->phase + ")";
  } catch (const std::exception& e) {
    r_.error = std::string("reading the bag at topic ") + where_->topic + " message " + std::to_string(where_->index) + " (" + where_->phase +
               "): " + e.what() + hint(e.what());
  }
  writer_.close();
  std::error_code ec;
  if (!r_.ok) {
    std::filesystem::remove(o_.out, ec);
  } else {
    r_.out_bytes = static_cast<std::int64_t>(std::filesystem::file_size(o_.out, ec));
  }
  r_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r_;
}

}  // namespace

Report convert_bag(const Options& options, Position* where) {
  Position local;
  Converter c(options, where ? where : &local);
  return c.run();
}

}  // namespace loopd::bag2lcm
