// loopd-bench retrieval: PlaceIndex::query time (median / p95 ms) among N Scan Context descriptors built from simulated
// town scans, each copy perturbed (random column shift = yaw, +-2 steps of bin noise), and the index's bytes.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <iostream>
#include <random>

#include "loopd/base/stopwatch.hpp"
#include "loopd/descriptor/scan_context.hpp"
#include "loopd/retrieval/place_index.hpp"
#include "loopd/sim/drive.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"

using namespace loopd;

namespace {

/// `base` with its columns turned by a random shift and +-2 quantisation steps of noise on occupied bins.
PlaceDescriptor perturbed(const PlaceDescriptor& base, std::mt19937& rng) {
  const int nr = base.num_rings, ns = base.num_sectors;
  std::uniform_int_distribution<int> shift(0, ns - 1), noise(-2, 2);
  const int k = shift(rng);
  PlaceDescriptor d = base;
  for (int s = 0; s < ns; ++s)
    for (int r = 0; r < nr; ++r) {
      const int v = base.bins[static_cast<std::size_t>(s * nr + r)];
      d.bins[static_cast<std::size_t>(((s + k) % ns) * nr + r)] = static_cast<std::uint8_t>(v == 0 ? 0 : std::clamp(v + noise(rng), 1, 255));
    }
  detail::finish_place_descriptor(d);
  return d;
}

std::vector<PlaceDescriptor> simulated_descriptors(int num_scans, const std::string& sensor, bool progress_on) {
  DriveConfig config;
  config.sensor = sensor;
  config.num_scans = num_scans * 5;  // every 5th scan (5 m apart): distinct places and the town's revisits
  config.seed = 2026;
  const Drive drive = make_drive(config);
  std::vector<PlaceDescriptor> out;
  tools::Progress progress("simulate", num_scans, progress_on);
  for (int i = 0; i < num_scans; ++i) {
    PlaceDescriptor d = compute_place_descriptor(drive.simulate(5 * i, 0));
    if (d.ok) out.push_back(std::move(d));
    progress.update(i + 1);
  }
  progress.finish();
  return out;
}

/// The table, or with `json` one JSON object as the last line.
void report(const PlaceIndex& index, std::size_t scans, const RetrievalConfig& config, const std::vector<double>& total_ms,
            const std::vector<double>& ring_ms, const std::vector<double>& full_ms, std::size_t found, const std::string& sensor, int views,
            bool json) {
  const int queries = static_cast<int>(total_ms.size());
  const tools::Summary total = tools::summarize(total_ms), ring = tools::summarize(ring_ms), full = tools::summarize(full_ms);
  const double ring_share = ring.mean / std::max(1e-12, ring.mean + full.mean);
  if (json) {
    tools::print_json_line({{"entries", index.size()},
                            {"scans", scans},
                            {"queries", queries},
                            {"views", views},
                            {"k", config.k},
                            {"ring_candidates", config.ring_candidates},
                            {"median_ms", total.median},
                            {"p95_ms", total.p95},
                            {"max_ms", total.max},
                            {"ring_key_median_ms", ring.median},
                            {"full_distance_median_ms", full.median},
                            {"ring_key_share", ring_share},
                            {"mean_candidates_returned", static_cast<double>(found) / queries},
                            {"index_bytes", index.bytes()},
                            {"peak_rss_bytes", tools::peak_rss_bytes()}});
  } else {
    tools::Table t({"entries", "queries", "median ms", "p95 ms", "max ms", "ring-key ms (share)", "full distance ms", "index MB"});
    t.add({std::to_string(index.size()), std::to_string(queries), tools::fmt(total.median), tools::fmt(total.p95), tools::fmt(total.max),
           tools::fmt(ring.median) + " (" + tools::fmt(100 * ring_share, 0) + " %)", tools::fmt(full.median),
           tools::fmt(static_cast<double>(index.bytes()) / 1e6, 1)});
    std::cout << t.str() << views << " view(s) per query; built from " << scans << " simulated " << sensor << " town scans; k " << config.k
              << ", ring_candidates " << config.ring_candidates << ", a filter rejecting a quarter of the keys; "
              << tools::fmt(static_cast<double>(found) / queries, 2) << " candidates returned per query\n";
  }
}

}  // namespace

int run_bench_retrieval(int argc, char** argv) {
  CLI::App app("loopd-bench retrieval: ms per PlaceIndex query", "loopd-bench retrieval");
  int entries = 100000, scans = 300, queries = 1000, views = 3;
  std::string sensor = "hdl64";
  RetrievalConfig config;
  bool json = false;
  app.add_option("--entries", entries, "descriptors in the index")->check(CLI::PositiveNumber);
  app.add_option("--scans", scans, "simulated town scans the entries are perturbed copies of")->check(CLI::PositiveNumber);
  app.add_option("--queries", queries, "timed queries")->check(CLI::PositiveNumber);
  app.add_option("--sensor", sensor, "lidar model of the simulated scans");
  app.add_option("--views", views, "views per query (loopd queries 3: the scan and retrieval.lateral_shift to either side)")->check(CLI::Range(1, 8));
  app.add_option("--k", config.k, "RetrievalConfig::k");
  app.add_option("--ring-candidates", config.ring_candidates, "RetrievalConfig::ring_candidates");
  app.add_flag("--json", json, "one JSON object as the last stdout line");
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;
  if (const auto err = config.validate()) {
    std::cerr << "loopd-bench retrieval: " << *err << "\n";
    return 2;
  }
  const std::vector<PlaceDescriptor> bases = simulated_descriptors(scans, sensor, !json);
  if (bases.empty()) {
    std::cerr << "loopd-bench retrieval: no simulated scan gave a descriptor\n";
    return 1;
  }
  std::mt19937 rng(7);
  PlaceIndex index;
  tools::Progress fill("fill", entries, !json);
  for (int i = 0; i < entries; ++i) {
    index.add({i % 4, i}, perturbed(bases[static_cast<std::size_t>(i) % bases.size()], rng));
    if (i % 1000 == 0 || i + 1 == entries) fill.update(i + 1);
  }
  fill.finish();

  std::vector<double> total_ms, ring_ms, full_ms;
  std::size_t found = 0;
  tools::Progress progress("query", queries, !json);
  const auto accept = [](const KeyframeKey& key) { return key.session != 3; };  // a filter that rejects a quarter
  for (int q = 0; q < queries; ++q) {
    std::vector<PlaceDescriptor> query_views;
    for (int v = 0; v < views; ++v) query_views.push_back(perturbed(bases[static_cast<std::size_t>(q * 7) % bases.size()], rng));
    std::vector<const PlaceDescriptor*> view_pointers;
    for (const PlaceDescriptor& v : query_views) view_pointers.push_back(&v);
    PlaceQueryStats stats;
    Stopwatch watch;
    found += index.query_views(view_pointers, config, accept, &stats).size();
    total_ms.push_back(watch.ms());
    ring_ms.push_back(stats.ring_key_ms);
    full_ms.push_back(stats.full_distance_ms);
    progress.update(q + 1);
  }
  progress.finish();
  report(index, bases.size(), config, total_ms, ring_ms, full_ms, found, sensor, views, json);
  return 0;
}
