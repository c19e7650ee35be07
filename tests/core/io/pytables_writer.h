// Writes HDF5 files the way PyTables (and so Tierpsy Tracker) does, with the HDF5 C
// library: tables as 1-D chunked compound datasets with Tierpsy's filters (zlib 5,
// shuffle, fletcher32) and PyTables' system attributes (CLASS, VERSION, TITLE, NROWS,
// FIELD_i_NAME); arrays as chunked float datasets; attributes as PyTables stores Python
// values: float → 64-bit float, int → 64-bit int, bool → 8-bit bitfield, str → scalar
// fixed-length UTF-8 string of the text's length.
#pragma once

#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace wormdrag::testing {

enum class ColType { kInt32, kFloat32, kUInt8, kBool };

struct Column {
  std::string name;
  ColType type;
  std::vector<double> values;
};

class PyTablesWriter {
 public:
  explicit PyTablesWriter(const std::string& path)
      : id_(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT)) {
    StringAttr("/", "CLASS", "GROUP");
    StringAttr("/", "PYTABLES_FORMAT_VERSION", "2.1");
  }
  ~PyTablesWriter() { H5Fclose(id_); }
  bool ok() const { return id_ >= 0; }

  void Group(const std::string& path) {
    H5Gclose(H5Gcreate2(id_, path.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
    StringAttr(path, "CLASS", "GROUP");
  }

  void Table(const std::string& path, const std::vector<Column>& cols) {
    size_t size = 0;
    std::vector<size_t> offset;
    for (const Column& c : cols) {
      offset.push_back(size);
      size += Size(c.type);
    }
    const hid_t type = H5Tcreate(H5T_COMPOUND, size);
    for (size_t i = 0; i < cols.size(); ++i) H5Tinsert(type, cols[i].name.c_str(), offset[i], Type(cols[i].type));
    const hsize_t rows = cols.empty() ? 0 : cols[0].values.size();
    std::vector<unsigned char> buf(rows * size);
    for (size_t i = 0; i < cols.size(); ++i)
      for (hsize_t r = 0; r < rows; ++r) Pack(cols[i].type, cols[i].values[r], buf.data() + r * size + offset[i]);
    const hsize_t maxdims = H5S_UNLIMITED, chunk = 64;
    const hid_t space = H5Screate_simple(1, &rows, &maxdims);
    const hid_t ds = H5Dcreate2(id_, path.c_str(), type, space, H5P_DEFAULT, Filters(1, &chunk), H5P_DEFAULT);
    if (rows) H5Dwrite(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data());
    H5Dclose(ds);
    H5Sclose(space);
    H5Tclose(type);
    StringAttr(path, "CLASS", "TABLE");
    StringAttr(path, "VERSION", "2.7");
    StringAttr(path, "TITLE", "");
    IntAttr(path, "NROWS", static_cast<long>(rows));
    for (size_t i = 0; i < cols.size(); ++i) StringAttr(path, "FIELD_" + std::to_string(i) + "_NAME", cols[i].name);
  }

  // A float32 array (PyTables CArray, or EArray when `extendable`), NaN where unwritten.
  void Array(const std::string& path, const std::vector<hsize_t>& dims, const std::vector<double>& v,
             bool extendable = false, hid_t mem_type = H5T_NATIVE_DOUBLE, hid_t file_type = H5T_IEEE_F32LE) {
    std::vector<hsize_t> maxdims = dims, chunk = dims;
    if (extendable) maxdims[0] = H5S_UNLIMITED;
    chunk[0] = std::max<hsize_t>(1, std::min<hsize_t>(16, dims[0]));
    const hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), maxdims.data());
    const hid_t dcpl = Filters(static_cast<int>(chunk.size()), chunk.data());
    const float nan = NAN;
    H5Pset_fill_value(dcpl, H5T_NATIVE_FLOAT, &nan);
    const hid_t ds = H5Dcreate2(id_, path.c_str(), file_type, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    if (!v.empty()) H5Dwrite(ds, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
    H5Dclose(ds);
    H5Sclose(space);
    StringAttr(path, "CLASS", extendable ? "EARRAY" : "CARRAY");
    StringAttr(path, "VERSION", "1.1");
    StringAttr(path, "TITLE", "");
    if (extendable) Attr(path, "EXTDIM", H5T_STD_I32LE, H5T_NATIVE_INT32, std::vector<int32_t>{0}, {});
  }

  void DoubleAttr(const std::string& obj, const std::string& name, const std::vector<double>& v,
                  const std::vector<hsize_t>& dims = {}) {
    Attr(obj, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, v, dims);
  }
  void IntAttr(const std::string& obj, const std::string& name, long v) {
    Attr(obj, name, H5T_STD_I64LE, H5T_NATIVE_INT64, std::vector<int64_t>{v}, {});
  }
  void BoolAttr(const std::string& obj, const std::string& name, bool v) {
    Attr(obj, name, H5T_STD_B8LE, H5T_NATIVE_B8, std::vector<uint8_t>{static_cast<uint8_t>(v)}, {});
  }
  void StringAttr(const std::string& obj, const std::string& name, const std::string& v) {
    const hid_t type = H5Tcopy(H5T_C_S1);
    H5Tset_cset(type, H5T_CSET_UTF8);
    H5Tset_strpad(type, H5T_STR_NULLTERM);
    H5Tset_size(type, v.empty() ? 1 : v.size());
    const hid_t space = H5Screate(H5S_SCALAR);
    const hid_t a = H5Acreate_by_name(id_, obj.c_str(), name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT,
                                      H5P_DEFAULT);
    std::string buf = v.empty() ? std::string(1, '\0') : v;
    H5Awrite(a, type, buf.data());
    H5Aclose(a);
    H5Sclose(space);
    H5Tclose(type);
  }

 private:
  template <typename T>
  void Attr(const std::string& obj, const std::string& name, hid_t file_type, hid_t mem_type, const std::vector<T>& v,
            const std::vector<hsize_t>& dims) {
    const hid_t space = dims.empty() ? H5Screate(H5S_SCALAR)
                                     : H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
    const hid_t a = H5Acreate_by_name(id_, obj.c_str(), name.c_str(), file_type, space, H5P_DEFAULT, H5P_DEFAULT,
                                      H5P_DEFAULT);
    H5Awrite(a, mem_type, v.data());
    H5Aclose(a);
    H5Sclose(space);
  }

  // Tierpsy's TABLE_FILTERS: zlib level 5, shuffle, fletcher32.
  static hid_t Filters(int rank, const hsize_t* chunk) {
    const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(dcpl, rank, chunk);
    H5Pset_fletcher32(dcpl);
    H5Pset_shuffle(dcpl);
    H5Pset_deflate(dcpl, 5);
    return dcpl;
  }
  static size_t Size(ColType t) { return t == ColType::kInt32 || t == ColType::kFloat32 ? 4 : 1; }
  static hid_t Type(ColType t) {
    switch (t) {
      case ColType::kInt32:
        return H5T_STD_I32LE;
      case ColType::kFloat32:
        return H5T_IEEE_F32LE;
      case ColType::kUInt8:
        return H5T_STD_U8LE;
      case ColType::kBool:
        return H5T_STD_B8LE;
    }
    return H5T_STD_U8LE;
  }
  static void Pack(ColType t, double v, unsigned char* out) {
    if (t == ColType::kInt32) {
      const int32_t x = static_cast<int32_t>(v);
      std::memcpy(out, &x, 4);
    } else if (t == ColType::kFloat32) {
      const float x = static_cast<float>(v);
      std::memcpy(out, &x, 4);
    } else {
      *out = static_cast<unsigned char>(v);
    }
  }

  hid_t id_;
};

}  // namespace wormdrag::testing
