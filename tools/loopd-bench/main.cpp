// loopd-bench: benchmark figures per stage (never asserted; see docs/benchmarks.md).
#include <cstring>
#include <iostream>
#include <string>

#include "exit_codes.hpp"

int run_bench_m2dp(int argc, char** argv);
int run_bench_register(int argc, char** argv);
int run_bench_gicp(int argc, char** argv);
int run_bench_verify(int argc, char** argv);
int run_bench_correct(int argc, char** argv);
int run_bench_pipeline(int argc, char** argv);
int run_bench_soak(int argc, char** argv);
int run_bench_deskew(int argc, char** argv);
int run_bench_retrieval(int argc, char** argv);
int run_bench_map_writes(int argc, char** argv);

namespace {
struct Subcommand {
  const char* name;
  int (*run)(int, char**);
  const char* help;
};
constexpr Subcommand kSubcommands[] = {
    {"m2dp", run_bench_m2dp, "M2DP descriptor: ms per descriptor, CPU vs OpenCL"},
    {"register", run_bench_register, "4PCS vs PCL KFPCS/FPCS: success rate and ms"},
    {"gicp", run_bench_gicp, "GICP vs PCL GICP: final error and ms"},
    {"verify", run_bench_verify, "whole verification: ms per stage"},
    {"correct", run_bench_correct, "loop correction: ms per method"},
    {"pipeline", run_bench_pipeline, "whole pipeline on a simulated drive: throughput, latency, memory"},
    {"soak", run_bench_soak, "loopd live for N minutes on a looping drive: RSS, threads, fds, latency"},
    {"deskew", run_bench_deskew, "deskew of the sharpest-turning simulated scan: ms and error per variant"},
    {"retrieval", run_bench_retrieval, "Scan Context PlaceIndex: ms per query among 100k descriptors, index bytes"},
    {"map-writes", run_bench_map_writes, "map store: keyframe writes per second and commit latency with N writers"},
};
void usage() {
  std::cout << "usage: loopd-bench <subcommand> [options] [--json]\n\nsubcommands:\n";
  for (const auto& s : kSubcommands) std::cout << "  " << s.name << std::string(12 - std::strlen(s.name), ' ') << s.help << "\n";
  std::cout << "\n'loopd-bench <subcommand> --help' lists its options.\n";
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    usage();
    return argc < 2 ? loopd::tools::kExitUsage : loopd::tools::kExitOk;
  }
  for (const auto& s : kSubcommands)
    if (s.name == std::string(argv[1])) return s.run(argc - 1, argv + 1);
  std::cerr << "loopd-bench: unknown subcommand '" << argv[1] << "'\n";
  usage();
  return loopd::tools::kExitUsage;
}
