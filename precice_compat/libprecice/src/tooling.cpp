// preCICE's tooling API and version information.

#include "precice/Tooling.hpp"

#include <cstdlib>
#include <ostream>
#include <string>

#include "precice/Exceptions.hpp"
#include "the_participant.hpp"

namespace precice {

std::string getVersionInformation() { return cosim::version_information(); }

namespace tooling {

void printConfigReference(std::ostream &out, ConfigReferenceType reftype)
{
  if (reftype != ConfigReferenceType::MD)
    throw ::precice::Error("printConfigReference: cosim's libprecice has no XML or DTD reference; cosim reads preCICE's "
                           "configuration as preCICE v3's configuration reference documents it (docs/precice.md)");
  out << "# preCICE configuration, served by cosim\n\ncosim reads a precice-config.xml as preCICE v3's configuration "
         "reference documents it; what it refuses, it refuses in one line naming the file, line and element. See "
         "cosim's docs/precice.md.\n";
}

namespace {
std::string quoted(const std::string &text)
{
  std::string out = "'";
  for (char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}
} // namespace

void checkConfiguration(const std::string &filename, const std::string &participant, int size)
{
  if (size < 1) throw ::precice::Error("checkConfiguration: a size of " + std::to_string(size) + " ranks");
  const char *given   = std::getenv("COSIM");
  std::string cosim   = given && *given ? given : "cosim";
  std::string command = quoted(cosim) + " check " + quoted(filename) + " > /dev/null";
  if (std::system(command.c_str()) != 0)
    throw ::precice::Error("checkConfiguration: `cosim check " + filename + "` refused the configuration of '" +
                           participant + "' (run it to see why)");
}

} // namespace tooling
} // namespace precice
