#include "proto/result_convert.h"

#include <cmath>
#include <limits>

#include <google/protobuf/descriptor.h>
#include <google/protobuf/util/json_util.h>
#include <nlohmann/json.hpp>

namespace wormdrag::rpc {
namespace {

using google::protobuf::FieldDescriptor;
using google::protobuf::Message;
using google::protobuf::Reflection;
using nlohmann::json;

class Converter {
 public:
  explicit Converter(const ResultConversion& o) : options_(o) {}

  Status Object(const json& j, const std::string& path, Message* m) const {
    if (!j.is_object()) return Bad(path, "an object");
    const auto* d = m->GetDescriptor();
    for (const auto& [key, value] : j.items()) {
      const FieldDescriptor* f = d->FindFieldByName(key);
      if (f == nullptr) {
        if (options_.strict) return Status::InvalidArgument(path + "." + key + ": no such field in " + d->name());
        continue;
      }
      Status s = Field(value, path + "." + key, m, f);
      if (!s.ok()) return s;
    }
    return Status::Ok();
  }

 private:
  static Status Bad(const std::string& path, const char* want) {
    return Status::InvalidArgument(path + ": expected " + std::string(want));
  }

  // A number as the document writes it: null is undefined, "inf" an infinity.
  static bool Number(const json& j, double* v) {
    if (j.is_number())
      *v = j.get<double>();
    else if (j.is_null())
      *v = std::numeric_limits<double>::quiet_NaN();
    else if (j == "inf")
      *v = std::numeric_limits<double>::infinity();
    else if (j == "-inf")
      *v = -std::numeric_limits<double>::infinity();
    else
      return false;
    return true;
  }

  Status Field(const json& j, const std::string& path, Message* m, const FieldDescriptor* f) const {
    const Reflection* r = m->GetReflection();
    if (f->is_repeated()) {
      if (f->type() == FieldDescriptor::TYPE_MESSAGE && j.is_object()) {  // named entries
        for (const auto& [key, value] : j.items()) {
          Message* e = r->AddMessage(m, f);
          const FieldDescriptor* name = e->GetDescriptor()->FindFieldByName("name");
          if (name == nullptr) return Bad(path, "an array");
          e->GetReflection()->SetString(e, name, key);
          Status s = Object(value, path + "." + key, e);
          if (!s.ok()) return s;
        }
        return Status::Ok();
      }
      if (!j.is_array()) return Bad(path, "an array");
      for (size_t i = 0; i < j.size(); ++i) {
        Status s = Element(j[i], path + "[" + std::to_string(i) + "]", m, f);
        if (!s.ok()) return s;
      }
      return Status::Ok();
    }
    return Element(j, path, m, f);
  }

  // One value into field f (appended if f is repeated).
  Status Element(const json& j, const std::string& path, Message* m, const FieldDescriptor* f) const {
    const Reflection* r = m->GetReflection();
    const bool rep = f->is_repeated();
    switch (f->cpp_type()) {
      case FieldDescriptor::CPPTYPE_MESSAGE: {
        if (j.is_null()) return Status::Ok();
        Message* sub = rep ? r->AddMessage(m, f) : r->MutableMessage(m, f);
        return j.is_array() ? Positional(j, path, sub) : Object(j, path, sub);
      }
      case FieldDescriptor::CPPTYPE_DOUBLE: {
        double v;
        if (!Number(j, &v)) return Bad(path, "a number");
        rep ? r->AddDouble(m, f, v) : r->SetDouble(m, f, v);
        return Status::Ok();
      }
      case FieldDescriptor::CPPTYPE_INT32:
      case FieldDescriptor::CPPTYPE_INT64: {
        if (!j.is_number_integer()) return Bad(path, "an integer");
        const int64_t v = j.get<int64_t>();
        if (f->cpp_type() == FieldDescriptor::CPPTYPE_INT64) {
          rep ? r->AddInt64(m, f, v) : r->SetInt64(m, f, v);
        } else {
          if (v < std::numeric_limits<int32_t>::min() || v > std::numeric_limits<int32_t>::max())
            return Bad(path, "a 32-bit integer");
          rep ? r->AddInt32(m, f, static_cast<int32_t>(v)) : r->SetInt32(m, f, static_cast<int32_t>(v));
        }
        return Status::Ok();
      }
      case FieldDescriptor::CPPTYPE_BOOL:
        if (!j.is_boolean()) return Bad(path, "true or false");
        rep ? r->AddBool(m, f, j.get<bool>()) : r->SetBool(m, f, j.get<bool>());
        return Status::Ok();
      case FieldDescriptor::CPPTYPE_STRING:
        if (!j.is_string()) return Bad(path, "a string");
        rep ? r->AddString(m, f, j.get<std::string>()) : r->SetString(m, f, j.get<std::string>());
        return Status::Ok();
      default:
        return Bad(path, "a supported field type");
    }
  }

  // A number array into a message: its one repeated field, or its fields in order.
  Status Positional(const json& j, const std::string& path, Message* m) const {
    const auto* d = m->GetDescriptor();
    if (d->field_count() == 1 && d->field(0)->is_repeated()) return Field(j, path, m, d->field(0));
    if (j.size() > static_cast<size_t>(d->field_count())) return Bad(path, "fewer values");
    for (size_t i = 0; i < j.size(); ++i) {
      const FieldDescriptor* f = d->field(static_cast<int>(i));
      if (f->is_repeated()) return Bad(path, "an object");
      Status s = Element(j[i], path + "[" + std::to_string(i) + "]", m, f);
      if (!s.ok()) return s;
    }
    return Status::Ok();
  }

  ResultConversion options_;
};

}  // namespace

Status ResultFromJson(const std::string& document, google::protobuf::Message* out, const ResultConversion& options) {
  out->Clear();
  const json j = json::parse(document, nullptr, false);
  if (j.is_discarded()) return Status::InvalidArgument("the stored result is not JSON");
  return Converter(options).Object(j, "result", out);
}

Status SetJobResult(const std::string& kind, const std::string& document, wormdrag::v2::GetResultsResponse* out,
                    const ResultConversion& options) {
  return kind == "diagnose" ? ResultFromJson(document, out->mutable_diagnosis(), options)
                            : ResultFromJson(document, out->mutable_estimate(), options);
}

std::string ResultToJson(const google::protobuf::Message& m) {
  google::protobuf::util::JsonPrintOptions o;
  o.add_whitespace = true;
  o.preserve_proto_field_names = true;
  std::string s;
  if (!google::protobuf::util::MessageToJsonString(m, &s, o).ok()) return "{}";
  return s;
}

}  // namespace wormdrag::rpc
