// The last line of defence at a thread or process boundary: a function that returns a
// Status is run so that no exception escapes it. Code below core/'s public functions
// reports failures as Status already; an exception that still arrives here (a bug, or
// std::bad_alloc) becomes an Internal Status naming what was running, so a job runner,
// a worker's task or a command records the failure instead of aborting the process.
#pragma once

#include <exception>
#include <new>
#include <string>
#include <utility>

#include "core/common/status.h"

namespace wormdrag {

template <typename F>
Status RunGuarded(const std::string& what, F&& f) noexcept {
  try {
    return std::forward<F>(f)();
  } catch (const std::bad_alloc&) {
    return Status::ResourceExhausted(what + ": out of memory");
  } catch (const std::exception& e) { return Status::Internal(what + ": unexpected error: " + e.what()); } catch (...) {
    return Status::Internal(what + ": unexpected error");
  }
}

}  // namespace wormdrag
