#include "core/diagnose/diagnosis.h"
namespace wormdrag::diagnose {
std::string Diagnosis::ToJson() const { return "{}"; }
std::string Diagnosis::ToText() const { return explanation; }
std::string Diagnosis::ToHtml() const { return ""; }
}
