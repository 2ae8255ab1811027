#pragma once
// The one participant of a process that the C and Fortran APIs drive (each language's calls on the same one).

#include <string>

#include "core.hpp"

namespace cosim {

void                  create_the_participant(const char *call, const std::string &name, const std::string &config,
                                             int rank, int size);
// the participant, or the program ends naming `call` (no participant was created)
precice::impl::Core  &the_participant(const char *call);
void                  destroy_the_participant();

// "3.4.1;served by cosim ...": the API version first, as preCICE's version information starts
const char           *version_information();

} // namespace cosim
