#include "physics/uncertainty.h"

#include <cmath>
#include <cstdio>
#include <random>

#include "model/vehicle.h"
#include "physics/random.h"
#include "physics/simulation.h"

namespace iapsim::physics {
namespace {

using bridge::YamlMap;

// the streams' indices, far above those of the vehicles' other streams (64 per vehicle, simulation.cc)
constexpr uint64_t kFirstStream = uint64_t{1} << 40;
constexpr uint64_t kStreamsPerVehicle = 8;
enum Quantity : uint64_t { kMass, kInertia, kPlatformCom, kThrust, kTorque, kMotorTime };

// How far an error may go: relative errors must keep the value positive even at 3σ.
struct Limits {
  bool vector;     // three axes (else one number)
  bool relative;   // a factor 1 + e on a positive value
  double largest;  // |fixed error| and half-width below it (relative: strictly)
  double largest_sigma;
};

std::string Number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

double ReadNumber(const YAML::Node& node, const YamlMap& map, const std::string& key,
                  const std::string& what) {
  double value = 0.0;
  if (!node.IsScalar() || !YAML::convert<double>::decode(node, value)) map.Fail(key, "expected " + what);
  if (!std::isfinite(value))
    map.Fail(key, "expected a finite number (" + what + "), got '" + node.Scalar() + "'");
  return value;
}

// a number, or [x, y, z] for a vector quantity (a number there applies to every axis of a distribution)
Eigen::Vector3d ReadValue(const YAML::Node& node, const YamlMap& map, const std::string& key, bool vector,
                          bool allow_scalar, const std::string& what) {
  if (vector && node.IsSequence()) {
    if (node.size() != 3) map.Fail(key, "expected three numbers [x, y, z] (" + what + ")");
    return {ReadNumber(node[0], map, key, what), ReadNumber(node[1], map, key, what),
            ReadNumber(node[2], map, key, what)};
  }
  if (vector && !allow_scalar) map.Fail(key, "expected three numbers [x, y, z] (" + what + ")");
  return Eigen::Vector3d::Constant(ReadNumber(node, map, key, what));
}

ParameterError ReadError(YamlMap& map, const std::string& key, const Limits& limits) {
  ParameterError error;
  const YAML::Node node = map.Raw(key);  // known, for the spelling suggestions of unknown keys
  if (!node) return error;
  const std::string unit = limits.relative ? "a relative error" : "an error";
  const std::string range =
      limits.relative ? "in (−1, 1)" : "of at most " + Number(limits.largest) + " in size";
  if (!node.IsMap()) {  // a fixed error
    error.kind = ParameterError::Kind::kFixed;
    error.value = ReadValue(node, map, key, limits.vector, false,
                            unit + " " + range + ", or {normal: σ} or {uniform: half-width}");
    const double size = error.value.cwiseAbs().maxCoeff();
    if (!(limits.relative ? size < limits.largest : size <= limits.largest)) {
      map.Fail(key, "expected " + unit + " " + range + ", got " + YAML::Dump(node));
    }
    map.SetResolved(key, node);
    return error;
  }
  YamlMap distribution = map.Map(key);
  const std::vector<std::string> keys = distribution.Keys();
  if (keys.size() != 1 || (keys[0] != "normal" && keys[0] != "uniform")) {
    map.Fail(key, "expected one of {normal: σ} or {uniform: half-width}");
  }
  const bool normal = keys[0] == "normal";
  const bool strict = limits.relative && !normal;  // a relative half-width of 1 could make a value zero
  error.kind = normal ? ParameterError::Kind::kNormal : ParameterError::Kind::kUniform;
  const double largest = normal ? limits.largest_sigma : limits.largest;
  const std::string what = normal ? "a standard deviation in [0, " + Number(largest) + "]"
                                  : "a half-width in [0, " + Number(largest) + (strict ? ")" : "]");
  error.value = ReadValue(distribution.Raw(keys[0]), distribution, keys[0], limits.vector, true, what);
  if (!(error.value.minCoeff() >= 0.0 &&
        (strict ? error.value.maxCoeff() < largest : error.value.maxCoeff() <= largest))) {
    distribution.Fail(keys[0], "expected " + what);
  }
  distribution.SetResolved(keys[0], distribution.Raw(keys[0]));
  distribution.Finish();
  return error;
}

// The error of one axis: a normal draw is redrawn beyond 3σ (so a relative error keeps its value positive).
double Draw(const ParameterError& error, int axis, std::mt19937_64& random) {
  switch (error.kind) {
    case ParameterError::Kind::kNone:
      return 0.0;
    case ParameterError::Kind::kFixed:
      return error.value[axis];
    case ParameterError::Kind::kNormal: {
      double n = StandardNormal(random);
      while (std::abs(n) > 3.0) n = StandardNormal(random);
      return error.value[axis] * n;
    }
    case ParameterError::Kind::kUniform:
      return error.value[axis] * SymmetricUniform(random);
  }
  return 0.0;
}

// The vehicle file's part that a description link is built from, or nullptr (a hand-written URDF's own link).
model::MassProperties* PartMass(model::Vehicle& vehicle, const model::MultibodyDescription& description,
                                size_t link) {
  if (link == 0) return &vehicle.platform;
  const std::string& name = description.links[link].name;
  for (auto& tool : vehicle.tools) {
    if (tool.name == name) return &tool.mass;
  }
  for (auto& sub : vehicle.sub_aircraft) {
    if (sub.name == name) return &sub.mass;
  }
  return nullptr;
}

}  // namespace

UncertaintyConfig ReadUncertainty(YamlMap& map) {
  UncertaintyConfig config;
  const Limits relative{false, true, 1.0, 0.3};
  config.mass = ReadError(map, "mass", relative);
  config.inertia = ReadError(map, "inertia", relative);
  config.platform_com_P_m = ReadError(map, "platform_com_P_m", {true, false, 1.0, 1.0});
  config.thrust_coefficient = ReadError(map, "thrust_coefficient", relative);
  config.torque_coefficient = ReadError(map, "torque_coefficient", relative);
  config.motor_time_constant = ReadError(map, "motor_time_constant", relative);
  config.wind_W_mps = ReadError(map, "wind_W_mps", {true, false, 30.0, 10.0});
  map.Finish();
  config.enabled = true;
  return config;
}

std::vector<DrawnParameter> DrawTrueModel(const UncertaintyConfig& uncertainty, uint64_t seed,
                                          SimulationConfig* config) {
  std::vector<DrawnParameter> drawn;
  if (!uncertainty.enabled) return drawn;
  for (size_t v = 0; v < config->vehicles.size(); ++v) {
    VehicleSpec& spec = config->vehicles[v];
    spec.flight_controller_model = spec.vehicle;  // the file's values, before the draw
    auto stream = [&](Quantity quantity) {
      return std::mt19937_64(StreamSeed(seed, kFirstStream + v * kStreamsPerVehicle + quantity));
    };
    const std::string prefix = spec.name + "/";

    std::mt19937_64 mass_random = stream(kMass), inertia_random = stream(kInertia);
    for (size_t l = 0; l < spec.description.links.size(); ++l) {
      model::LinkDescription& link = spec.description.links[l];
      const double mass_factor = 1.0 + Draw(uncertainty.mass, 0, mass_random);
      const double inertia_factor = mass_factor * (1.0 + Draw(uncertainty.inertia, 0, inertia_random));
      if (uncertainty.mass.active()) {
        drawn.push_back(
            {prefix + link.name + "/mass_kg", link.mass.mass_kg, link.mass.mass_kg * mass_factor});
      }
      if (uncertainty.mass.active() || uncertainty.inertia.active()) {
        const double trace = link.mass.inertia_B_kgm2.trace();
        drawn.push_back({prefix + link.name + "/inertia_trace_kgm2", trace, trace * inertia_factor});
      }
      for (model::MassProperties* mass : {&link.mass, PartMass(spec.vehicle, spec.description, l)}) {
        if (mass == nullptr) continue;
        mass->mass_kg *= mass_factor;
        mass->inertia_B_kgm2 *= inertia_factor;
      }
    }

    if (uncertainty.platform_com_P_m.active()) {
      std::mt19937_64 random = stream(kPlatformCom);
      model::LinkDescription& platform = spec.description.links[0];
      for (int axis = 0; axis < 3; ++axis) {
        const double offset_m = Draw(uncertainty.platform_com_P_m, axis, random);
        drawn.push_back({prefix + platform.name + "/com_P_m/" + "xyz"[axis], platform.mass.com_B_m[axis],
                         platform.mass.com_B_m[axis] + offset_m});
        platform.mass.com_B_m[axis] += offset_m;
        spec.vehicle.platform.com_B_m[axis] += offset_m;
      }
    }

    std::mt19937_64 thrust_random = stream(kThrust), torque_random = stream(kTorque),
                    time_random = stream(kMotorTime);
    for (model::SubAircraft& sub : spec.vehicle.sub_aircraft) {
      model::RotorSet& rotors = sub.rotors;
      const std::string part = prefix + sub.name + "/";
      const double thrust_factor = 1.0 + Draw(uncertainty.thrust_coefficient, 0, thrust_random);
      const double torque_factor = 1.0 + Draw(uncertainty.torque_coefficient, 0, torque_random);
      const double time_factor = 1.0 + Draw(uncertainty.motor_time_constant, 0, time_random);
      if (uncertainty.thrust_coefficient.active()) {
        drawn.push_back({part + "thrust_coefficient", rotors.thrust_coefficient,
                         rotors.thrust_coefficient * thrust_factor});
      }
      if (uncertainty.torque_coefficient.active()) {
        drawn.push_back({part + "torque_coefficient", rotors.torque_coefficient,
                         rotors.torque_coefficient * torque_factor});
      }
      if (uncertainty.motor_time_constant.active()) {
        drawn.push_back({part + "motor_time_constant_s", rotors.motor_time_constant_s,
                         rotors.motor_time_constant_s * time_factor});
      }
      rotors.thrust_coefficient *= thrust_factor;
      rotors.torque_coefficient *= torque_factor;
      rotors.motor_time_constant_s *= time_factor;
      rotors.electric.time_constant_up_s *= time_factor;
      rotors.electric.time_constant_down_s *= time_factor;
    }
  }

  if (uncertainty.wind_W_mps.active()) {
    std::mt19937_64 random(StreamSeed(seed, kFirstStream - 1));
    for (int axis = 0; axis < 3; ++axis) {
      const double nominal = config->air.wind_W_mps[axis];
      config->air.wind_W_mps[axis] += Draw(uncertainty.wind_W_mps, axis, random);
      drawn.push_back(
          {std::string("air/wind_W_mps/") + "xyz"[axis], nominal, config -> air.wind_W_mps[axis]});
    }
  }
  return drawn;
}

}  // namespace iapsim::physics
