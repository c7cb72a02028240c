#include "tools/mujoco_reference.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "model/urdf.h"

namespace iapsim::tools {
namespace {

std::string Vector(const Eigen::Vector3d& v) {
  std::ostringstream out;
  out.precision(17);
  out << v.x() << " " << v.y() << " " << v.z();
  return out.str();
}

// MuJoCo's quaternion attribute: w x y z
std::string Quaternion(const Eigen::Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  std::ostringstream out;
  out.precision(17);
  out << q.w() << " " << q.x() << " " << q.y() << " " << q.z();
  return out.str();
}

// mass, CoM and full inertia about the CoM in body axes
std::string Inertial(const model::MassProperties& mass) {
  const Eigen::Matrix3d& I = mass.inertia_B_kgm2;
  std::ostringstream out;
  out.precision(17);
  out << "<inertial pos=\"" << Vector(mass.com_B_m) << "\" mass=\"" << mass.mass_kg << "\" fullinertia=\""
      << I(0, 0) << " " << I(1, 1) << " " << I(2, 2) << " " << I(0, 1) << " " << I(0, 2) << " " << I(1, 2)
      << "\"/>";
  return out.str();
}

std::string Boxes(const std::vector<model::Shape>& shapes, const std::string& body) {
  std::string out;
  for (const model::Shape& shape : shapes) {
    if (shape.kind != model::Shape::Kind::kBox) {
      throw std::invalid_argument(body + ": the resting scene takes box shapes only");
    }
    // friction: Bullet multiplies the two bodies' (0.5 x the ground's 1), MuJoCo takes the larger
    out += "<geom type=\"box\" size=\"" + Vector(0.5 * shape.box_size_m) + "\" pos=\"" +
           Vector(shape.origin_B_m) + "\" quat=\"" + Quaternion(model::RotationFromRpy(shape.rpy_B_rad)) +
           "\" friction=\"0.5 0.005 0.0001\"/>";
  }
  return out;
}

}  // namespace

double RestingPlatformZ_m(const model::Vehicle& vehicle) {
  double lowest_m = -std::numeric_limits<double>::infinity();
  const auto visit = [&](const std::vector<model::Shape>& shapes, const Eigen::Isometry3d& X_PB) {
    for (const model::Shape& shape : shapes) {
      if (shape.kind != model::Shape::Kind::kBox) {
        throw std::invalid_argument(vehicle.name + ": the resting scene takes box shapes only");
      }
      Eigen::Isometry3d X_BS = Eigen::Isometry3d::Identity();
      X_BS.translation() = shape.origin_B_m;
      X_BS.linear() = model::RotationFromRpy(shape.rpy_B_rad);
      const Eigen::Isometry3d X_PS = X_PB * X_BS;
      for (int corner = 0; corner < 8; ++corner) {
        const Eigen::Vector3d sign(corner & 1 ? 1.0 : -1.0, corner & 2 ? 1.0 : -1.0, corner & 4 ? 1.0 : -1.0);
        lowest_m = std::max(lowest_m, (X_PS * (0.5 * shape.box_size_m.cwiseProduct(sign))).z());
      }
    }
  };
  visit(vehicle.platform_collision, Eigen::Isometry3d::Identity());
  for (const model::SubAircraft& sub : vehicle.sub_aircraft) {
    Eigen::Isometry3d X_PS = Eigen::Isometry3d::Identity();
    X_PS.translation() = sub.joint_P_m;
    X_PS.linear() = Eigen::AngleAxisd(sub.initial_yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    visit(sub.collision, X_PS);
  }
  return -lowest_m;
}

std::string RestingVehicleMjcf(const model::Vehicle& vehicle, const std::string& solver) {
  if (!vehicle.tools.empty())
    throw std::invalid_argument(vehicle.name + ": the MuJoCo reference scene has no tools");
  std::string mjcf = "<mujoco model=\"" + vehicle.name + "\">";
  // NED: gravity along +z, the ground's solid side below z = 0 (a plane turned over: its normal −z)
  mjcf += "<option timestep=\"0.001\" gravity=\"0 0 9.81\" solver=\"" + solver +
          "\" iterations=\"100\" tolerance=\"1e-8\"/>";
  mjcf += "<worldbody><geom type=\"plane\" size=\"0 0 1\" quat=\"0 1 0 0\" friction=\"1 0.005 0.0001\"/>";
  mjcf += "<body name=\"platform\" pos=\"0 0 " + std::to_string(RestingPlatformZ_m(vehicle)) +
          "\"><freejoint/>" + Inertial(vehicle.platform) +
          Boxes(vehicle.platform_collision, vehicle.name + " platform");
  for (const model::SubAircraft& sub : vehicle.sub_aircraft) {
    mjcf += "<body name=\"" + sub.name + "\" pos=\"" + Vector(sub.joint_P_m) + "\" quat=\"" +
            Quaternion(Eigen::AngleAxisd(sub.initial_yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix()) +
            "\">";
    if (sub.joint == model::JointType::kSpherical) mjcf += "<joint type=\"ball\"/>";
    mjcf += Inertial(sub.mass) + Boxes(sub.collision, vehicle.name + " " + sub.name) + "</body>";
  }
  mjcf += "</body></worldbody></mujoco>";
  return mjcf;
}

MujocoFigures MeasureMujocoResting(const model::Vehicle& vehicle, const std::string& solver,
                                   double min_seconds) {
  const std::string mjcf = RestingVehicleMjcf(vehicle, solver);
  // MuJoCo 2.2 parses XML from files only: a virtual file system holds it
  mjVFS vfs;
  mj_defaultVFS(&vfs);
  const char* kFile = "resting.xml";
  if (mj_makeEmptyFileVFS(&vfs, kFile, static_cast<int>(mjcf.size())) != 0) {
    throw std::runtime_error("MuJoCo: cannot make the scene's virtual file");
  }
  std::memcpy(vfs.filedata[mj_findFileVFS(&vfs, kFile)], mjcf.data(), mjcf.size());
  char error[1000] = "";
  std::unique_ptr<mjModel, void (*)(mjModel*)> model(mj_loadXML(kFile, &vfs, error, sizeof(error)),
                                                     mj_deleteModel);
  mj_deleteVFS(&vfs);
  if (!model) throw std::runtime_error(std::string("MuJoCo rejected the scene: ") + error);
  std::unique_ptr<mjData, void (*)(mjData*)> data(mj_makeData(model.get()), mj_deleteData);

  MujocoFigures figures;
  figures.version = mj_versionString();
  for (int k = 0; k < 2000; ++k) mj_step(model.get(), data.get());
  int64_t steps = 0;
  const auto start = std::chrono::steady_clock::now();
  double elapsed_s = 0.0;
  while (elapsed_s < min_seconds) {
    for (int k = 0; k < 1000; ++k) {
      mj_step(model.get(), data.get());
      for (int c = 0; c < data->ncon; ++c) {
        figures.max_penetration_m = std::max(figures.max_penetration_m, -data->contact[c].dist);
      }
    }
    steps += 1000;
    elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  figures.steps_per_s = static_cast<double>(steps) / elapsed_s;
  figures.contacts = data->ncon;
  figures.solver_iterations = data->solver_iter;
  double vertical_N = 0.0;  // the normal force (frame row 0) of each contact, along z
  for (int c = 0; c < data->ncon; ++c) {
    mjtNum force[6];
    mj_contactForce(model.get(), data.get(), c, force);
    vertical_N += force[0] * data->contact[c].frame[2];
  }
  figures.weight_error_N = std::abs(std::abs(vertical_N) - vehicle.TotalMass_kg() * 9.81);
  return figures;
}

}  // namespace iapsim::tools
