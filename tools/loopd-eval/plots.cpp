#include "plots.hpp"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace loopd::tools {
namespace {

bool file_nonempty(const std::string& p) {
  std::error_code ec;
  return std::filesystem::exists(p, ec) && std::filesystem::file_size(p, ec) > 0;
}

void write_path(const std::string& path, const std::vector<Eigen::Isometry3d>& poses) {
  std::ofstream f(path);
  for (const auto& T : poses) f << T.translation().x() << ' ' << T.translation().y() << '\n';
}

std::string quote(const std::string& s) { return "'" + s + "'"; }

}  // namespace

std::vector<std::string> write_plots(const std::string& dir, const EvalInput& input, const EvalReport& rep, std::string* error) {
  std::vector<std::string> written;
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    if (error) *error = "cannot create plot folder " + dir + ": " + ec.message();
    return written;
  }
  const std::string d = dir + "/";
  {
    std::ofstream f(d + "ground_truth.dat");
    for (const auto& p : rep.gt_path) f << p.x() << ' ' << p.y() << '\n';
  }
  write_path(d + "odometry.dat", rep.before_keyframes);
  write_path(d + "corrected.dat", rep.after_keyframes);
  {
    std::ofstream f(d + "revisits.dat");
    for (std::size_t i = 0; i < rep.gt_keyframes.size(); ++i)
      if (rep.loop_ground_truth.revisit[i]) f << rep.gt_keyframes[i].translation().x() << ' ' << rep.gt_keyframes[i].translation().y() << '\n';
  }
  // Accepted loops as segments between the two keyframes on the odometry ("before") trajectory: the length of a
  // segment is the drift the loop closes.
  {
    std::ofstream good(d + "loops_correct.dat"), bad(d + "loops_wrong.dat");
    for (const auto& c : rep.checks) {
      if (input.loops[c.loop].status != LoopStatus::kAccepted || c.query_keyframe < 0 || c.match_keyframe < 0) continue;
      std::ofstream& f = c.correct ? good : bad;
      const auto& q = rep.before_keyframes[static_cast<std::size_t>(c.query_keyframe)].translation();
      const auto& m = rep.before_keyframes[static_cast<std::size_t>(c.match_keyframe)].translation();
      f << q.x() << ' ' << q.y() << '\n' << m.x() << ' ' << m.y() << "\n\n";
    }
  }
  {
    std::ofstream f(d + "pr_curve.dat");
    f << "# threshold precision recall true_positives false_positives\n";
    for (const auto& p : rep.detection.pr_curve)
      f << p.threshold << ' ' << p.precision << ' ' << p.recall << ' ' << p.true_positives << ' ' << p.false_positives << '\n';
  }

  std::ostringstream traj_plot, pr_plot;
  traj_plot << "reset\nset title 'Trajectories (top view): " << rep.closure.accepted << " accepted loops, " << rep.closure.correct << " correct'\n"
            << "set xlabel 'x [m]'\nset ylabel 'y [m]'\nset size ratio -1\nset key outside right top\nset grid\n"
            << "plot " << quote(d + "ground_truth.dat") << " with lines lw 2 lc rgb '#202020' title 'ground truth'";
  if (file_nonempty(d + "revisits.dat"))
    traj_plot << ", " << quote(d + "revisits.dat") << " with points pt 7 ps 0.5 lc rgb '#33aa33' title 'revisited (ground truth)'";
  traj_plot << ", " << quote(d + "odometry.dat") << " with lines lw 1.5 lc rgb '#3060d0' title 'odometry (before)'";
  if (rep.has_corrected)  // without a correction "after" is the odometry and would hide it
    traj_plot << ", " << quote(d + "corrected.dat") << " with lines lw 1.5 lc rgb '#e08000' title 'corrected (after)'";
  if (file_nonempty(d + "loops_correct.dat"))
    traj_plot << ", " << quote(d + "loops_correct.dat") << " with lines lw 1 lc rgb '#00a000' title 'accepted loop, correct'";
  if (file_nonempty(d + "loops_wrong.dat"))
    traj_plot << ", " << quote(d + "loops_wrong.dat") << " with lines lw 1.5 lc rgb '#e00000' title 'accepted loop, wrong'";
  traj_plot << "\n";

  const bool have_pr = !rep.detection.pr_curve.empty();
  if (have_pr) {
    pr_plot << "reset\nset title sprintf('Precision-recall over the descriptor threshold (F1 max %.3f)', " << rep.detection.f1_max << ")\n"
            << "set xlabel 'recall'\nset ylabel 'precision'\nset xrange [0:1.02]\nset yrange [0:1.02]\nset grid\n"
            << "set key inside left bottom box opaque\n"
            << "plot " << quote(d + "pr_curve.dat") << " using 3:2 with linespoints pt 7 ps 0.6 lw 2 lc rgb '#3060d0' "
            << "title 'descriptor threshold sweep', '-' with points pt 9 ps 2 lc rgb '#e00000' title 'accepted loops'\n"
            << rep.detection.recall << ' ' << rep.detection.precision << "\ne\n";
  }

  const std::string script = d + "plots.gp";
  for (const char* png_term : {"pngcairo", "png"}) {
    std::ofstream gp(script);
    gp << "set terminal " << png_term << " size 1200,900\n";
    gp << "set output " << quote(d + "trajectories.png") << "\n" << traj_plot.str();
    if (have_pr) gp << "set terminal " << png_term << " size 900,800\nset output " << quote(d + "pr_curve.png") << "\n" << pr_plot.str();
    gp << "set terminal svg size 1200,900 dynamic\nset output " << quote(d + "trajectories.svg") << "\n" << traj_plot.str();
    if (have_pr) gp << "set terminal svg size 900,800 dynamic\nset output " << quote(d + "pr_curve.svg") << "\n" << pr_plot.str();
    gp << "unset output\n";
    gp.close();
    const std::string cmd = "gnuplot " + quote(script) + " 2> " + quote(d + "gnuplot.log");
    if (std::system(cmd.c_str()) == 0) {
      for (const char* f : {"trajectories.png", "trajectories.svg", "pr_curve.png", "pr_curve.svg"})
        if (file_nonempty(d + f)) written.push_back(d + f);
      return written;
    }
  }
  if (error) *error = "gnuplot failed or is not installed (see " + d + "gnuplot.log; script " + script + ")";
  return written;
}

}  // namespace loopd::tools
