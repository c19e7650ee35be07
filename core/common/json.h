// How wormdrag writes JSON documents: one value type, the encodings of non-finite
// numbers that the documents' readers expect, and a dump that cannot throw.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace wormdrag {

// Objects keep their keys in insertion order, so a document reads in the order it is built.
using Json = nlohmann::ordered_json;

// A finite number as itself; NaN and ±inf as null.
Json NumberOrNull(double v);

// A finite number as itself; +inf and -inf as the strings "inf" and "-inf" (an unbounded
// tolerance or interval end, which readers tell apart from a missing value); NaN as null.
Json NumberOrInf(double v);

// The document on one line. Bytes that are not UTF-8 (a file name, say) become U+FFFD
// instead of throwing.
std::string Dump(const Json& j);

}  // namespace wormdrag
