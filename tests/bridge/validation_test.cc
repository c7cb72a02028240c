// Issue 20's validation rules on real configuration: every number a run reads (the scenario's keys, each
// process's params as its --check resolves them, the vehicle's) refuses .nan with the file, the line and the
// key; a key or a process given twice is refused with both lines; an oversized file is refused before it is
// parsed; `iapsim run --check` validates the whole graph without running it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "bridge/config.h"
#include "bridge/launcher.h"
#include "bridge/scenario.h"
#include "model/vehicle.h"

namespace iapsim::bridge {
namespace {

namespace fs = std::filesystem;

using KeyPath = std::vector<std::string>;  // map keys and list indices, from the document's root

std::string Dotted(const KeyPath& path) {
  std::string out;
  for (const auto& part : path) out += (out.empty() ? "" : ".") + part;
  return out;
}

// Every scalar under `node` that reads as a number, with where it is.
void NumericScalars(const YAML::Node& node, const KeyPath& path,
                    std::vector<std::pair<KeyPath, YAML::Mark>>* out) {
  if (node.IsMap()) {
    for (const auto& entry : node) {
      KeyPath child = path;
      child.push_back(entry.first.Scalar());
      NumericScalars(entry.second, child, out);
    }
  } else if (node.IsSequence()) {
    for (size_t i = 0; i < node.size(); ++i) {
      KeyPath child = path;
      child.push_back(std::to_string(i));
      NumericScalars(node[i], child, out);
    }
  } else if (double value; node.IsScalar() && YAML::convert<double>::decode(node, value)) {
    out->emplace_back(path, node.Mark());
  }
}

std::string ReadText(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// `text` with the number that starts at `mark` replaced by ".nan".
std::string WithNan(const std::string& text, const YAML::Mark& mark) {
  const size_t start = static_cast<size_t>(mark.pos);
  const size_t end = text.find_first_of(",]} #\n", start);
  return text.substr(0, start) + ".nan" + text.substr(end);
}

// The error a check gives (empty when it passes).
template <class Check>
std::string ErrorOf(Check check) {
  try {
    check();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

// what a process's --check prints on stderr when it fails (exit 2), or "exit N" otherwise
std::string NodeCheckError(const std::string& exec, const fs::path& scenario, const std::string& node,
                           const fs::path& err) {
  const std::string command = ExecutableDir() + "/" + exec + " --check --scenario " + scenario.string() +
                              " --node " + node + " > /dev/null 2> " + err.string();
  const int status = std::system(command.c_str());
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return code == 2 ? ReadText(err) : "exit " + std::to_string(code);
}

// The key that holds a number: the last name of its path (a list entry's list)
std::string KeyOf(const KeyPath& path) {
  for (auto part = path.rbegin(); part != path.rend(); ++part) {
    if (part->find_first_not_of("0123456789") != std::string::npos) return *part;
  }
  return "";
}

// `error` names the file and the line of the number, the key, and what was expected of it.
void ExpectRefusedAt(const std::string& error, const fs::path& file, const YAML::Mark& mark,
                     const KeyPath& path) {
  const std::string where = file.string() + ":" + std::to_string(mark.line + 1) + ":";
  EXPECT_NE(error.find(where), std::string::npos) << Dotted(path) << " = .nan: " << error;
  EXPECT_NE(error.find(KeyOf(path)), std::string::npos) << Dotted(path) << " = .nan: " << error;
  EXPECT_TRUE(error.find("expected a finite number") != std::string::npos ||
              error.find("expected an integer") != std::string::npos)
      << Dotted(path) << " = .nan: " << error;
}

class Validation : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("iapsim-validation-" + std::to_string(getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }

  // A file of `text` in the test's folder.
  fs::path Write(const std::string& name, const std::string& text) {
    const fs::path path = dir_ / name;
    std::ofstream(path) << text;
    return path;
  }

  fs::path dir_;
};

// The spiral's full configuration as a run resolves it (every default written out, every process's params
// included), in both fidelity profiles (the realistic one adds the air, the actuation, delays and sensor
// noise): each of its numbers set to .nan is refused where it stands.
class ValidationOf : public Validation, public ::testing::WithParamInterface<std::string> {};

TEST_P(ValidationOf, NanInAnyNumberOfTheScenarioIsRefusedWithItsLineAndKey) {
  LaunchOptions options;
  options.scenario_path = std::string(IAPSIM_SOURCE_DIR) + "/configs/regression/three_star_spiral.yaml";
  options.overrides = {"duration_s=0.01", "lead_in_s=0.002", "fidelity=" + GetParam()};
  options.out_dir = (dir_ / "run").string();
  options.bin_dir = ExecutableDir();
  const LaunchResult run = Launch(options);
  ASSERT_EQ(run.exit_code, 0) << run.message;
  const fs::path resolved = fs::path(run.run_dir) / "scenario.resolved.yaml";
  const std::string text = ReadText(resolved);
  const YAML::Node root = LoadYamlFile(resolved.string());
  std::vector<std::pair<KeyPath, YAML::Mark>> numbers;
  NumericScalars(root, {}, &numbers);
  ASSERT_GT(numbers.size(), 100u);

  int in_params = 0;
  for (const auto& [path, mark] : numbers) {
    const fs::path copy = Write("nan.yaml", WithNan(text, mark));
    std::string error;
    if (path.size() > 3 && path[0] == "processes" && path[2] == "params") {
      ++in_params;
      error = NodeCheckError(root["processes"][path[1]]["exec"].Scalar(), copy, path[1], dir_ / "err.txt");
    } else {
      error = ErrorOf([&] { LoadScenario(copy.string()); });
    }
    ExpectRefusedAt(error, copy, mark, path);
  }
  std::printf("%s: %zu numbers refused as .nan, %d of them in process params\n", GetParam().c_str(),
              numbers.size(), in_params);
  EXPECT_GT(in_params, 50);
}

INSTANTIATE_TEST_SUITE_P(, ValidationOf, ::testing::Values("ideal", "realistic"));

// The three-star and the F450 it is built of (a copy of both, side by side as in configs/vehicles/).
TEST_F(Validation, NanInAnyNumberOfTheVehicleIsRefusedWithItsLineAndKey) {
  const fs::path source = std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/";
  fs::create_directories(dir_ / "parts");
  const std::string vehicle_text = ReadText(source / "three_star.yaml");
  const std::string part_text = ReadText(source / "parts/f450.yaml");
  const fs::path vehicle = Write("three_star.yaml", vehicle_text);
  const fs::path part = Write("parts/f450.yaml", part_text);
  ASSERT_EQ(ErrorOf([&] { model::LoadVehicle(vehicle.string()); }), "");
  size_t count = 0;
  for (const auto& [file, text] : {std::pair{vehicle, vehicle_text}, std::pair{part, part_text}}) {
    std::vector<std::pair<KeyPath, YAML::Mark>> numbers;
    NumericScalars(LoadYamlFile(file.string()), {}, &numbers);
    count += numbers.size();
    for (const auto& [path, mark] : numbers) {
      Write(fs::relative(file, dir_).string(), WithNan(text, mark));
      ExpectRefusedAt(ErrorOf([&] { model::LoadVehicle(vehicle.string()); }), file, mark, path);
    }
    Write(fs::relative(file, dir_).string(), text);
  }
  std::printf("%zu numbers of the vehicle refused as .nan\n", count);
  EXPECT_GT(count, 40u);
}

TEST_F(Validation, AKeyOrAProcessGivenTwiceIsRefusedWithBothLines) {
  const auto expect_refused = [](const fs::path& file, const std::string& expected) {
    const std::string error = ErrorOf([&] { LoadScenario(file.string()); });
    EXPECT_NE(error.find(file.string() + expected), std::string::npos) << error;
  };
  expect_refused(Write("twice.yaml",
                       "name: twice\n"
                       "duration_s: 1\n"
                       "duration_s: 2\n"
                       "processes:\n"
                       "  physics: {exec: iapsim_physics, role: clock}\n"),
                 ":3:1: duration_s: given twice (first at line 2)");
  expect_refused(Write("processes.yaml",
                       "name: twice\n"
                       "processes:\n"
                       "  physics: {exec: iapsim_physics, role: clock}\n"
                       "  control: {exec: iapsim_control}\n"
                       "  physics: {exec: iapsim_physics}\n"),
                 ":5:3: processes.physics: given twice (first at line 3)");
}

// `base: FILE`: the base's keys with the scenario's laid over them, map by map; an error in the base names
// the base; a base elsewhere or a cycle is refused.
TEST_F(Validation, ABaseScenarioIsLaidUnderTheScenario) {
  Write("base.yaml",
        "name: base\n"
        "duration_s: 2\n"
        "processes:\n"
        "  physics: {exec: iapsim_physics, role: clock, params: {a: 1, b: 2}}\n"
        "  control: {exec: iapsim_control, rate_hz: 100}\n");
  const Scenario derived = LoadScenario(Write("derived.yaml",
                                              "base: base.yaml\n"
                                              "name: derived\n"
                                              "processes:\n"
                                              "  physics: {params: {b: 3}}\n"
                                              "  extra: {exec: iapsim_control, after: [control]}\n")
                                            .string());
  EXPECT_EQ(derived.name, "derived");
  EXPECT_DOUBLE_EQ(derived.duration_s, 2.0);
  ASSERT_EQ(derived.processes.size(), 4u);  // the base's two (in its order), the new one and the recorder
  EXPECT_EQ(derived.processes[0].name, "physics");
  EXPECT_EQ(derived.processes[0].params["a"].as<int>(), 1);
  EXPECT_EQ(derived.processes[0].params["b"].as<int>(), 3);
  EXPECT_DOUBLE_EQ(derived.processes[1].rate_hz, 100.0);
  EXPECT_EQ(derived.processes[2].name, "extra");
  // `~` removes a key of the base (and only one it has)
  const Scenario trimmed = LoadScenario(
      Write("trimmed.yaml",
            "base: base.yaml\nname: trimmed\nprocesses:\n  physics: {params: {a: ~}}\n  control: ~\n")
          .string());
  ASSERT_EQ(trimmed.processes.size(), 2u);  // physics and the recorder
  EXPECT_FALSE(trimmed.processes[0].params["a"].IsDefined());
  EXPECT_EQ(trimmed.processes[0].params["b"].as<int>(), 2);
  const std::string absent = ErrorOf([&] {
    LoadScenario(Write("absent.yaml", "base: base.yaml\nname: x\nprocesses:\n  physics: {c: ~}\n").string());
  });
  EXPECT_NE(absent.find("absent.yaml:4:"), std::string::npos) << absent;
  EXPECT_NE(absent.find("processes.physics.c: ~ removes a key of the base"), std::string::npos)
      << absent;

  Write("broken.yaml", "name: broken\nduration_s: .nan\n");
  const std::string broken =
      ErrorOf([&] { LoadScenario(Write("on_broken.yaml", "base: broken.yaml\nname: x\n").string()); });
  EXPECT_NE(broken.find((dir_ / "broken.yaml").string() + ":2:"), std::string::npos) << broken;
  const std::string elsewhere =
      ErrorOf([&] { LoadScenario(Write("elsewhere.yaml", "base: ../base.yaml\nname: x\n").string()); });
  EXPECT_NE(elsewhere.find("base: must be a scenario beside this one"), std::string::npos) << elsewhere;
  Write("a.yaml", "base: b.yaml\nname: a\n");
  Write("b.yaml", "base: a.yaml\nname: b\n");
  const std::string cycle = ErrorOf([&] { LoadScenario((dir_ / "a.yaml").string()); });
  EXPECT_NE(cycle.find("(a cycle)"), std::string::npos) << cycle;
}

TEST_F(Validation, AnOversizedFileIsRefusedBeforeItIsParsed) {
  const fs::path big = Write("big.yaml", "name: big\n# " + std::string(kMaxYamlFileBytes, 'x') + "\n");
  const std::string error = ErrorOf([&] { LoadScenario(big.string()); });
  EXPECT_NE(error.find("a configuration file may have at most 2 MiB"), std::string::npos) << error;
}

TEST_F(Validation, CheckOnlyValidatesTheGraphAndStartsNothing) {
  LaunchOptions options;
  options.scenario_path = std::string(IAPSIM_SOURCE_DIR) + "/configs/regression/three_star_spiral.yaml";
  options.out_dir = (dir_ / "run").string();
  options.bin_dir = ExecutableDir();
  options.check_only = true;
  const LaunchResult valid = Launch(options);
  EXPECT_EQ(valid.exit_code, 0) << valid.message;
  EXPECT_TRUE(valid.run_dir.empty());
  EXPECT_FALSE(fs::exists(dir_ / "run"));
  // a process's param is checked by the process itself
  options.overrides = {"processes.control.params.gains.kp=[1, 2]"};
  const LaunchResult invalid = Launch(options);
  EXPECT_EQ(invalid.exit_code, 2);
  EXPECT_NE(invalid.message.find("kp"), std::string::npos) << invalid.message;
}

}  // namespace
}  // namespace iapsim::bridge
