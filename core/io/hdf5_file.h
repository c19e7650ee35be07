// Read-only access to HDF5 files through the HDF5 C library, for the importers of tracker
// files (Tierpsy, WormPose). Every failure becomes a Status naming the file, the object
// path and, for tables, the column; the library's own error printing is switched off.
//
// Tables are what PyTables writes: a 1-D dataset of a compound type, one member per
// column. A column is read by name into doubles whatever its stored numeric type
// (integers, floats, and PyTables' booleans, stored as 8-bit bitfields).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/common/status.h"

namespace wormdrag::h5 {

class File {
 public:
  static Result<File> Open(const std::string& path);
  File(File&& o) noexcept;
  File& operator=(File&& o) noexcept;
  File(const File&) = delete;
  File& operator=(const File&) = delete;
  ~File();

  const std::string& path() const { return path_; }

  // True when every component of the absolute `object` path exists.
  bool Has(const std::string& object) const;
  bool IsDataset(const std::string& object) const;

  Result<std::vector<uint64_t>> Shape(const std::string& dataset) const;
  // The whole dataset, row-major, converted to double.
  Result<std::vector<double>> ReadDoubles(const std::string& dataset) const;
  // Rows [first, first + count) along the first dimension, row-major, as double.
  Result<std::vector<double>> ReadRows(const std::string& dataset, uint64_t first, uint64_t count) const;

  // The member names of a compound (table) dataset.
  Result<std::vector<std::string>> Columns(const std::string& table) const;
  Result<std::vector<double>> ReadColumn(const std::string& table, const std::string& column) const;

  bool HasAttribute(const std::string& object, const std::string& name) const;
  // A numeric attribute (scalar or array), as doubles.
  Result<std::vector<double>> NumericAttribute(const std::string& object, const std::string& name) const;
  // A string attribute, fixed or variable length, without trailing NULs.
  Result<std::string> StringAttribute(const std::string& object, const std::string& name) const;

 private:
  File(int64_t id, std::string path) : id_(id), path_(std::move(path)) {}
  std::string Where(const std::string& object) const { return path_ + ": " + object; }
  int64_t id_ = -1;
  std::string path_;
};

}  // namespace wormdrag::h5
