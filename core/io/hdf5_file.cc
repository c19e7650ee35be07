#include "core/io/hdf5_file.h"

#include <hdf5.h>

#include <cstring>
#include <filesystem>
#include <mutex>

namespace wormdrag::h5 {
namespace {

// Closes an HDF5 identifier when it goes out of scope.
class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

// Failures come back as negative return values and become Statuses; the library's
// automatic printing of its error stack to stderr would only add noise.
void SilenceLibraryErrors() {
  static std::once_flag once;
  std::call_once(once, [] { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); });
}

std::string ShapeText(const std::vector<uint64_t>& d) {
  std::string s = "(";
  for (size_t i = 0; i < d.size(); ++i) s += (i ? ", " : "") + std::to_string(d[i]);
  return s + ")";
}

bool IsNumber(H5T_class_t c) {
  return c == H5T_INTEGER || c == H5T_FLOAT;
}
// PyTables stores booleans as 8-bit bitfields; enums hold integers too.
bool IsFlag(H5T_class_t c) {
  return c == H5T_BITFIELD || c == H5T_ENUM;
}

// Unsigned integers of `size` bytes each (native order), as doubles.
std::vector<double> BytesToDoubles(const std::vector<unsigned char>& raw, size_t size) {
  std::vector<double> out(raw.size() / size);
  for (size_t i = 0; i < out.size(); ++i) {
    uint64_t v = 0;
    std::memcpy(&v, raw.data() + i * size, size);
    out[i] = static_cast<double>(v);
  }
  return out;
}

}  // namespace

Result<File> File::Open(const std::string& path) {
  SilenceLibraryErrors();
  if (!std::filesystem::exists(path)) return Status::NotFound(path + ": no such file");
  if (H5Fis_hdf5(path.c_str()) <= 0) return Status::InvalidArgument(path + ": not an HDF5 file");
  const hid_t id = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (id < 0) return Status::InvalidArgument(path + ": cannot open the HDF5 file");
  return File(id, path);
}

File::File(File&& o) noexcept : id_(o.id_), path_(std::move(o.path_)) {
  o.id_ = -1;
}

File& File::operator=(File&& o) noexcept {
  if (this != &o) {
    if (id_ >= 0) H5Fclose(id_);
    id_ = o.id_;
    path_ = std::move(o.path_);
    o.id_ = -1;
  }
  return *this;
}

File::~File() {
  if (id_ >= 0) H5Fclose(id_);
}

bool File::Has(const std::string& object) const {
  if (object == "/") return true;
  for (size_t pos = 1;; ++pos) {
    pos = object.find('/', pos);
    const std::string prefix = object.substr(0, pos);
    if (H5Lexists(id_, prefix.c_str(), H5P_DEFAULT) <= 0) return false;
    if (pos == std::string::npos) return true;
  }
}

bool File::IsDataset(const std::string& object) const {
  if (!Has(object)) return false;
  Handle ds(H5Dopen2(id_, object.c_str(), H5P_DEFAULT), H5Dclose);
  return ds.ok();
}

Result<std::vector<uint64_t>> File::Shape(const std::string& dataset) const {
  if (!IsDataset(dataset)) return Status::InvalidArgument(Where(dataset) + ": no such dataset");
  Handle ds(H5Dopen2(id_, dataset.c_str(), H5P_DEFAULT), H5Dclose);
  Handle space(H5Dget_space(ds.get()), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0) return Status::InvalidArgument(Where(dataset) + ": cannot read its shape");
  std::vector<hsize_t> dims(rank);
  H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  return std::vector<uint64_t>(dims.begin(), dims.end());
}

Result<std::vector<double>> File::ReadDoubles(const std::string& dataset) const {
  auto shape = Shape(dataset);
  if (!shape.ok()) return shape.status();
  return ReadRows(dataset, 0, shape->empty() ? 0 : shape->front());  // a scalar: its one value
}

Result<std::vector<double>> File::ReadRows(const std::string& dataset, uint64_t first, uint64_t count) const {
  auto shape = Shape(dataset);
  if (!shape.ok()) return shape.status();
  Handle ds(H5Dopen2(id_, dataset.c_str(), H5P_DEFAULT), H5Dclose);
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  if (!IsNumber(H5Tget_class(type.get()))) return Status::InvalidArgument(Where(dataset) + ": not a numeric dataset");
  if (shape->empty()) {  // a scalar dataset: one value
    std::vector<double> v(1);
    if (H5Dread(ds.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
      return Status::InvalidArgument(Where(dataset) + ": read failed");
    return v;
  }
  const std::vector<uint64_t>& d = *shape;
  if (first + count > d[0])
    return Status::InvalidArgument(Where(dataset) + ": rows " + std::to_string(first) + "…" +
                                   std::to_string(first + count) + " beyond its shape " + ShapeText(d));
  std::vector<hsize_t> start(d.size(), 0), cnt(d.begin(), d.end());
  start[0] = first;
  cnt[0] = count;
  size_t n = 1;
  for (hsize_t c : cnt) n *= c;
  std::vector<double> v(n);
  if (n == 0) return v;
  Handle fspace(H5Dget_space(ds.get()), H5Sclose);
  H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start.data(), nullptr, cnt.data(), nullptr);
  Handle mspace(H5Screate_simple(static_cast<int>(cnt.size()), cnt.data(), nullptr), H5Sclose);
  if (H5Dread(ds.get(), H5T_NATIVE_DOUBLE, mspace.get(), fspace.get(), H5P_DEFAULT, v.data()) < 0)
    return Status::InvalidArgument(Where(dataset) + ": read failed (corrupt or unsupported compression)");
  return v;
}

Result<std::vector<std::string>> File::Columns(const std::string& table) const {
  if (!IsDataset(table)) return Status::InvalidArgument(Where(table) + ": no such dataset");
  Handle ds(H5Dopen2(id_, table.c_str(), H5P_DEFAULT), H5Dclose);
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  if (H5Tget_class(type.get()) != H5T_COMPOUND)
    return Status::InvalidArgument(Where(table) + ": not a table (a compound dataset, as PyTables writes)");
  std::vector<std::string> names;
  const int n = H5Tget_nmembers(type.get());
  for (int i = 0; i < n; ++i) {
    char* name = H5Tget_member_name(type.get(), static_cast<unsigned>(i));
    names.emplace_back(name ? name : "");
    H5free_memory(name);
  }
  return names;
}

Result<std::vector<double>> File::ReadColumn(const std::string& table, const std::string& column) const {
  auto columns = Columns(table);
  if (!columns.ok()) return columns.status();
  Handle ds(H5Dopen2(id_, table.c_str(), H5P_DEFAULT), H5Dclose);
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  const int index = H5Tget_member_index(type.get(), column.c_str());
  if (index < 0) {
    std::string list;
    for (const std::string& c : *columns) list += (list.empty() ? "" : ", ") + c;
    return Status::InvalidArgument(Where(table) + ": no column '" + column + "' (columns: " + list + ")");
  }
  auto shape = Shape(table);
  if (!shape.ok()) return shape.status();
  if (shape->size() != 1)
    return Status::InvalidArgument(Where(table) + ": shape " + ShapeText(*shape) + ", expected one row per entry");
  const size_t rows = shape->front();
  Handle member(H5Tget_member_type(type.get(), static_cast<unsigned>(index)), H5Tclose);
  const H5T_class_t cls = H5Tget_class(member.get());
  const std::string where = Where(table) + ": column '" + column + "'";
  if (IsNumber(cls)) {
    Handle mem(H5Tcreate(H5T_COMPOUND, sizeof(double)), H5Tclose);
    H5Tinsert(mem.get(), column.c_str(), 0, H5T_NATIVE_DOUBLE);
    std::vector<double> v(rows);
    if (rows && H5Dread(ds.get(), mem.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
      return Status::InvalidArgument(where + ": read failed");
    return v;
  }
  if (IsFlag(cls) && H5Tget_size(member.get()) <= sizeof(uint64_t)) {
    Handle native(H5Tget_native_type(member.get(), H5T_DIR_ASCEND), H5Tclose);
    const size_t size = H5Tget_size(native.get());
    Handle mem(H5Tcreate(H5T_COMPOUND, size), H5Tclose);
    H5Tinsert(mem.get(), column.c_str(), 0, native.get());
    std::vector<unsigned char> raw(rows * size);
    if (rows && H5Dread(ds.get(), mem.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, raw.data()) < 0)
      return Status::InvalidArgument(where + ": read failed");
    return BytesToDoubles(raw, size);
  }
  return Status::InvalidArgument(where + ": not numeric");
}

bool File::HasAttribute(const std::string& object, const std::string& name) const {
  return Has(object) && H5Aexists_by_name(id_, object.c_str(), name.c_str(), H5P_DEFAULT) > 0;
}

Result<std::vector<double>> File::NumericAttribute(const std::string& object, const std::string& name) const {
  const std::string where = Where(object) + ": attribute '" + name + "'";
  if (!HasAttribute(object, name)) return Status::InvalidArgument(where + ": missing");
  Handle attr(H5Aopen_by_name(id_, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(attr.get()), H5Tclose);
  Handle space(H5Aget_space(attr.get()), H5Sclose);
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  const H5T_class_t cls = H5Tget_class(type.get());
  if (n <= 0) return Status::InvalidArgument(where + ": empty");
  if (IsNumber(cls)) {
    std::vector<double> v(static_cast<size_t>(n));
    if (H5Aread(attr.get(), H5T_NATIVE_DOUBLE, v.data()) < 0) return Status::InvalidArgument(where + ": read failed");
    return v;
  }
  if (IsFlag(cls) && H5Tget_size(type.get()) <= sizeof(uint64_t)) {
    Handle native(H5Tget_native_type(type.get(), H5T_DIR_ASCEND), H5Tclose);
    const size_t size = H5Tget_size(native.get());
    std::vector<unsigned char> raw(static_cast<size_t>(n) * size);
    if (H5Aread(attr.get(), native.get(), raw.data()) < 0) return Status::InvalidArgument(where + ": read failed");
    return BytesToDoubles(raw, size);
  }
  return Status::InvalidArgument(where + ": not a number" + (cls == H5T_STRING ? " (a string)" : ""));
}

Result<std::string> File::StringAttribute(const std::string& object, const std::string& name) const {
  const std::string where = Where(object) + ": attribute '" + name + "'";
  if (!HasAttribute(object, name)) return Status::InvalidArgument(where + ": missing");
  Handle attr(H5Aopen_by_name(id_, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(attr.get()), H5Tclose);
  if (H5Tget_class(type.get()) != H5T_STRING) return Status::InvalidArgument(where + ": not a string");
  std::string s;
  if (H5Tis_variable_str(type.get()) > 0) {
    char* p = nullptr;
    if (H5Aread(attr.get(), type.get(), &p) < 0) return Status::InvalidArgument(where + ": read failed");
    s = p ? p : "";
    H5free_memory(p);
  } else {
    std::vector<char> buf(H5Tget_size(type.get()) + 1, '\0');
    if (H5Aread(attr.get(), type.get(), buf.data()) < 0) return Status::InvalidArgument(where + ": read failed");
    s = buf.data();  // stops at the first NUL
  }
  return s;
}

}  // namespace wormdrag::h5
