#pragma once
// preCICE's tooling API: the configuration reference and a configuration's check.

#include <iosfwd>
#include <string>

#include "precice/export.h"

namespace precice {
namespace tooling {

enum struct ConfigReferenceType {
  XML = 0,
  DTD = 1,
  MD  = 2
};

// cosim's libprecice has no reference of its own to print: it writes where cosim documents the configuration it
// reads, and raises precice::Error for DTD and XML.
PRECICE_API void printConfigReference(std::ostream &out, ConfigReferenceType reftype);

// Runs `cosim check FILE` (cosim on PATH, or $COSIM): raises precice::Error with its verdict if the configuration
// is refused. `participant` must be one of the configuration's; `size` is its number of ranks.
PRECICE_API void checkConfiguration(const std::string &filename, const std::string &participant, int size);

} // namespace tooling

// The API version, then what serves it: "3.4.1;served by cosim ..."
PRECICE_API std::string getVersionInformation();

} // namespace precice
