// loopd-map picture: a top view of the 3D map coloured by height, with the trajectory and the accepted loops over it
// (gnuplot renders it, as loopd-eval's plots).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <unistd.h>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/io/cloud_file.hpp"
#include "map_build_options.hpp"
#include "map_commands.hpp"
#include "tool_output.hpp"

namespace loopd::tools {
namespace {

/// @brief The map's top view: the highest point's height in each cell (NaN: empty).
struct HeightGrid {
  double x0 = 0.0, y0 = 0.0, cell = 1.0;
  int nx = 0, ny = 0;
  std::vector<float> top;
  float lo = 0.0f, hi = 1.0f;  ///< colour range: 2nd and 98th percentile of the cells' heights
};

constexpr double kMaxExtent = 1e6;     ///< [m] a map wider than this is not drawn (a stray point, a hostile file)
constexpr double kMaxPixels = 8000.0;  ///< pixels along the longer side at most

/// `cell` 0: the map in about 1400 pixels, at least `min_cell` (a pixel smaller than the map's voxel leaves holes).
HeightGrid rasterise(const PointCloud& map, double cell, double min_cell) {
  HeightGrid g;
  Eigen::Vector3f mn = Eigen::Vector3f::Constant(std::numeric_limits<float>::max()), mx = -mn;
  for (const auto& p : map.points) {
    mn = mn.cwiseMin(p);
    mx = mx.cwiseMax(p);
  }
  const double extent = std::max(static_cast<double>(mx.x()) - mn.x(), static_cast<double>(mx.y()) - mn.y());
  if (!std::isfinite(extent) || extent > kMaxExtent) return g;  // nx = 0: the caller says why
  g.cell = cell > 0.0 ? cell : std::max(min_cell, extent / 1400.0);
  g.cell = std::max(g.cell, extent / kMaxPixels);  // a pixel asked for too small for the map: as fine as allowed
  g.x0 = mn.x();
  g.y0 = mn.y();
  g.nx = std::max(1, static_cast<int>((mx.x() - mn.x()) / g.cell) + 1);
  g.ny = std::max(1, static_cast<int>((mx.y() - mn.y()) / g.cell) + 1);
  g.top.assign(static_cast<std::size_t>(g.nx) * static_cast<std::size_t>(g.ny), std::numeric_limits<float>::quiet_NaN());
  for (const auto& p : map.points) {
    const auto ix = static_cast<std::size_t>((p.x() - g.x0) / g.cell), iy = static_cast<std::size_t>((p.y() - g.y0) / g.cell);
    float& t = g.top[iy * static_cast<std::size_t>(g.nx) + ix];
    if (!(t >= p.z())) t = p.z();
  }
  std::vector<float> h;
  for (float t : g.top)
    if (std::isfinite(t)) h.push_back(t);
  if (!h.empty()) {
    std::sort(h.begin(), h.end());
    g.lo = h[h.size() * 2 / 100];
    g.hi = std::max(g.lo + 0.5f, h[h.size() * 98 / 100]);
  }
  return g;
}

/// @brief gnuplot's binary matrix: n, then x of each column; each row: y, then its values.
bool write_matrix(const std::string& path, const HeightGrid& g) {
  std::ofstream f(path, std::ios::binary);
  auto put = [&f](float v) { f.write(reinterpret_cast<const char*>(&v), sizeof v); };
  put(static_cast<float>(g.nx));
  for (int i = 0; i < g.nx; ++i) put(static_cast<float>(g.x0 + (i + 0.5) * g.cell));
  for (int j = 0; j < g.ny; ++j) {
    put(static_cast<float>(g.y0 + (j + 0.5) * g.cell));
    for (int i = 0; i < g.nx; ++i) put(g.top[static_cast<std::size_t>(j) * static_cast<std::size_t>(g.nx) + static_cast<std::size_t>(i)]);
  }
  return static_cast<bool>(f);
}

/// @brief The trajectory (one line per session) and the accepted loops (segments between their keyframes).
std::size_t write_overlays(MapStore& store, const KeyframePoses& poses, const std::string& dir) {
  std::map<KeyframeKey, Eigen::Vector3d> at;
  std::ofstream traj(dir + "/trajectory.dat");
  SessionId last = 0;
  for (std::size_t i = 0; i < poses.poses.size(); ++i) {
    const KeyframePose& p = poses.poses[i];
    if (i > 0 && p.key.session != last) traj << "\n\n";
    last = p.key.session;
    at[p.key] = p.T.translation();
    traj << p.T.translation().x() << ' ' << p.T.translation().y() << '\n';
  }
  std::ofstream loops(dir + "/loops.dat");
  std::size_t n = 0;
  store.for_each_loop(true, [&](LoopDecision&& l) {
    const auto q = at.find(l.query), m = at.find(l.match);
    if (q == at.end() || m == at.end()) return;
    loops << q->second.x() << ' ' << q->second.y() << '\n' << m->second.x() << ' ' << m->second.y() << "\n\n";
    ++n;
  });
  return n;
}

std::string quote(const std::string& s) { return "'" + s + "'"; }

bool render(const std::string& dir, const HeightGrid& g, std::size_t loops, const MapBuildOptions& o) {
  const int width = std::clamp(g.nx + 260, 600, 2000), height = std::clamp(g.ny + 120, 400, 2000);
  for (const char* term : {"pngcairo", "png"}) {
    std::ofstream gp(dir + "/picture.gp");
    gp << "set terminal " << term << " size " << width << "," << height << "\nset output " << quote(o.out) << "\n"
       << "set title 'loopd map, top view (" << (o.odometry ? "odometry" : "corrected") << " poses): " << loops << " accepted loops'\n"
       << "set size ratio -1\nset xlabel 'x [m]'\nset ylabel 'y [m]'\nset cblabel 'height of the highest point [m]'\n"
       << "set palette defined (0 '#440154', 0.25 '#3b528b', 0.5 '#21918c', 0.75 '#5ec962', 1 '#fde725')\n"
       << "set cbrange [" << g.lo << ":" << g.hi
       << "]\nset key outside bottom center horizontal\nset object 1 rectangle from screen 0,0 to screen 1,1 fillcolor rgb 'white' behind\n"
       << "plot " << quote(dir + "/height.bin") << " binary matrix with image notitle, " << quote(dir + "/trajectory.dat")
       << " with lines lw 1.5 lc rgb '#e00000' title 'trajectory'";
    if (loops > 0)
      gp << ", " << quote(dir + "/loops.dat") << " with linespoints lw 1 pt 6 ps 1.2 lc rgb '#000000' title 'accepted loops (query - match)'";
    gp << "\nunset output\n";
    gp.close();
    const std::string cmd = "gnuplot " + quote(dir + "/picture.gp") + " 2> " + quote(dir + "/gnuplot.log");
    if (std::system(cmd.c_str()) == 0) return true;
  }
  return false;
}

}  // namespace

int run_picture(MapStore& store, const MapBuildOptions& o, const CommandOptions& options) {
  MapBuildConfig config;
  KeyframePoses poses;
  std::vector<MapBuildKeyframe> keyframes;
  if (!prepare_build(store, o, options.progress, &config, &poses, &keyframes)) return kExitBadInput;
  PointCloud map;
  if (!o.picture_cloud.empty()) {
    CloudFile file = read_cloud_file(o.picture_cloud);
    if (!file.ok) {
      std::cerr << "loopd-map: " << file.error << "\n";
      return kExitBadInput;
    }
    map = std::move(file.cloud);
  } else {
    std::string read_error;
    map = build_map(keyframes, store_clouds(store, &read_error), config, phase_progress(options.progress)).map;
    if (!read_error.empty()) {
      std::cerr << "loopd-map: " << read_error << "\n";
      return kExitBadInput;
    }
  }
  map = remove_non_finite(map);
  if (map.empty()) {
    std::cerr << "loopd-map: no map points to draw (a map written before map clouds, or an empty cloud file)\n";
    return kExitBadInput;
  }
  char tmpl[] = "/tmp/loopd-map-picture-XXXXXX";
  if (!::mkdtemp(tmpl)) {
    std::cerr << "loopd-map: cannot create a temporary folder in /tmp\n";
    return kExitBadInput;
  }
  const std::string dir = tmpl;
  const HeightGrid grid = rasterise(map, o.picture_cell, 1.5 * (o.picture_cloud.empty() ? o.voxel : 0.2));
  if (grid.nx == 0) {
    std::cerr << "loopd-map: the map spans more than " << kMaxExtent / 1000.0 << " km (a stray point far away?): not drawn\n";
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
    return kExitBadInput;
  }
  const std::size_t loops = write_overlays(store, poses, dir);
  const bool ok = write_matrix(dir + "/height.bin", grid) && render(dir, grid, loops, o);
  if (!ok) {
    std::cerr << "loopd-map: gnuplot failed or is not installed (see " << dir << "/gnuplot.log)\n";
    return kExitBadInput;
  }
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  Table t({"", "value"});
  t.add({"map points" + std::string(o.picture_cloud.empty() ? "" : " (" + o.picture_cloud + ")"), std::to_string(map.size())});
  t.add({"pixel [m]", fmt(grid.cell, 2)});
  t.add({"height range coloured [m]", fmt(grid.lo, 1) + " .. " + fmt(grid.hi, 1)});
  t.add({"accepted loops drawn", std::to_string(loops)});
  t.add({"written to", o.out});
  std::cout << t.str();
  if (options.json)
    print_json_line({{"out", o.out}, {"points", map.size()}, {"pixel_m", grid.cell}, {"loops", loops}, {"keyframes", poses.poses.size()}});
  return kExitOk;
}

}  // namespace loopd::tools
