// iapsim_render: the rendering process of seed §V-B. It draws the scene with the vehicles at the pose of the
// latest physics state and publishes, per camera eye, the image stamped with that state's stamp (Fig. 10),
// never with the time it was drawn.
//
//   subscribes  /<vehicle>/state                       iapsim_msgs/IapState (each vehicle of `vehicles`)
//   publishes   <eye>/image_raw/compressed             sensor_msgs/CompressedImage (PNG)
//               <eye>/camera_info                      sensor_msgs/CameraInfo
//               <eye>/image_raw                        sensor_msgs/Image rgb8 (camera `raw: true`)
//               <eye>/depth/image_raw                  sensor_msgs/Image 32FC1, metres (camera `depth: true`)
//   <eye> = /<body>/<camera>[/left|/right], or /<camera>[/left|/right] for a world-fixed camera.
//
// A camera draws at steps k that are multiples of its period (its rate_hz must divide the process's). In
// lockstep and fast mode the step is acknowledged only after its images are published, so physics waits for
// them and a run's images are reproducible. In realtime the drawing runs beside the bus: a due step starts a
// frame of the newest state unless the previous frame is still drawing (then it is skipped and counted).
// The render latency reported is wall time from the state's publication to the frame's last image.

#include <iapsim_msgs/IapState.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <exception>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <thread>

#include "bridge/eigen_msgs.h"
#include "bridge/process.h"
#include "model/vehicle.h"
#include "render/camera_messages.h"
#include "render/camera_system.h"
#include "render/scene_config.h"
#include "render/vehicle_visual.h"

namespace iapsim::render {
namespace {

using Clock = std::chrono::steady_clock;

// One frame: the body poses of one physics state and the cameras due at its step.
struct FrameRequest {
  int64_t stamp_ns = 0;
  int64_t state_sent_unix_ns = 0;  // when physics published the state (for the latency)
  std::vector<int> cameras;
  std::map<std::string, Eigen::Isometry3d> poses_W;
};

double Percentile(std::vector<double> values, double fraction) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[std::min(values.size() - 1,
                         static_cast<size_t>(fraction * static_cast<double>(values.size())))];
}

class RenderNode : public bridge::Process {
 public:
  RenderNode(const bridge::ProcessContext& context, bridge::YamlMap& params)
      : clock_step_s_(context.scenario.clock.step_s),
        synchronous_(context.scenario.mode != bridge::ClockMode::kRealtime) {
    scene_ = LoadScene(bridge::ReadFilePath(params, "scene", context.scenario.file));
    ReadVehicles(context, params);
    cameras_ = ReadCameras(params, "cameras");
    if (cameras_.empty()) params.Fail("cameras", "is required: a list of at least one camera");
    const uint64_t process_every =
        context.self.rate_hz > 0 ? bridge::StepsPerPeriod(context.self.rate_hz, clock_step_s_) : 1;
    const YAML::Node camera_nodes = params.Raw("cameras");
    for (size_t c = 0; c < cameras_.size(); ++c) {
      const bridge::YamlMap camera(camera_nodes[c], params.file(),
                                   params.PathOf("cameras") + "[" + std::to_string(c) + "]");
      const uint64_t every = bridge::StepsPerPeriod(cameras_[c].rate_hz, clock_step_s_);
      if (every == 0 || every % process_every != 0) {
        char rates[96];
        std::snprintf(rates, sizeof(rates), "%g must divide the render process's rate_hz %g",
                      cameras_[c].rate_hz, 1.0 / (static_cast<double>(process_every) * clock_step_s_));
        camera.Fail("rate_hz", rates);
      }
      camera_every_.push_back(every);
      const std::string& body = cameras_[c].mount.body;
      if (cameras_[c].mount.kind != CameraMount::Kind::kWorld && !bodies_.count(body)) {
        std::string known;
        for (const std::string& b : bodies_) known += " " + b;
        camera.Fail("body", "no body '" + body + "' in the vehicles drawn; they have:" + known);
      }
    }
    std::string backend = "osmesa";
    params.OptionalChoice("backend", &backend, {"osmesa", "egl"});
    options_.renderer.backend = ParseBackend(backend);
    params.OptionalInRange("threads", &options_.renderer.threads, 0, 256);
    params.OptionalInRange("png_compression", &options_.png_compression, 0, 9);
  }

  ~RenderNode() override { StopWorker(); }

  void Setup(bridge::Bus& bus) override {
    bus_ = &bus;
    for (const std::string& vehicle : vehicles_) {
      bus.Subscribe<iapsim_msgs::IapState>("/" + vehicle + "/state",
                                           [this](const iapsim_msgs::IapState& state,
                                                  const bridge::MessageInfo& info) { OnState(state, info); });
    }
    // the renderer's GL context belongs to the thread that draws; it is made there, before the run starts
    worker_ = std::thread([this] { Work(); });
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [this] { return system_ready_ || worker_error_; });
    if (worker_error_) std::rethrow_exception(worker_error_);
  }

  void Step(const bridge::StepInfo& step) override {
    PublishDone();
    RequestFrame(step);
    // lockstep and fast: the step's images go out before it is acknowledged; realtime: at the last step, so
    // that the run's last frame is out before the run ends (and reaches the recorder)
    if (synchronous_ || step.final) AwaitFrame();
  }

  void Finish(nlohmann::json* report) override {
    StopWorker();
    if (bus_) PublishDone();
    FinishReport(report);
  }

 private:
  // Asks the drawing thread for a frame of the cameras due at `step`, of the newest state, unless the
  // previous frame is still drawing (realtime; it is skipped and counted).
  void RequestFrame(const bridge::StepInfo& step) {
    std::vector<int> due;
    for (size_t c = 0; c < cameras_.size(); ++c) {
      if (step.step % camera_every_[c] == 0) due.push_back(static_cast<int>(c));
    }
    if (due.empty()) return;
    if (latest_stamp_ns_ < 0) {
      ++frames_without_state_;  // realtime: no state yet
      return;
    }
    {
      std::unique_lock lock(mutex_);
      if (worker_error_) std::rethrow_exception(worker_error_);
      if (request_ || done_) {
        ++frames_skipped_busy_;  // realtime only: the previous frame is still drawing
        return;
      }
      request_ = FrameRequest{latest_stamp_ns_, latest_sent_unix_ns_, due, poses_W_};
    }
    if (frames_ == 0) first_request_ = Clock::now();
    changed_.notify_all();
  }

  // Waits for the frame being drawn, if any, and publishes it.
  void AwaitFrame() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [this] { return !request_ || done_ || worker_error_; });
    if (worker_error_) std::rethrow_exception(worker_error_);
    lock.unlock();
    PublishDone();
  }

  void FinishReport(nlohmann::json* report) {
    nlohmann::json& out = *report;
    out["renderer"] = renderer_description_;
    out["frames"] = frames_;
    out["images"] = images_;
    // throughput from the first frame asked for to the last one published
    const double busy_s =
        frames_ > 0 ? std::chrono::duration<double>(last_publish_ - first_request_).count() : 0.0;
    out["frames_per_s"] = busy_s > 0.0 ? static_cast<double>(frames_) / busy_s : 0.0;
    out["images_per_s"] = busy_s > 0.0 ? static_cast<double>(images_) / busy_s : 0.0;
    out["frames_skipped_busy"] = frames_skipped_busy_;
    out["frames_without_state"] = frames_without_state_;
    out["png_kib_mean"] =
        images_ > 0 ? static_cast<double>(png_bytes_) / static_cast<double>(images_) / 1024.0 : 0.0;
    out["draw_ms"] = {{"p50", Percentile(draw_ms_, 0.5)}, {"p95", Percentile(draw_ms_, 0.95)}};
    out["latency_ms"] = {
        {"p50", Percentile(latency_ms_, 0.5)},
        {"p95", Percentile(latency_ms_, 0.95)},
        {"max", latency_ms_.empty() ? 0.0 : *std::max_element(latency_ms_.begin(), latency_ms_.end())}};
    nlohmann::json& cameras = out["cameras"];
    for (size_t c = 0; c < cameras_.size(); ++c) {
      for (size_t e = 0; e < cameras_[c].EyeNames().size(); ++e) {
        cameras[cameras_[c].TopicNamespace(static_cast<int>(e))] = images_per_eye_[{c, e}];
      }
    }
  }

  void ReadVehicles(const bridge::ProcessContext& context, bridge::YamlMap& params) {
    const YAML::Node list = params.Raw("vehicles");
    if (!list || !list.IsSequence() || list.size() == 0) {
      params.Fail("vehicles", "expected a list of {name, file}: the vehicles drawn and their state topics");
    }
    YAML::Node resolved(YAML::NodeType::Sequence);  // with absolute file paths, for a restart from the run
    for (size_t i = 0; i < list.size(); ++i) {
      bridge::YamlMap item(list[i], params.file(), params.PathOf("vehicles") + "[" + std::to_string(i) + "]");
      std::string name;
      item.Required("name", &name);
      const model::Vehicle vehicle =
          model::LoadVehicle(bridge::ReadFilePath(item, "file", context.scenario.file));
      AddVehicle(&scene_, vehicle, name);
      bodies_.insert(PlatformBody(name));
      for (const model::SubAircraft& sub : vehicle.sub_aircraft) bodies_.insert(SubAircraftBody(name, sub));
      item.Finish();
      vehicles_.push_back(name);
      resolved.push_back(item.Resolved());
    }
    params.SetResolved("vehicles", resolved);
  }

  void OnState(const iapsim_msgs::IapState& state, const bridge::MessageInfo& info) {
    for (const iapsim_msgs::BodyState& body : state.bodies) {
      Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
      X_WB.translation() = bridge::FromMsg(body.pose_W.position);
      X_WB.linear() = bridge::FromMsg(body.pose_W.orientation).normalized().toRotationMatrix();
      poses_W_[body.name] = X_WB;
    }
    // the vehicles' states of one step arrive back to back: the frame takes the last one's stamp
    latest_stamp_ns_ = bridge::ToNanoseconds(state.header.stamp);
    latest_sent_unix_ns_ = info.sent_unix_ns;
    PublishDone();
  }

  // The drawing thread: makes the renderer, then draws each request until stopped.
  void Work() {
    std::optional<CameraSystem> system;
    try {
      system.emplace(scene_, cameras_, options_);
      std::lock_guard lock(mutex_);
      renderer_description_ = system->renderer().Description();
      system_ready_ = true;
    } catch (...) {
      std::lock_guard lock(mutex_);
      worker_error_ = std::current_exception();
    }
    changed_.notify_all();
    if (!system) return;
    std::vector<EyeFrame> frames;
    while (true) {
      FrameRequest request;
      {
        std::unique_lock lock(mutex_);
        changed_.wait(lock, [this] { return stop_ || (request_ && !done_); });
        if (stop_) return;
        request = *request_;
      }
      try {
        for (const auto& [body, X_WB] : request.poses_W) system->SetBodyPose(body, X_WB);
        if (const std::vector<std::string> missing = system->MissingMounts(); !missing.empty()) {
          throw std::runtime_error("no state has reached this process for body '" + missing.front() +
                                   "', which a camera is mounted on: does physics fly that vehicle?");
        }
        const auto start = Clock::now();
        system->Render(request.cameras, &frames);
        const double draw_ms = 1e3 * std::chrono::duration<double>(Clock::now() - start).count();
        std::lock_guard lock(mutex_);
        done_frames_.swap(frames);
        done_draw_ms_ = draw_ms;
        done_ = true;
      } catch (...) {
        {
          std::lock_guard lock(mutex_);
          worker_error_ = std::current_exception();
        }
        changed_.notify_all();
        return;  // the bus thread rethrows it and the run stops
      }
      changed_.notify_all();
    }
  }

  // Publishes a finished frame, if any (on the bus's thread: the bus is not shared with the drawing thread).
  void PublishDone() {
    std::unique_lock lock(mutex_);
    if (worker_error_) std::rethrow_exception(worker_error_);
    if (!done_) return;
    const FrameRequest request = std::move(*request_);
    std::vector<EyeFrame> frames;
    frames.swap(done_frames_);
    draw_ms_.push_back(done_draw_ms_);
    request_.reset();
    done_ = false;
    lock.unlock();
    changed_.notify_all();

    for (EyeFrame& frame : frames) {
      const CameraConfig& camera = cameras_[frame.camera];
      const std::string ns = camera.TopicNamespace(frame.eye);
      const std_msgs::Header header = EyeHeader(camera, frame.eye, request.stamp_ns);
      png_bytes_ += frame.png.size();
      bus_->Publish(ns + "/image_raw/compressed", PngMessage(std::move(frame.png), header));
      bus_->Publish(ns + "/camera_info", CameraInfoMessage(camera, frame.eye, header));
      if (camera.publish_raw) bus_->Publish(ns + "/image_raw", RgbMessage(frame.rgb, header));
      if (camera.publish_depth) bus_->Publish(ns + "/depth/image_raw", DepthMessage(frame.depth, header));
      ++images_;
      ++images_per_eye_[{static_cast<size_t>(frame.camera), static_cast<size_t>(frame.eye)}];
    }
    ++frames_;
    last_publish_ = Clock::now();
    latency_ms_.push_back(static_cast<double>(bridge::UnixTimeNs() - request.state_sent_unix_ns) * 1e-6);
  }

  void StopWorker() {
    if (!worker_.joinable()) return;
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    changed_.notify_all();
    worker_.join();
  }

  const double clock_step_s_;
  const bool synchronous_;
  Scene scene_;
  std::vector<std::string> vehicles_;
  std::set<std::string> bodies_;  // the vehicles' bodies, as physics names them
  std::vector<CameraConfig> cameras_;
  std::vector<uint64_t> camera_every_;  // clock steps between a camera's frames
  CameraSystemOptions options_;
  bridge::Bus* bus_ = nullptr;

  // the newest state (bus thread)
  std::map<std::string, Eigen::Isometry3d> poses_W_;
  int64_t latest_stamp_ns_ = -1;
  int64_t latest_sent_unix_ns_ = 0;

  // hand-over between the bus thread and the drawing thread
  std::thread worker_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::optional<FrameRequest> request_;  // set by Step, cleared once its frame is published
  bool done_ = false;                    // the request's frame is drawn (done_frames_)
  std::vector<EyeFrame> done_frames_;
  double done_draw_ms_ = 0.0;
  bool system_ready_ = false;
  bool stop_ = false;
  std::exception_ptr worker_error_;
  std::string renderer_description_;

  // figures (bus thread)
  uint64_t frames_ = 0, images_ = 0, png_bytes_ = 0, frames_skipped_busy_ = 0, frames_without_state_ = 0;
  std::map<std::pair<size_t, size_t>, uint64_t> images_per_eye_;
  std::vector<double> draw_ms_, latency_ms_;
  Clock::time_point first_request_, last_publish_;
};

}  // namespace
}  // namespace iapsim::render

int main(int argc, char** argv) {
  return iapsim::bridge::ProcessMainFor<iapsim::render::RenderNode>(
      argc, argv, "iapsim render: camera images of the scene at each physics state, stamped with its stamp");
}
