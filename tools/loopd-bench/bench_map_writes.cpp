// loopd-bench map-writes: keyframe write throughput of a map store with N writers at once, as a fleet writes one
// PostgreSQL map: writer i opens its own store as vehicle i + 1 and writes K keyframes of a real keyframe's size
// (features of a 1500-point prepared scan, a ~100 KiB map cloud), each in its own transaction with mark_decided.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <iostream>
#include <random>
#include <thread>

#include "loopd/store/keyframe_codec.hpp"
#include "loopd/store/map_cloud_codec.hpp"
#include "loopd/store/map_store.hpp"
#include "loopd/records/vehicle_sessions.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"
#include "loopd/store/store_uri.hpp"

using namespace loopd;

namespace {

using Clock = std::chrono::steady_clock;

constexpr int kPreparedPoints = 1500;   // a voxel-downsampled HDL-64E keyframe's prepared scan
constexpr int kMapCloudPoints = 27000;  // encodes to ~100 KiB (0.01 m quantum, points spread over +-40 m)
constexpr int kDescriptorValues = 192;  // M2DP

/// Features of a synthetic keyframe: points, normals, a descriptor; random, so zstd cannot shrink them unrealistically.
std::shared_ptr<const KeyframeFeatures> synthetic_features(std::mt19937& rng) {
  std::uniform_real_distribution<float> coordinate(-40.f, 40.f), unit(-1.f, 1.f);
  auto f = std::make_shared<KeyframeFeatures>();
  for (int i = 0; i < kPreparedPoints; ++i) {
    f->prepared.points.emplace_back(coordinate(rng), coordinate(rng), 0.1f * coordinate(rng));
    f->prepared.normals.push_back({static_cast<std::int8_t>(127 * unit(rng)), static_cast<std::int8_t>(127 * unit(rng)), 127});
  }
  f->prepared.input_points = f->prepared.finite_points = 120000;
  f->descriptor = Eigen::VectorXf::Random(kDescriptorValues);
  f->ok = true;
  f->input_points = 120000;
  return f;
}

std::shared_ptr<const std::vector<std::uint8_t>> synthetic_map_cloud(std::mt19937& rng) {
  std::uniform_real_distribution<float> coordinate(-40.f, 40.f);
  PointCloud cloud;
  for (int i = 0; i < kMapCloudPoints; ++i) cloud.points.emplace_back(coordinate(rng), coordinate(rng), 0.1f * coordinate(rng));
  return std::make_shared<const std::vector<std::uint8_t>>(encode_map_cloud(cloud, 0.01));
}

struct Payload {
  std::shared_ptr<const KeyframeFeatures> features;
  std::shared_ptr<const std::vector<std::uint8_t>> map_cloud;
  std::size_t features_bytes = 0;  ///< features blob + descriptor, as stored
  std::size_t bytes = 0;           ///< with the map cloud
};

struct WriterResult {
  std::vector<double> commit_ms;  ///< begin() .. commit() of each keyframe
  double seconds = 0;             ///< the writer's whole run
  std::string error;
};

/// The first session id of `vehicle` not in the map yet (the bench may run again on the same map).
StoreResult<SessionId> fresh_session(MapStore& store, int vehicle) {
  StoreResult<SessionId> out;
  const auto sessions = store.sessions();
  out.status = sessions.status;
  out.value = std::max(vehicle, 0) * kSessionsPerVehicle;
  for (const SessionRecord& s : sessions.value) out.value = std::max(out.value, s.id + 1);
  return out;
}

StoreStatus write_keyframe(MapStore& store, const Payload& payload, SessionId session, std::int64_t index) {
  MapKeyframe k;
  k.record.key = {session, index};
  k.record.utime = 1700000000000000 + 100000 * index;
  k.record.T_odom_sensor.translation() = Eigen::Vector3d(2.0 * static_cast<double>(index), 0, 0);
  k.record.travelled = 2.0 * static_cast<double>(index);
  k.record.features = payload.features;
  k.T_map_sensor = k.record.T_odom_sensor;
  k.map_cloud = payload.map_cloud;
  if (StoreStatus s = store.begin(); !s.ok()) return s;
  StoreStatus s = store.put_keyframe(k);
  if (s.ok()) s = store.mark_decided(k.record.key);
  if (!s.ok()) {
    store.rollback();
    return s;
  }
  return store.commit();
}

WriterResult run_writer(MapStoreConfig config, int vehicle, int keyframes, const Payload& payload, std::atomic<int>& ready) {
  WriterResult out;
  config.vehicle = vehicle;
  OpenedMapStore opened = open_map_store(config);
  StoreResult<SessionId> session = opened.status.ok() ? fresh_session(*opened.store, vehicle) : StoreResult<SessionId>{opened.status, 0};
  SessionRecord record;
  record.id = session.value;
  record.sensor = "hdl64";
  record.source = "loopd-bench map-writes";
  StoreStatus s = session.ok() ? opened.store->put_session(record) : session.status;
  --ready;  // every writer connects first, then all write at once
  while (ready.load() > 0) std::this_thread::yield();
  const Clock::time_point start = Clock::now();
  for (int i = 0; i < keyframes && s.ok(); ++i) {
    const Clock::time_point t0 = Clock::now();
    s = write_keyframe(*opened.store, payload, session.value, i);
    out.commit_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  }
  out.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (!s.ok()) out.error = to_string(s.code) + std::string(": ") + s.message;
  return out;
}

void report(const std::vector<WriterResult>& results, double wall_s, int keyframes, const Payload& payload, bool json) {
  std::vector<double> all_ms;
  double per_writer = 0;
  for (const WriterResult& r : results) {
    all_ms.insert(all_ms.end(), r.commit_ms.begin(), r.commit_ms.end());
    per_writer += keyframes / std::max(1e-9, r.seconds) / static_cast<double>(results.size());
  }
  const tools::Summary latency = tools::summarize(all_ms);
  const double total = static_cast<double>(all_ms.size()) / wall_s;
  const double mb_s = total * static_cast<double>(payload.bytes) / 1e6;
  if (json) {
    tools::print_json_line({{"writers", results.size()},
                            {"keyframes_per_writer", keyframes},
                            {"keyframe_bytes", payload.bytes},
                            {"features_bytes", payload.features_bytes},
                            {"keyframes_per_s", total},
                            {"keyframes_per_s_per_writer", per_writer},
                            {"commit_p50_ms", latency.median},
                            {"commit_p95_ms", latency.p95},
                            {"commit_max_ms", latency.max},
                            {"mb_per_s", mb_s},
                            {"wall_s", wall_s}});
    return;
  }
  tools::Table t({"writers", "keyframes/s", "per writer", "commit p50 ms", "commit p95 ms", "MB/s"});
  t.add({std::to_string(results.size()), tools::fmt(total, 1), tools::fmt(per_writer, 1), tools::fmt(latency.median, 2), tools::fmt(latency.p95, 2),
         tools::fmt(mb_s, 1)});
  std::cout << t.str() << keyframes << " keyframes per writer of " << tools::fmt(static_cast<double>(payload.bytes) / 1024, 0)
            << " KiB each (features " << tools::fmt(static_cast<double>(payload.features_bytes) / 1024, 0) << " KiB, map cloud "
            << tools::fmt(static_cast<double>(payload.map_cloud->size()) / 1024, 0) << " KiB), one transaction per keyframe with mark_decided\n";
}

}  // namespace

int run_bench_map_writes(int argc, char** argv) {
  CLI::App app("loopd-bench map-writes: keyframe writes per second with N writers on one map", "loopd-bench map-writes");
  std::string uri;
  MapStoreConfig config;
  int writers = 1, keyframes = 200;
  bool json = false;
  app.add_option("--map", uri, "map URI (postgresql://... for several writers; an SQLite file with --writers 1)")->required();
  app.add_option("--writers", writers, "writers at once, each its own store as vehicle i + 1")->check(CLI::Range(1, 256));
  app.add_option("--keyframes", keyframes, "keyframes per writer")->check(CLI::PositiveNumber);
  app.add_option("--synchronous", config.synchronous, "SQLite synchronous: normal (no fsync per commit) or full (PostgreSQL's default durability)");
  app.add_flag("--json", json, "one JSON object as the last stdout line");
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;
  config.uri = uri;
  const bool postgres = names_shared_map(uri);
  if (!postgres && writers > 1) {
    std::cerr << "loopd-bench map-writes: an SQLite map has one writer (--writers 1)\n";
    return 2;
  }
  std::mt19937 rng(2026);
  Payload payload{synthetic_features(rng), synthetic_map_cloud(rng)};
  payload.features_bytes = encode_features(*payload.features).size() + 4 * kDescriptorValues;
  payload.bytes = payload.features_bytes + payload.map_cloud->size();
  std::vector<WriterResult> results(static_cast<std::size_t>(writers));
  std::atomic<int> ready{writers};
  std::vector<std::thread> threads;
  for (int i = 0; i < writers; ++i)
    threads.emplace_back([&, i] { results[static_cast<std::size_t>(i)] = run_writer(config, postgres ? i + 1 : -1, keyframes, payload, ready); });
  for (std::thread& t : threads) t.join();
  double wall_s = 0;
  for (const WriterResult& r : results) {
    if (!r.error.empty()) {
      std::cerr << "loopd-bench map-writes: " << r.error << "\n";
      return 1;
    }
    wall_s = std::max(wall_s, r.seconds);
  }
  report(results, wall_s, keyframes, payload, json);
  return 0;
}
