#include "loopd/web/view_feed.hpp"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

namespace loopd {
namespace {

using Json = nlohmann::json;

/// Rounded to `decimals` places: the page needs millimetres, not 17 digits.
double rounded(double v, int decimals) {
  if (!std::isfinite(v)) return 0.0;
  const double scale = std::pow(10.0, decimals);
  return std::round(v * scale) / scale;
}

double yaw_of(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

void pose4(const Eigen::Isometry3d& T, float out[4]) {
  out[0] = static_cast<float>(T.translation().x());
  out[1] = static_cast<float>(T.translation().y());
  out[2] = static_cast<float>(T.translation().z());
  out[3] = static_cast<float>(yaw_of(T.rotation()));
}

Json pose_json(const float p[4]) { return Json::array({rounded(p[0], 3), rounded(p[1], 3), rounded(p[2], 3), rounded(p[3], 4)}); }

Json key_json(const KeyframeKey& k) { return Json::array({k.session, k.index}); }

/// A score, or null where the stage did not compute it (-1).
Json score(double v) { return v < 0.0 || !std::isfinite(v) ? Json() : Json(rounded(v, 4)); }

std::string decision_json(const LoopDecision& d) {
  Json j;
  j["id"] = d.event_id;
  j["q"] = key_json(d.query);
  j["m"] = key_json(d.match);
  j["a"] = d.accepted();
  j["stage"] = d.stage;
  j["reason"] = d.reason;
  j["retrieval"] = d.retrieval;
  j["t"] = rounded(static_cast<double>(d.query_utime) * 1e-6, 3);
  j["scores"] = {{"gate_distance", score(d.gate_distance)},
                 {"gate_radius", score(d.gate_radius)},
                 {"descriptor_distance", score(d.descriptor_distance)},
                 {"place_distance", score(d.place_distance)},
                 {"lcp_fraction", score(d.lcp_fraction)},
                 {"icp_residual", score(d.icp_residual)},
                 {"icp_fitness", score(d.icp_fitness)},
                 {"hungarian_consistency", score(d.hungarian_consistency)},
                 {"degeneracy", score(d.degeneracy)},
                 {"ms_total", score(d.ms_total)}};
  if (d.accepted()) {
    float p[4];
    pose4(d.T_match_query, p);
    j["T_match_query"] = pose_json(p);
  }
  return j.dump(-1, ' ', false, Json::error_handler_t::replace);
}

double percentile(std::vector<float> v, double q) {
  if (v.empty()) return 0.0;
  const std::size_t i = std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(i), v.end());
  return v[i];
}

}  // namespace

std::string base64_encode(const std::uint8_t* bytes, std::size_t size) {
  static const char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  for (std::size_t i = 0; i < size; i += 3) {
    const std::uint32_t n = (static_cast<std::uint32_t>(bytes[i]) << 16) | (i + 1 < size ? static_cast<std::uint32_t>(bytes[i + 1]) << 8 : 0u) |
                            (i + 2 < size ? static_cast<std::uint32_t>(bytes[i + 2]) : 0u);
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += i + 1 < size ? kAlphabet[(n >> 6) & 63] : '=';
    out += i + 2 < size ? kAlphabet[n & 63] : '=';
  }
  return out;
}

ViewFeed::ViewFeed(ViewFeedConfig config) : config_(config) {}

void ViewFeed::set_source(const std::string& source) {
  std::lock_guard<std::mutex> lock(mutex_);
  source_ = source;
}

std::size_t ViewFeed::keyframe_id(const KeyframeKey& key, std::int64_t utime) {
  const auto found = ids_.find(key);
  if (found != ids_.end()) return found->second;
  Keyframe k;
  k.key = key;
  k.utime = utime;
  keyframes_.push_back(k);
  ids_.emplace(key, keyframes_.size() - 1);
  return keyframes_.size() - 1;
}

bool ViewFeed::set_corrected(Keyframe& k, const Eigen::Isometry3d& T_map_sensor) {
  float p[4];
  pose4(T_map_sensor, p);
  const double moved = std::hypot(std::hypot(p[0] - k.corrected[0], p[1] - k.corrected[1]), p[2] - k.corrected[2]);
  const double turned = std::abs(std::remainder(static_cast<double>(p[3] - k.corrected[3]), 2.0 * M_PI)) * 180.0 / M_PI;
  if (k.pose_seq != 0 && moved < config_.moved_m && turned < config_.moved_deg) return false;
  std::copy(p, p + 4, k.corrected);
  k.pose_seq = next_pose_seq_++;
  return true;
}

void ViewFeed::push_cloud(const KeyframeKey& key, const Eigen::Isometry3d& T_sensor, const std::vector<Eigen::Vector3f>& cloud_sensor) {
  if (cloud_sensor.empty() || config_.clouds <= 0) return;
  // Points turned by the sensor's roll and pitch only, so the page places a cloud with a position and a yaw (which is
  // what a correction changes) and it still lies level.
  const Eigen::Matrix3d R = T_sensor.rotation();
  const Eigen::Matrix3f R_tilt = (Eigen::AngleAxisd(-yaw_of(R), Eigen::Vector3d::UnitZ()).toRotationMatrix() * R).cast<float>();
  const std::size_t stride = std::max<std::size_t>(1, (cloud_sensor.size() + config_.cloud_points - 1) / std::max(1, config_.cloud_points));
  std::vector<std::uint8_t> bytes;
  bytes.reserve(cloud_sensor.size() / stride * 6 + 6);
  for (std::size_t i = 0; i < cloud_sensor.size(); i += stride) {
    const Eigen::Vector3f p = R_tilt * cloud_sensor[i] * 100.0f;  // [cm] as int16: +-327 m
    if (!p.allFinite() || p.cwiseAbs().maxCoeff() > 32767.0f) continue;
    for (int axis = 0; axis < 3; ++axis) {
      const auto v = static_cast<std::uint16_t>(static_cast<std::int16_t>(std::lround(p[axis])));
      bytes.push_back(static_cast<std::uint8_t>(v & 0xff));
      bytes.push_back(static_cast<std::uint8_t>(v >> 8));
    }
  }
  Json j;
  j["k"] = key_json(key);
  j["p"] = base64_encode(bytes.data(), bytes.size());
  clouds_.push_back({next_seq_++, j.dump()});
  while (static_cast<int>(clouds_.size()) > config_.clouds) clouds_.pop_front();
}

void ViewFeed::add_keyframe(const KeyframeKey& key, std::int64_t utime, const Eigen::Isometry3d& T_odom_sensor, const Eigen::Isometry3d& T_map_sensor,
                            const std::vector<Eigen::Vector3f>* cloud_sensor) {
  std::lock_guard<std::mutex> lock(mutex_);
  Keyframe& k = keyframes_[keyframe_id(key, utime)];
  k.utime = utime;
  k.has_odometry = true;
  pose4(T_odom_sensor, k.odometry);
  set_corrected(k, T_map_sensor);
  if (cloud_sensor) push_cloud(key, T_odom_sensor, *cloud_sensor);
}

void ViewFeed::add_map_keyframe(const KeyframeKey& key, std::int64_t utime, const Eigen::Isometry3d& T_odom_sensor,
                                const Eigen::Isometry3d& T_map_sensor) {
  add_keyframe(key, utime, T_odom_sensor, T_map_sensor, nullptr);
}

void ViewFeed::add_cloud(const KeyframeKey& key, const Eigen::Isometry3d& T_odom_sensor, const std::vector<Eigen::Vector3f>& cloud_sensor) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (ids_.count(key)) push_cloud(key, T_odom_sensor, cloud_sensor);
}

void ViewFeed::add_decision(const LoopDecision& d) {
  std::string json = decision_json(d);
  std::lock_guard<std::mutex> lock(mutex_);
  ++decisions_;
  ++stages_[d.accepted() ? std::string("accepted") : d.stage];
  if (d.ms_total > 0.0) {
    verify_ms_.push_back(static_cast<float>(d.ms_total));
    while (static_cast<int>(verify_ms_.size()) > config_.timing_window) verify_ms_.pop_front();
  }
  if (d.accepted()) {
    accepted_.push_back({next_seq_++, std::move(json)});
  } else {
    rejected_.push_back({next_seq_++, std::move(json)});
    while (static_cast<int>(rejected_.size()) > config_.max_rejected) rejected_.pop_front();
  }
}

void ViewFeed::set_correction(std::int64_t revision, const std::vector<KeyframeKey>& keys, const std::vector<Eigen::Isometry3d>& T_map_sensor) {
  std::lock_guard<std::mutex> lock(mutex_);
  revision_ = revision;
  const std::size_t n = std::min(keys.size(), T_map_sensor.size());
  // A correction lists every keyframe in the order added: the ids of the keys the last one had are reused by
  // position, so a revision costs one comparison per keyframe, not a lookup.
  correction_ids_.resize(std::min(correction_ids_.size(), n));
  correction_keys_.resize(correction_ids_.size());
  for (std::size_t i = 0; i < n; ++i) {
    if (i >= correction_ids_.size() || correction_keys_[i] != keys[i]) {
      correction_ids_.resize(i + 1);
      correction_keys_.resize(i + 1);
      correction_ids_[i] = keyframe_id(keys[i], 0);
      correction_keys_[i] = keys[i];
    }
    set_corrected(keyframes_[correction_ids_[i]], T_map_sensor[i]);
  }
}

void ViewFeed::set_health(const std::vector<std::pair<std::string, double>>& numbers, const std::vector<std::pair<std::string, std::string>>& texts) {
  nlohmann::ordered_json j = nlohmann::ordered_json::object();  // shown in the order given
  for (const auto& [name, value] : numbers) j[name] = std::isfinite(value) ? nlohmann::ordered_json(rounded(value, 3)) : nlohmann::ordered_json();
  for (const auto& [name, text] : texts) j[name] = text;
  std::string json = j.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
  std::lock_guard<std::mutex> lock(mutex_);
  health_ = std::move(json);
  ++health_seq_;
}

ViewFeed::Counts ViewFeed::counts() const {
  std::lock_guard<std::mutex> lock(mutex_);
  Counts c;
  c.keyframes = static_cast<std::int64_t>(keyframes_.size());
  c.decisions = decisions_;
  c.accepted = static_cast<std::int64_t>(accepted_.size());
  c.revision = revision_;
  c.stages = stages_;
  return c;
}

/// What a message may still take: the first item always fits, later ones while the total stays within the budget.
struct ViewFeed::Budget {
  std::size_t max_bytes = 0, used = 0;
  bool more = false;  ///< an item did not fit: the page has more to come
  bool take(const std::string& item) {
    if (used > 0 && used + item.size() > max_bytes) {
      more = true;
      return false;
    }
    used += item.size() + 1;
    return true;
  }
};

void ViewFeed::take_keyframes(ViewCursor* cursor, Budget& budget, std::vector<std::string>* out) const {
  while (cursor->keyframes < keyframes_.size()) {
    const Keyframe& k = keyframes_[cursor->keyframes];
    Json j = Json::array({k.key.session, k.key.index, rounded(static_cast<double>(k.utime) * 1e-6, 3)});
    j.push_back(k.has_odometry ? pose_json(k.odometry) : Json());
    std::string s = j.dump();
    if (!budget.take(s)) return;
    out->push_back(std::move(s));
    ++cursor->keyframes;
  }
}

void ViewFeed::take_poses(ViewCursor* cursor, Budget& budget, std::vector<std::string>* out) const {
  std::vector<std::pair<std::int64_t, std::size_t>> moved;  // (pose_seq, id) of the poses the page has not had
  for (std::size_t id = 0; id < cursor->keyframes; ++id)
    if (keyframes_[id].pose_seq > cursor->pose_seq) moved.emplace_back(keyframes_[id].pose_seq, id);
  std::sort(moved.begin(), moved.end());
  for (const auto& [seq, id] : moved) {
    const Keyframe& k = keyframes_[id];
    std::string s = Json::array({k.key.session, k.key.index, rounded(k.corrected[0], 3), rounded(k.corrected[1], 3), rounded(k.corrected[2], 3),
                                 rounded(k.corrected[3], 4)})
                        .dump();
    if (!budget.take(s)) return;
    out->push_back(std::move(s));
    cursor->pose_seq = seq;
  }
  // Every keyframe sent and every moved pose with it: the page is at the newest pose.
  if (cursor->keyframes == keyframes_.size()) cursor->pose_seq = std::max(cursor->pose_seq, next_pose_seq_ - 1);
}

void ViewFeed::take_decisions(ViewCursor* cursor, Budget& budget, std::vector<std::string>* out) const {
  // Accepted and rejected decisions merged in the order decided.
  const auto after = [](std::int64_t seq, const Item& i) { return seq < i.seq; };
  auto a = std::upper_bound(accepted_.begin(), accepted_.end(), cursor->decision_seq, after);
  auto r = std::upper_bound(rejected_.begin(), rejected_.end(), cursor->decision_seq, after);
  while (a != accepted_.end() || r != rejected_.end()) {
    const bool take_accepted = r == rejected_.end() || (a != accepted_.end() && a->seq < r->seq);
    const Item& item = take_accepted ? *a : *r;
    if (!budget.take(item.json)) return;
    out->push_back(item.json);
    cursor->decision_seq = item.seq;
    if (take_accepted) {
      ++a;
    } else {
      ++r;
    }
  }
}

void ViewFeed::take_clouds(ViewCursor* cursor, Budget& budget, std::vector<std::string>* out) const {
  for (const Item& c : clouds_) {
    if (c.seq <= cursor->cloud_seq) continue;
    if (!budget.take(c.json)) return;
    out->push_back(c.json);
    cursor->cloud_seq = c.seq;
  }
}

std::string ViewFeed::next_message(ViewCursor* cursor, std::size_t max_bytes) const {
  std::lock_guard<std::mutex> lock(mutex_);
  Budget budget{max_bytes};
  std::string body;  // the message's lists, each ",\"name\":[...]"
  const auto list = [&](const char* name, const std::vector<std::string>& items) {
    if (items.empty()) return;
    body += std::string(",\"") + name + "\":[";
    for (std::size_t i = 0; i < items.size(); ++i) body += (i ? "," : "") + items[i];
    body += "]";
  };
  std::vector<std::string> keyframes, poses, decisions, clouds;
  take_keyframes(cursor, budget, &keyframes);
  if (!budget.more) take_poses(cursor, budget, &poses);
  if (!budget.more) take_decisions(cursor, budget, &decisions);
  if (!budget.more) take_clouds(cursor, budget, &clouds);
  list("keyframes", keyframes);
  list("poses", poses);
  list("decisions", decisions);
  list("clouds", clouds);
  if (!budget.more && health_seq_ > cursor->health_seq && !health_.empty()) {
    body += ",\"health\":" + health_;
    cursor->health_seq = health_seq_;
  }
  if (body.empty() && cursor->hello_sent) return "";

  Json head;
  head["type"] = cursor->hello_sent ? "update" : "hello";
  if (!cursor->hello_sent) head["source"] = source_;
  cursor->hello_sent = true;
  head["more"] = budget.more;
  head["revision"] = revision_;
  head["counts"] = {{"keyframes", keyframes_.size()}, {"decisions", decisions_}, {"accepted", accepted_.size()}};
  head["funnel"] = stages_;
  if (!decisions.empty()) {
    const std::vector<float> ms(verify_ms_.begin(), verify_ms_.end());
    head["verify_ms"] = {
        {"p50", rounded(percentile(ms, 0.50), 1)}, {"p95", rounded(percentile(ms, 0.95), 1)}, {"p99", rounded(percentile(ms, 0.99), 1)}};
  }
  std::string message = head.dump();
  message.pop_back();  // the closing brace: the lists follow
  return message + body + "}";
}

}  // namespace loopd
