#pragma once
// The error the API raises on a misuse, or when the coupling stops: what() is one line naming the call and why.

#include <stdexcept>
#include <string>

#include "precice/export.h"

namespace precice {

class PRECICE_API Error : public std::runtime_error {
public:
  explicit Error(const std::string &message) : std::runtime_error(message) {}
};

} // namespace precice
