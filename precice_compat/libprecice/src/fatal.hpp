#pragma once
// How a participant ends on an error, as preCICE ends one: the error's line on stderr ("precice: error: ..."), its
// message to the coupler sent first, exit code 2. The C and Fortran APIs end so on every misuse; a C++ program ends
// so when it lets precice::Error go uncaught (the library's terminate handler).

#include <string>
#include <utility>

#include "precice/Exceptions.hpp"

namespace cosim {

[[noreturn]] void exit_on_error(const std::string &message);

// `body()`, ending the program on a precice::Error it throws
template <typename Body>
auto guarded(Body &&body) -> decltype(body())
{
  try {
    return body();
  } catch (const ::precice::Error &error) {
    exit_on_error(error.what());
  }
}

} // namespace cosim
