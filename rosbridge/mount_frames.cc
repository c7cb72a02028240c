#include "rosbridge/mount_frames.h"

#include <filesystem>

#include "model/vehicle.h"
#include "render/camera_rig.h"
#include "sensors/sensor_config.h"

namespace iapsim::rosbridge {

MountFrames ReadMountFrames(const bridge::Scenario& scenario, const std::string& process) {
  const bridge::ProcessConfig* config = scenario.Find(process);
  if (!config) throw bridge::ConfigError("no process '" + process + "' to read mounts from");
  // a copy: the reader marks keys as read, and the process's own check reads them all
  bridge::YamlMap params(YAML::Clone(config->params), scenario.file, "processes." + process + ".params");
  const std::string exec = std::filesystem::path(config->exec).filename();
  MountFrames frames;
  if (exec == "iapsim_sensors") {
    bridge::YamlMap vehicle = params.Map("vehicle");
    std::string name;
    vehicle.Required("name", &name);
    const model::Vehicle model = model::LoadVehicle(bridge::ReadFilePath(vehicle, "file", scenario.file));
    const sensors::SensorsConfig sensors = sensors::ReadSensorsConfig(params);
    for (const model::SubAircraft& sub : model.sub_aircraft) {
      const std::string body = name + "/" + sub.name;
      frames.fixed.push_back({body, body + "/imu", sensors.imu.p_BI_m, sensors.imu.q_BI});
    }
  } else if (exec == "iapsim_render") {
    for (const render::CameraConfig& camera : render::ReadCameras(params, "cameras")) {
      const std::vector<Eigen::Isometry3d> X_PC =
          render::CameraPoses_W(camera, Eigen::Isometry3d::Identity());
      for (size_t eye = 0; eye < X_PC.size(); ++eye) {
        const std::string frame = camera.OpticalFrameId(static_cast<int>(eye));
        if (camera.mount.kind == render::CameraMount::Kind::kChase) {
          frames.moving.push_back(frame);
          continue;
        }
        const std::string parent =
            camera.mount.kind == render::CameraMount::Kind::kBody ? camera.mount.body : "W";
        frames.fixed.push_back(
            {parent, frame, X_PC[eye].translation(), Eigen::Quaterniond(X_PC[eye].rotation())});
      }
    }
  } else {
    throw bridge::ConfigError("process '" + process + "' runs " + exec +
                              ": mounts come from an iapsim_sensors or iapsim_render process");
  }
  return frames;
}

}  // namespace iapsim::rosbridge
