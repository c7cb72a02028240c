#include "rl/dataset.h"

#include <hdf5.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <stdexcept>
#include <utility>

namespace iapsim::rl {
namespace {

constexpr hsize_t kChunkRows = 4096;
const char* const kObservationLayout =
    "A then B: position error to target (3, W, m), velocity (3, W, m/s), R_WP row-major (9), body rate (3, "
    "P, rad/s), acceleration (3, W, m/s^2); contact wrench on B in its P: force (3, N), moment (3, N m)";
const char* const kActionLayout =
    "A then B, in [-1, 1]: linear acceleration (3, W, x max_acceleration_mps2), angular acceleration (3, P, "
    "x max_angular_acceleration_radps2)";

// An HDF5 identifier closed with its own function when it goes.
class Handle {
 public:
  Handle() = default;
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  Handle(Handle&& other) noexcept : id_(std::exchange(other.id_, H5I_INVALID_HID)), close_(other.close_) {}
  Handle& operator=(Handle&& other) noexcept {
    if (this != &other) {
      Reset();
      id_ = std::exchange(other.id_, H5I_INVALID_HID);
      close_ = other.close_;
    }
    return *this;
  }
  ~Handle() { Reset(); }
  void Reset() {
    if (id_ >= 0 && close_ != nullptr) close_(id_);
    id_ = H5I_INVALID_HID;
  }
  hid_t get() const { return id_; }
  /// Gives the identifier up without closing it.
  hid_t Release() { return std::exchange(id_, H5I_INVALID_HID); }
  bool valid() const { return id_ >= 0; }

 private:
  hid_t id_ = H5I_INVALID_HID;
  herr_t (*close_)(hid_t) = nullptr;
};

// HDF5 prints its error stack to stderr by default; the errors here are exceptions with the file's name.
void SilenceHdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

// h5py's bool: an enum {FALSE = 0, TRUE = 1} over a signed byte.
Handle BoolType() {
  Handle type(H5Tenum_create(H5T_NATIVE_INT8), H5Tclose);
  const int8_t no = 0, yes = 1;
  H5Tenum_insert(type.get(), "FALSE", &no);
  H5Tenum_insert(type.get(), "TRUE", &yes);
  return type;
}

struct Field {
  const char* name;
  hsize_t columns;  // 0: one value a row (a 1-D data set)
  bool boolean;
};
const Field kFields[] = {
    {"observations", kObservationSize, false},
    {"actions", kActionSize, false},
    {"rewards", 0, false},
    {"next_observations", kObservationSize, false},
    {"terminals", 0, true},
    {"timeouts", 0, true},
    {"success", 0, true},
};

void WriteStringAttribute(hid_t file, const char* name, const std::string& value) {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type.get(), std::max<size_t>(value.size(), 1));
  H5Tset_strpad(type.get(), H5T_STR_NULLPAD);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attribute(H5Acreate2(file, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attribute.valid() || H5Awrite(attribute.get(), type.get(), value.c_str()) < 0) {
    throw std::runtime_error(std::string("cannot write the attribute ") + name);
  }
}

void WriteNumberAttribute(hid_t file, const char* name, hid_t type, const void* value) {
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attribute(H5Acreate2(file, name, type, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attribute.valid() || H5Awrite(attribute.get(), type, value) < 0) {
    throw std::runtime_error(std::string("cannot write the attribute ") + name);
  }
}

std::string ReadStringAttribute(hid_t file, const char* name) {
  if (H5Aexists(file, name) <= 0) return "";
  Handle attribute(H5Aopen(file, name, H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(attribute.get()), H5Tclose);
  if (H5Tget_class(type.get()) != H5T_STRING || H5Tis_variable_str(type.get()) > 0) return "";
  std::string value(H5Tget_size(type.get()), '\0');
  H5Aread(attribute.get(), type.get(), value.data());
  return value.substr(0, value.find('\0'));
}

template <typename T>
T ReadNumberAttribute(hid_t file, const char* name, hid_t type) {
  T value{};
  if (H5Aexists(file, name) > 0) {
    Handle attribute(H5Aopen(file, name, H5P_DEFAULT), H5Aclose);
    H5Aread(attribute.get(), type, &value);
  }
  return value;
}

}  // namespace

struct DatasetWriter::Impl {
  std::string path;
  std::string partial;
  Handle file;
  Handle bool_type;
  std::vector<Handle> datasets;
  hsize_t rows = 0;
  bool closed = false;

  void Append(size_t field, const void* data, hsize_t count) {
    const Field& f = kFields[field];
    const int rank = f.columns > 0 ? 2 : 1;
    const hsize_t extent[2] = {rows + count, f.columns};
    const hsize_t start[2] = {rows, 0};
    const hsize_t block[2] = {count, f.columns};
    const hid_t dataset = datasets[field].get();
    if (H5Dset_extent(dataset, extent) < 0) throw std::runtime_error(partial + ": cannot extend " + f.name);
    Handle file_space(H5Dget_space(dataset), H5Sclose);
    H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start, nullptr, block, nullptr);
    Handle memory_space(H5Screate_simple(rank, block, nullptr), H5Sclose);
    const hid_t type = f.boolean ? bool_type.get() : H5T_NATIVE_FLOAT;
    if (H5Dwrite(dataset, type, memory_space.get(), file_space.get(), H5P_DEFAULT, data) < 0) {
      throw std::runtime_error(partial + ": cannot write " + f.name + " (disk full?)");
    }
  }
};

DatasetWriter::DatasetWriter(const std::string& path) : impl_(std::make_unique<Impl>()) {
  SilenceHdf5();
  Impl& impl = *impl_;
  impl.path = path;
  impl.partial = path + ".partial";
  impl.file = Handle(H5Fcreate(impl.partial.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
  if (!impl.file.valid()) throw std::runtime_error(impl.partial + ": cannot create the data set file");
  impl.bool_type = BoolType();
  for (const Field& field : kFields) {
    const int rank = field.columns > 0 ? 2 : 1;
    const hsize_t dims[2] = {0, field.columns};
    const hsize_t max_dims[2] = {H5S_UNLIMITED, field.columns};
    const hsize_t chunk[2] = {kChunkRows, field.columns};
    Handle space(H5Screate_simple(rank, dims, max_dims), H5Sclose);
    Handle properties(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
    H5Pset_chunk(properties.get(), rank, chunk);
    const hid_t type = field.boolean ? impl.bool_type.get() : H5T_IEEE_F32LE;
    impl.datasets.emplace_back(H5Dcreate2(impl.file.get(), field.name, type, space.get(), H5P_DEFAULT,
                                          properties.get(), H5P_DEFAULT),
                               H5Dclose);
    if (!impl.datasets.back().valid()) {
      throw std::runtime_error(impl.partial + ": cannot create the data set " + field.name);
    }
  }
}

DatasetWriter::~DatasetWriter() {
  if (impl_->closed) return;
  impl_->datasets.clear();
  impl_->file.Reset();
  std::remove(impl_->partial.c_str());
}

int64_t DatasetWriter::size() const { return static_cast<int64_t>(impl_->rows); }

void DatasetWriter::Append(const Transitions& transitions) {
  Impl& impl = *impl_;
  if (impl.closed) throw std::logic_error(impl.path + ": the data set is closed");
  const hsize_t n = transitions.size();
  if (n == 0) return;
  const auto rows = [n](const std::vector<Observation>& values) {
    RowMatrixF matrix(n, kObservationSize);
    for (hsize_t i = 0; i < n; ++i) matrix.row(i) = values[i].transpose().cast<float>();
    return matrix;
  };
  RowMatrixF actions(n, kActionSize);
  for (hsize_t i = 0; i < n; ++i) actions.row(i) = transitions.actions[i].transpose().cast<float>();
  const Eigen::VectorXf rewards =
      Eigen::Map<const Eigen::VectorXd>(transitions.rewards.data(), n).cast<float>();
  impl.Append(0, rows(transitions.observations).data(), n);
  impl.Append(1, actions.data(), n);
  impl.Append(2, rewards.data(), n);
  impl.Append(3, rows(transitions.next_observations).data(), n);
  impl.Append(4, transitions.terminals.data(), n);
  impl.Append(5, transitions.timeouts.data(), n);
  impl.Append(6, transitions.successes.data(), n);
  impl.rows += n;
}

void DatasetWriter::Close(const DatasetAttributes& attributes) {
  Impl& impl = *impl_;
  const hid_t file = impl.file.get();
  WriteStringAttribute(file, "task", attributes.task);
  WriteStringAttribute(file, "scenario", attributes.scenario);
  WriteStringAttribute(file, "policy", attributes.policy);
  WriteStringAttribute(file, "observation_layout", kObservationLayout);
  WriteStringAttribute(file, "action_layout", kActionLayout);
  WriteNumberAttribute(file, "seed", H5T_NATIVE_UINT64, &attributes.seed);
  WriteNumberAttribute(file, "episodes", H5T_NATIVE_INT64, &attributes.episodes);
  WriteNumberAttribute(file, "control_rate_hz", H5T_NATIVE_DOUBLE, &attributes.control_rate_hz);
  WriteNumberAttribute(file, "action_noise", H5T_NATIVE_DOUBLE, &attributes.action_noise);
  impl.datasets.clear();
  if (H5Fclose(impl.file.Release()) < 0) {
    throw std::runtime_error(impl.partial + ": cannot close the data set file (disk full?)");
  }
  std::filesystem::rename(impl.partial, impl.path);
  impl.closed = true;
}

Dataset ReadDataset(const std::string& path) {
  SilenceHdf5();
  if (!std::filesystem::exists(path)) throw std::runtime_error(path + ": no such data set file");
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.valid()) throw std::runtime_error(path + ": not an HDF5 file (or a damaged one)");
  const Handle bool_type = BoolType();
  Dataset out;
  hsize_t rows = 0;
  for (size_t i = 0; i < std::size(kFields); ++i) {
    const Field& field = kFields[i];
    const std::string where = path + ": " + field.name;
    if (H5Lexists(file.get(), field.name, H5P_DEFAULT) <= 0) throw std::runtime_error(where + ": missing");
    Handle dataset(H5Dopen2(file.get(), field.name, H5P_DEFAULT), H5Dclose);
    if (!dataset.valid()) throw std::runtime_error(where + ": not a data set");
    Handle space(H5Dget_space(dataset.get()), H5Sclose);
    const int rank = H5Sget_simple_extent_ndims(space.get());
    hsize_t dims[2] = {0, 0};
    if (rank != (field.columns > 0 ? 2 : 1) || H5Sget_simple_extent_dims(space.get(), dims, nullptr) < 0 ||
        (field.columns > 0 && dims[1] != field.columns)) {
      throw std::runtime_error(where + ": expected " +
                               (field.columns > 0 ? "[N, " + std::to_string(field.columns) + "]" : "[N]") +
                               ", got rank " + std::to_string(rank) +
                               (rank == 2 ? " with " + std::to_string(dims[1]) + " columns" : ""));
    }
    if (i == 0) rows = dims[0];
    if (dims[0] != rows) {
      throw std::runtime_error(where + ": " + std::to_string(dims[0]) + " rows, observations has " +
                               std::to_string(rows));
    }
    void* data = nullptr;
    switch (i) {
      case 0:
        data = (out.observations.resize(rows, kObservationSize), out.observations.data());
        break;
      case 1:
        data = (out.actions.resize(rows, kActionSize), out.actions.data());
        break;
      case 2:
        data = (out.rewards.resize(rows), out.rewards.data());
        break;
      case 3:
        data = (out.next_observations.resize(rows, kObservationSize), out.next_observations.data());
        break;
      case 4:
        data = (out.terminals.resize(rows), out.terminals.data());
        break;
      case 5:
        data = (out.timeouts.resize(rows), out.timeouts.data());
        break;
      case 6:
        data = (out.successes.resize(rows), out.successes.data());
        break;
    }
    const hid_t type = field.boolean ? bool_type.get() : H5T_NATIVE_FLOAT;
    if (rows > 0 && H5Dread(dataset.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
      throw std::runtime_error(where + ": cannot read it as " + (field.boolean ? "booleans" : "numbers"));
    }
  }
  out.attributes.task = ReadStringAttribute(file.get(), "task");
  out.attributes.scenario = ReadStringAttribute(file.get(), "scenario");
  out.attributes.policy = ReadStringAttribute(file.get(), "policy");
  out.attributes.seed = ReadNumberAttribute<uint64_t>(file.get(), "seed", H5T_NATIVE_UINT64);
  out.attributes.episodes = ReadNumberAttribute<int64_t>(file.get(), "episodes", H5T_NATIVE_INT64);
  out.attributes.control_rate_hz =
      ReadNumberAttribute<double>(file.get(), "control_rate_hz", H5T_NATIVE_DOUBLE);
  return out;
}

}  // namespace iapsim::rl
