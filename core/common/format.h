// The one text formatter of wormdrag: numbers in messages, file metadata, HTML and SVG
// text, and HTML escaping. JSON documents carry their numbers through nlohmann::json
// instead (core/common/json.h).
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace wormdrag {

// `v` with at most `significant` significant digits, as printf's "%.<significant>g":
// FormatNumber(0.125, 6) is "0.125", FormatNumber(1e-5, 3) "1e-05"; ±inf and NaN print
// as "inf", "-inf" and "nan".
std::string FormatNumber(double v, int significant);

// `v` with `decimals` digits after the point, as printf's "%.<decimals>f".
std::string FormatFixed(double v, int decimals);

// The cells of a list separated by `sep`, as written, empty ones included: "a,,b," gives
// "a", "", "b", "" (so that a stray separator is refused where a cell is parsed); an
// empty `s` gives none.
std::vector<std::string> SplitList(std::string_view s, char sep = ',');

// &, <, >, " and ' as character references: safe in HTML text and in quoted attributes
// (every HTML page and SVG figure).
std::string HtmlEscape(std::string_view s);

}  // namespace wormdrag
