// `iapsim sweep`'s file and expansion (tools/sweep.h): the runs, their order and their stable ids. The pool,
// the tables and --resume are exercised end to end by tests/sweep_test.sh.

#include "tools/sweep.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>

#include "bridge/config.h"

namespace iapsim::tools {
namespace {

namespace fs = std::filesystem;

class SweepFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("iapsim-sweep-" + std::to_string(getpid()));
    fs::create_directories(dir_);
    std::ofstream(dir_ / "scenario.yaml") << "name: s\n";
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Write(const std::string& name, const std::string& text) {
    const fs::path path = dir_ / name;
    std::ofstream(path) << text;
    return path.string();
  }

  fs::path dir_;
};

TEST_F(SweepFile, GridPointsTimesSeedsTheLastKeyFastest) {
  const SweepSpec spec = ReadSweep(Write("a.yaml",
                                         "scenario: scenario.yaml\n"
                                         "set: {duration_s: 1}\n"
                                         "grid:\n"
                                         "  a: [1, 2]\n"
                                         "  b: [x, [1, 2]]\n"
                                         "seeds: [7, 8]\n"));
  EXPECT_EQ(spec.scenario, fs::absolute(dir_ / "scenario.yaml").lexically_normal().string());
  const std::vector<SweepRun> runs = ExpandSweep(spec);
  ASSERT_EQ(runs.size(), 8u);
  EXPECT_EQ(runs[0].overrides, (std::vector<std::string>{"duration_s=1", "a=1", "b=x", "seed=7"}));
  EXPECT_EQ(runs[1].overrides, (std::vector<std::string>{"duration_s=1", "a=1", "b=x", "seed=8"}));
  EXPECT_EQ(runs[2].overrides, (std::vector<std::string>{"duration_s=1", "a=1", "b=[1, 2]", "seed=7"}));
  EXPECT_EQ(runs[7].overrides, (std::vector<std::string>{"duration_s=1", "a=2", "b=[1, 2]", "seed=8"}));
  std::set<std::string> ids, groups;
  for (size_t i = 0; i < runs.size(); ++i) {
    EXPECT_EQ(runs[i].index, i);
    EXPECT_EQ(runs[i].id.size(), 12u);
    ids.insert(runs[i].id);
    groups.insert(runs[i].group);
    // the runs of a group differ only by seed
    EXPECT_EQ(runs[i].group, runs[i - i % 2].group);
  }
  EXPECT_EQ(ids.size(), 8u);
  EXPECT_EQ(groups.size(), 4u);
}

// An id is the run's settings: the same in another order of the file, different with another common setting.
TEST_F(SweepFile, IdsAreTheRunsSettings) {
  const auto ids = [&](const std::string& text) {
    std::set<std::string> out;
    for (const SweepRun& run : ExpandSweep(ReadSweep(Write("f.yaml", text)))) out.insert(run.id);
    return out;
  };
  const auto a = ids("scenario: scenario.yaml\ngrid: {a: [1, 2], b: [3]}\nseeds: [1]\n");
  EXPECT_EQ(a, ids("scenario: scenario.yaml\nseeds: [1]\ngrid: {b: [3], a: [2, 1]}\n"));
  EXPECT_NE(a, ids("scenario: scenario.yaml\nset: {duration_s: 2}\ngrid: {a: [1, 2], b: [3]}\nseeds: [1]\n"));
  EXPECT_NE(a, ids("scenario: scenario.yaml\ngrid: {a: [1, 2], b: [3]}\nseeds: [2]\n"));
}

// Draws: seeded (the same every time), within their laws, the same draws for every grid point.
TEST_F(SweepFile, RandomDrawsAreSeededAndWithinTheirLaws) {
  const std::string text =
      "scenario: scenario.yaml\n"
      "grid: {g: [1, 2]}\n"
      "random:\n"
      "  draws: 200\n"
      "  seed: 5\n"
      "  keys: {u: {uniform: [0.5, 1.5]}, n: {normal: [10.0, 0.1]}, c: {choice: [p, q, r]}}\n";
  const std::vector<SweepRun> runs = ExpandSweep(ReadSweep(Write("r.yaml", text)));
  ASSERT_EQ(runs.size(), 400u);
  const std::vector<SweepRun> again = ExpandSweep(ReadSweep(Write("r2.yaml", text)));
  std::set<std::string> choices;
  double sum_n = 0.0;
  for (size_t i = 0; i < 200; ++i) {
    const auto& values = runs[i].values;
    ASSERT_EQ(values.size(), 4u);
    EXPECT_EQ(values[0], (std::pair<std::string, std::string>{"g", "1"}));
    const double u = std::stod(values[1].second), n = std::stod(values[2].second);
    EXPECT_GE(u, 0.5);
    EXPECT_LT(u, 1.5);
    sum_n += n;
    choices.insert(values[3].second);
    EXPECT_EQ(runs[200 + i].values[1], values[1]);  // grid point 2 flies the same draws
    EXPECT_EQ(again[i].id, runs[i].id);
  }
  EXPECT_NEAR(sum_n / 200, 10.0, 0.03);  // 4 standard errors
  EXPECT_EQ(choices, (std::set<std::string>{"p", "q", "r"}));
}

TEST_F(SweepFile, SlurmBlockGivesTheArraysOptions) {
  const SweepSpec spec = ReadSweep(Write("s.yaml",
                                         "scenario: scenario.yaml\n"
                                         "slurm: {partition: gpu, time: \"00:05:00\", cpus_per_run: 2,\n"
                                         "        sbatch: [--qos=short, --exclusive]}\n"));
  EXPECT_EQ(spec.slurm.partition, "gpu");
  EXPECT_EQ(spec.slurm.time, "00:05:00");
  EXPECT_EQ(spec.slurm.cpus_per_task, 2);
  EXPECT_EQ(spec.slurm.sbatch_args, (std::vector<std::string>{"--qos=short", "--exclusive"}));
  EXPECT_EQ(ReadSweep(Write("d.yaml", "scenario: scenario.yaml\n")).slurm.cpus_per_task, 1);
}

TEST_F(SweepFile, MistakesNameTheFileLineAndKey) {
  const struct {
    std::string text, expect;
  } cases[] = {
      {"grid: {a: [1]}\n", "scenario: is required"},
      {"scenario: nope.yaml\n", "no such file"},
      {"scenario: scenario.yaml\ngrid: {a: 1}\n", "grid.a: expected a non-empty list of values"},
      {"scenario: scenario.yaml\ngrid: {a: [1, 1]}\n", "the value 1 is given twice"},
      {"scenario: scenario.yaml\nseeds: [1, -2]\n", "seeds: expected non-negative integers, got '-2'"},
      {"scenario: scenario.yaml\nrandom: {draws: 2, keys: {a: {uniform: [2, 1]}}}\n", "lo < hi"},
      {"scenario: scenario.yaml\nrandom: {draws: 2, keys: {a: {gauss: [2, 1]}}}\n", "random.keys.a"},
      {"scenario: scenario.yaml\ngrid: {a: [1]}\nrandom: {draws: 2, keys: {a: {choice: [1]}}}\n",
       "'a' is both in the grid and drawn"},
      {"scenario: scenario.yaml\ngrdi: {a: [1]}\n", "grdi"},
      {"scenario: scenario.yaml\njobs: 0\n", "jobs: must be in [1, 1024]"},
      {"scenario: scenario.yaml\nslurm: {cpus_per_run: 0}\n", "slurm.cpus_per_run"},
      {"scenario: scenario.yaml\nslurm: {sbatch: [qos=short]}\n", "each starting with -), got 'qos=short'"},
      {"scenario: scenario.yaml\nslurm: {partiton: a}\n", "partiton"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.text);
    const std::string path = Write("bad.yaml", c.text);
    try {
      ReadSweep(path);
      ADD_FAILURE() << "accepted";
    } catch (const bridge::ConfigError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(c.expect), std::string::npos) << what;
      EXPECT_NE(what.find(path), std::string::npos) << what;
    }
  }
}

}  // namespace
}  // namespace iapsim::tools
