// Data sets in D4RL's layout: what is written is read back (here and by h5py), an unfinished file is never
// left looking complete, and a file that is not a data set is a clear error.
#include "rl/dataset.h"

#include <gtest/gtest.h>
#include <hdf5.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "rl/docking_expert.h"
#include "rl/docking_task.h"
#include "tests/support/test_folder.h"

namespace iapsim::rl {
namespace {

std::vector<EpisodeResult> TwoShortEpisodes() {
  const DockingTaskConfig task = ReadDockingTask(std::string(IAPSIM_SOURCE_DIR) + "/configs/rl/docking.yaml",
                                                 {"termination.max_steps=50"});
  return RunEpisodes(task, [](const DockingEnv& env) { return std::make_unique<DockingExpert>(env); }, 2, 9,
                     1, {0, 0, true});
}

std::string ErrorOf(const std::string& path) {
  try {
    ReadDataset(path);
  } catch (const std::runtime_error& error) {
    return error.what();
  }
  return "no error";
}

TEST(Dataset, WhatIsWrittenIsReadBackInEpisodeOrder) {
  test_support::TestFolder folder("dataset");
  const std::string path = (folder.path() / "expert.hdf5").string();
  const std::vector<EpisodeResult> episodes = TwoShortEpisodes();
  DatasetWriter writer(path);
  for (const EpisodeResult& episode : episodes) writer.Append(episode.transitions);
  EXPECT_EQ(writer.size(), 100);
  EXPECT_FALSE(std::filesystem::exists(path));  // only the .partial file until it is closed
  writer.Close({"docking.yaml", "docking_approach.yaml", "expert", 9, 2, 200.0});
  EXPECT_TRUE(std::filesystem::exists(path));
  EXPECT_FALSE(std::filesystem::exists(path + ".partial"));

  const Dataset data = ReadDataset(path);
  ASSERT_EQ(data.size(), 100);
  for (int e = 0; e < 2; ++e) {
    const Transitions& t = episodes[e].transitions;
    for (int k = 0; k < 50; ++k) {
      const int row = 50 * e + k;
      EXPECT_EQ(data.observations.row(row), t.observations[k].transpose().cast<float>());
      EXPECT_EQ(data.next_observations.row(row), t.next_observations[k].transpose().cast<float>());
      EXPECT_EQ(data.actions.row(row), t.actions[k].transpose().cast<float>());
      EXPECT_EQ(data.rewards[row], static_cast<float>(t.rewards[k]));
      EXPECT_EQ(data.terminals[row], 0);
      EXPECT_EQ(data.timeouts[row], k == 49 ? 1 : 0);  // 50 steps: truncated
      EXPECT_EQ(data.successes[row], 0);
    }
    // a transition's next observation is the next one's observation within an episode
    EXPECT_EQ(data.next_observations.row(50 * e + 10), data.observations.row(50 * e + 11));
  }
  EXPECT_EQ(data.attributes.policy, "expert");
  EXPECT_EQ(data.attributes.seed, 9u);
  EXPECT_EQ(data.attributes.episodes, 2);
  EXPECT_EQ(data.attributes.control_rate_hz, 200.0);

  // h5py (python3-h5py, installed with the project) reads the same file, booleans as numpy bool
  const std::string script =
      "import h5py, numpy; f = h5py.File('" + path +
      "', 'r'); print(f['observations'].shape, f['actions'].dtype, f['terminals'].dtype,"
      " int(f['timeouts'][()].sum()), f.attrs['policy'].decode()"
      " if isinstance(f.attrs['policy'], bytes) else f.attrs['policy'])";
  FILE* python = popen(("/usr/bin/python3 -c \"" + script + "\" 2>&1").c_str(), "r");
  ASSERT_NE(python, nullptr);
  char line[256] = {0};
  ASSERT_NE(fgets(line, sizeof(line), python), nullptr);
  EXPECT_EQ(pclose(python), 0) << line;
  EXPECT_EQ(std::string(line), "(100, 48) float32 bool 2 expert\n");
}

TEST(Dataset, AnUnfinishedDataSetLeavesNothingBehind) {
  test_support::TestFolder folder("dataset_unfinished");
  const std::string path = (folder.path() / "cut.hdf5").string();
  {
    DatasetWriter writer(path);
    writer.Append(TwoShortEpisodes()[0].transitions);
  }
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_FALSE(std::filesystem::exists(path + ".partial"));
  EXPECT_THROW(DatasetWriter((folder.path() / "no/such/folder/x.hdf5").string()), std::runtime_error);
}

TEST(Dataset, AFileThatIsNotADataSetIsAnErrorNamingItAndTheField) {
  test_support::TestFolder folder("dataset_bad");
  EXPECT_NE(ErrorOf(folder.Write("text.hdf5", "not hdf5 at all\n")).find("text.hdf5: not an HDF5 file"),
            std::string::npos);
  EXPECT_NE(ErrorOf((folder.path() / "absent.hdf5").string()).find("absent.hdf5: no such data set file"),
            std::string::npos);

  // observations of the wrong width
  const std::string narrow = (folder.path() / "narrow.hdf5").string();
  {
    const hid_t file = H5Fcreate(narrow.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    const hsize_t dims[2] = {3, 47};
    const hid_t space = H5Screate_simple(2, dims, nullptr);
    const hid_t dataset =
        H5Dcreate2(file, "observations", H5T_IEEE_F32LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    H5Dclose(dataset);
    H5Sclose(space);
    H5Fclose(file);
  }
  const std::string error = ErrorOf(narrow);
  EXPECT_NE(error.find("narrow.hdf5: observations: expected [N, 48], got rank 2 with 47 columns"),
            std::string::npos)
      << error;

  // a data set cut short (the first half of a good file)
  const std::string good = (folder.path() / "good.hdf5").string();
  DatasetWriter writer(good);
  writer.Append(TwoShortEpisodes()[0].transitions);
  writer.Close({});
  const auto size = std::filesystem::file_size(good);
  std::filesystem::resize_file(good, size / 2);
  EXPECT_NE(ErrorOf(good).find("good.hdf5"), std::string::npos);
}

}  // namespace
}  // namespace iapsim::rl
