// Internal errors: thrown inside the library, turned into aacbvh_status by capi/.
#pragma once

#include <stdexcept>
#include <string>

#include "aacbvh/aacbvh.h"

namespace aacbvh {

/// A failure with the status the C API reports and a message for last_error().
class Error : public std::runtime_error {
public:
    Error(aacbvh_status status, const std::string &message)
        : std::runtime_error(message), status_(status) {}
    aacbvh_status status() const { return status_; }

private:
    aacbvh_status status_;
};

} // namespace aacbvh
