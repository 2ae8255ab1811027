#include "the_participant.hpp"

#include <memory>

#include "fatal.hpp"
#include "precice/Version.h"

namespace cosim {

namespace {

std::unique_ptr<precice::impl::Core> &slot()
{
  static std::unique_ptr<precice::impl::Core> participant;
  return participant;
}

} // namespace

void create_the_participant(const char *call, const std::string &name, const std::string &config, int rank, int size)
{
  if (slot()) exit_on_error(std::string(call) + ": a participant was created already (one per process)");
  slot().reset(new precice::impl::Core(name, config, rank, size, call));
}

precice::impl::Core &the_participant(const char *call)
{
  if (!slot()) exit_on_error(std::string(call) + ": no participant: create it first (precicec_createParticipant or "
                             "precicef_create)");
  return *slot();
}

void destroy_the_participant() { slot().reset(); }

const char *version_information() { return PRECICE_VERSION ";served by cosim's coupler (cosim's libprecice)"; }

} // namespace cosim
