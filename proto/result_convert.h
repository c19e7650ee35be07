// A finished job's result on the wire: the typed messages of wormdrag/v2/results.proto
// from the result document the job store keeps, and their JSON for users.
#pragma once

#include <string>

#include <google/protobuf/message.h>

#include "core/common/status.h"
#include "wormdrag/v2/jobs.pb.h"
#include "wormdrag/v2/results.pb.h"

namespace wormdrag::rpc {

struct ResultConversion {
  // Refuse a document key the message has no field for. Default: false, because a
  // coordinator must still serve results stored by an older version; tests set it so
  // that a key added to a result document without its field fails them.
  bool strict = false;
};

// The document's keys name the message's fields. Shapes beside plain objects:
//   - a number array for a message field fills the message's fields in field-number
//     order ([factor, E] → ScalePoint; [μ_n, μ_t, η_n, η_t] → FrictionCoefficients), or
//     its one repeated field (a Hessian row → Row);
//   - an object for a repeated message field lists named entries: each key becomes the
//     entry's `name` (an effect's parameters);
//   - null is NaN in a number field and leaves a message field unset; "inf" and "-inf"
//     are infinities.
// INVALID_ARGUMENT names the path of the first value that does not fit.
Status ResultFromJson(const std::string& document, google::protobuf::Message* out,
                      const ResultConversion& options = {});

// A done job's stored result document as GetResults carries it: an EstimateResult or,
// for kind "diagnose", a DiagnosisResult.
Status SetJobResult(const std::string& kind, const std::string& document, wormdrag::v2::GetResultsResponse* out,
                    const ResultConversion& options = {});

// The message as JSON (the proto3 mapping, field names as in the .proto, every set
// field; NaN and infinities as "NaN" / "Infinity"), indented by two spaces.
std::string ResultToJson(const google::protobuf::Message& m);

}  // namespace wormdrag::rpc
