// Timing harness: pinocchio's forward kinematics on a machine URDF, for benches/vs_pinocchio.rs.
//
// Usage: fk MODEL.txt POSES.txt REPEATS
//
// MODEL.txt: the machine as pinocchio's text archive, written by pinocchio's own URDF parser
// (`pinocchio.buildModelFromUrdf(urdf).saveToText(path)`, see vs_pinocchio.rs): the pip build
// of pinocchio ships its URDF parser compiled but not the urdfdom headers a C++ program that
// parses URDF itself would need. The model is the same one, and loading is not timed.
// POSES.txt: the first line names the joints (axis letters), each further line holds one pose's
// positions in that order (SI: m, rad). Per pose the harness runs `forwardKinematics` and places
// the `tool` and `workpiece` frames (`updateFramePlacement`), the two frames mtcal's pose error
// relates. Configurations are built once before timing (a continuous joint is (cos, sin) in
// pinocchio), so only the kinematics is timed.
//
// Prints `ns_per_pose MEDIAN MIN` over REPEATS passes through the pose set, and a checksum line
// (so the compiler cannot drop the work). Exit code 2 on bad input.

#include <pinocchio/multibody.hpp>
#include <pinocchio/serialization.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/joint-configuration.hpp>
#include <pinocchio/algorithm/kinematics.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

namespace {

// Writes one joint position into pinocchio's configuration (see tests/fk_reference.py).
bool set_joint(const pinocchio::Model &model, Eigen::VectorXd &q, const std::string &name,
               double value) {
  if (!model.existJointName(name)) {
    std::cerr << "fk: the model has no joint named " << name << "\n";
    return false;
  }
  const auto &joint = model.joints[model.getJointId(name)];
  if (joint.nq() == 1) {
    q[joint.idx_q()] = value;
  } else if (joint.nq() == 2) {
    q[joint.idx_q()] = std::cos(value);
    q[joint.idx_q() + 1] = std::sin(value);
  } else {
    std::cerr << "fk: joint " << name << " has nq = " << joint.nq() << "\n";
    return false;
  }
  return true;
}

bool read_poses(const pinocchio::Model &model, const char *path,
                std::vector<Eigen::VectorXd> &out) {
  std::ifstream in(path);
  std::string line;
  if (!std::getline(in, line)) {
    std::cerr << "fk: " << path << ": no header line\n";
    return false;
  }
  std::vector<std::string> names;
  std::istringstream header(line);
  for (std::string n; header >> n;) names.push_back(n);
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::istringstream row(line);
    Eigen::VectorXd q = pinocchio::neutral(model);
    for (const auto &n : names) {
      double v;
      if (!(row >> v)) {
        std::cerr << "fk: " << path << ": short line: " << line << "\n";
        return false;
      }
      if (!set_joint(model, q, n, v)) return false;
    }
    out.push_back(q);
  }
  return !out.empty();
}

}  // namespace

int main(int argc, char **argv) {
  if (argc != 4) {
    std::cerr << "usage: fk MODEL.txt POSES.txt REPEATS\n";
    return 2;
  }
  pinocchio::Model model;
  try {
    model.loadFromText(argv[1]);
  } catch (const std::exception &e) {
    std::cerr << "fk: " << argv[1] << ": " << e.what() << "\n";
    return 2;
  }
  pinocchio::Data data(model);
  const auto tool = model.getFrameId("tool", pinocchio::BODY);
  const auto workpiece = model.getFrameId("workpiece", pinocchio::BODY);
  if (tool >= model.frames.size() || workpiece >= model.frames.size()) {
    std::cerr << "fk: the model has no `tool` or `workpiece` frame\n";
    return 2;
  }
  std::vector<Eigen::VectorXd> poses;
  if (!read_poses(model, argv[2], poses)) return 2;
  const int repeats = std::max(1, std::atoi(argv[3]));

  double checksum = 0.0;
  // One pass through the pose set: FK, then the two frames.
  auto pass = [&]() {
    for (const auto &q : poses) {
      pinocchio::forwardKinematics(model, data, q);
      pinocchio::updateFramePlacement(model, data, tool);
      pinocchio::updateFramePlacement(model, data, workpiece);
      checksum += data.oMf[tool].translation()[0] + data.oMf[workpiece].translation()[2];
    }
  };
  // Warm-up: caches, branch predictors, clock frequency.
  for (int r = 0; r < std::max(1, repeats / 10); ++r) pass();
  std::vector<double> ns;
  ns.reserve(repeats);
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    pass();
    const auto t1 = std::chrono::steady_clock::now();
    ns.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count() /
                 static_cast<double>(poses.size()));
  }
  std::sort(ns.begin(), ns.end());
  std::printf("ns_per_pose %.3f %.3f\n", ns[ns.size() / 2], ns.front());
  std::printf("checksum %.17g\n", checksum);
  return 0;
}
