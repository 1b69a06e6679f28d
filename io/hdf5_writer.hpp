// Writing (and reading back) HDF5 with the C API: every call is checked, and a failure
// becomes one std::runtime_error naming the file and what was being done. Shared by the
// frame writer (io/output.cpp) and checkpoints (io/checkpoint.cpp).
#pragma once

#include "io/hdf5_handle.hpp"

#include <hdf5.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace wake::hdf5 {

struct Writer {
  std::string path;  ///< the file, for messages

  // Every HDF5 call goes through check(): a negative result becomes an exception naming
  // the file and what was being done.
  template <class Id>
  Id check(Id result, const std::string& what) const {
    if (result < 0) throw std::runtime_error("HDF5: cannot " + what + " in " + path);
    return result;
  }
  Handle create(hid_t id, Handle::Closer close, const std::string& what) const {
    return Handle(check(id, what), close);
  }
  Handle createGroup(hid_t parent, const std::string& name) const {
    return create(H5Gcreate2(parent, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                  "create group " + name);
  }

  void writeAttribute(hid_t object, const char* name, const double* values, hsize_t n) const {
    const Handle space = create(n == 1 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &n, nullptr),
                                H5Sclose, std::string("create dataspace for ") + name);
    const Handle attr =
        create(H5Acreate2(object, name, H5T_NATIVE_DOUBLE, space.get(), H5P_DEFAULT, H5P_DEFAULT),
               H5Aclose, std::string("create attribute ") + name);
    check(H5Awrite(attr.get(), H5T_NATIVE_DOUBLE, values), std::string("write attribute ") + name);
  }
  void writeAttribute(hid_t object, const char* name, double value) const {
    writeAttribute(object, name, &value, 1);
  }
  void writeAttribute(hid_t object, const char* name, const std::string& value) const {
    const Handle type = create(H5Tcopy(H5T_C_S1), H5Tclose, "create string type");
    check(H5Tset_size(type.get(), value.empty() ? 1 : value.size()), "set string size");
    check(H5Tset_cset(type.get(), H5T_CSET_UTF8), "set string character set");
    const Handle space = create(H5Screate(H5S_SCALAR), H5Sclose, "create dataspace");
    const Handle attr =
        create(H5Acreate2(object, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT),
               H5Aclose, std::string("create attribute ") + name);
    const std::string padded = value.empty() ? std::string(1, '\0') : value;
    check(H5Awrite(attr.get(), type.get(), padded.data()), std::string("write attribute ") + name);
  }

  /// Writes a fixed-size dataset of `rows` x `cols` values (cols == 1: a 1-D dataset).
  void writeDataset(hid_t group, const char* name, hid_t type, const void* data, hsize_t rows,
                    hsize_t cols) const {
    const hsize_t dims[2] = {rows, cols};
    const Handle space =
        create(H5Screate_simple(cols == 1 ? 1 : 2, dims, nullptr), H5Sclose, "create dataspace");
    const Handle set =
        create(H5Dcreate2(group, name, type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
               H5Dclose, std::string("create dataset ") + name);
    // HDF5 refuses a null buffer even for zero elements; an empty dataset needs no write.
    if (rows > 0)
      check(H5Dwrite(set.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data),
            std::string("write dataset ") + name);
  }

  /// Creates an empty dataset of 0 x `cols` rows that grows by one row per frame.
  Handle createSeries(hid_t group, const char* name, hsize_t cols) const {
    const hsize_t dims[2] = {0, cols};
    const hsize_t max_dims[2] = {H5S_UNLIMITED, cols};
    const hsize_t chunk[2] = {256, cols};
    const int rank = cols == 1 ? 1 : 2;
    const Handle space =
        create(H5Screate_simple(rank, dims, max_dims), H5Sclose, "create dataspace");
    const Handle props = create(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, "create properties");
    check(H5Pset_chunk(props.get(), rank, chunk), "set chunk size");
    return create(H5Dcreate2(group, name, H5T_NATIVE_DOUBLE, space.get(), H5P_DEFAULT, props.get(),
                             H5P_DEFAULT),
                  H5Dclose, std::string("create dataset ") + name);
  }

  /// Appends row `row` (the frame index) of `cols` doubles to a series.
  void appendRow(const Handle& set, hsize_t row, const double* values, hsize_t cols) const {
    const int rank = cols == 1 ? 1 : 2;
    const hsize_t new_dims[2] = {row + 1, cols};
    check(H5Dset_extent(set.get(), new_dims), "extend a body series");
    const Handle file_space = create(H5Dget_space(set.get()), H5Sclose, "get dataspace");
    const hsize_t start[2] = {row, 0};
    const hsize_t count[2] = {1, cols};
    check(H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start, nullptr, count, nullptr),
          "select a row");
    const Handle memory_space =
        create(H5Screate_simple(rank, count, nullptr), H5Sclose, "create dataspace");
    check(H5Dwrite(set.get(), H5T_NATIVE_DOUBLE, memory_space.get(), file_space.get(), H5P_DEFAULT,
                   values),
          "append to a body series");
  }

  void writeAttribute(hid_t object, const char* name, std::uint64_t value) const {
    const Handle space = create(H5Screate(H5S_SCALAR), H5Sclose, "create dataspace");
    const Handle attr =
        create(H5Acreate2(object, name, H5T_NATIVE_UINT64, space.get(), H5P_DEFAULT, H5P_DEFAULT),
               H5Aclose, std::string("create attribute ") + name);
    check(H5Awrite(attr.get(), H5T_NATIVE_UINT64, &value), std::string("write attribute ") + name);
  }

  // --- Reading ---------------------------------------------------------------------------
  Handle openGroup(hid_t parent, const std::string& name) const {
    return create(H5Gopen2(parent, name.c_str(), H5P_DEFAULT), H5Gclose, "open group " + name);
  }
  /// A scalar attribute of a numeric type (read as `type`).
  template <class T>
  T readAttribute(hid_t object, const char* name, hid_t type) const {
    const Handle attr =
        create(H5Aopen(object, name, H5P_DEFAULT), H5Aclose, std::string("open attribute ") + name);
    T value{};
    check(H5Aread(attr.get(), type, &value), std::string("read attribute ") + name);
    return value;
  }
  std::string readStringAttribute(hid_t object, const char* name) const {
    const Handle attr =
        create(H5Aopen(object, name, H5P_DEFAULT), H5Aclose, std::string("open attribute ") + name);
    const Handle type = create(H5Aget_type(attr.get()), H5Tclose, "get attribute type");
    const std::size_t size = H5Tget_size(type.get());
    std::string value(size, '\0');
    check(H5Aread(attr.get(), type.get(), value.data()), std::string("read attribute ") + name);
    return std::string(value.c_str());
  }
  /// The rows of a 1-D (cols == 1) or rows x cols dataset; its shape must be that.
  template <class T>
  std::vector<T> readDataset(hid_t group, const char* name, hid_t type, hsize_t cols) const {
    const Handle set =
        create(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose, std::string("open dataset ") + name);
    const Handle space = create(H5Dget_space(set.get()), H5Sclose, "get dataspace");
    const int rank = H5Sget_simple_extent_ndims(space.get());
    hsize_t dims[2] = {0, 1};
    if (rank != (cols == 1 ? 1 : 2) || H5Sget_simple_extent_dims(space.get(), dims, nullptr) < 0 ||
        (cols > 1 && dims[1] != cols))
      throw std::runtime_error("HDF5: dataset " + std::string(name) + " in " + path +
                               " has the wrong shape");
    std::vector<T> values(dims[0] * cols);
    if (!values.empty())
      check(H5Dread(set.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()),
            std::string("read dataset ") + name);
    return values;
  }
};

}  // namespace wake::hdf5
