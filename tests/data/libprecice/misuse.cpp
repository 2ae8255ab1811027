// The tube's Solid in C++ that goes wrong as it is told (argv[2]) in the third window, for the tests of how a
// compiled participant's errors stop a run: a misuse of the API left uncaught or caught, a crash, a hang, an exit
// without finalize, or no finalize at all (the destructor's).
#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include <precice/precice.hpp>

int main(int argc, char **argv)
{
  const std::string what = argc > 2 ? argv[2] : "";
  const int         n    = 101;
  precice::Participant participant("Solid", argv[1], 0, 1);
  std::vector<double>  coordinates(2 * n, 0.0), pressure(n), section(n, 1.0);
  for (int i = 0; i < n; ++i) coordinates[2 * i] = 0.1 * i;
  std::vector<int> ids(n);
  participant.setMeshVertices("Solid-Nodes", coordinates, ids);
  participant.writeData("Solid-Nodes", "CrossSectionLength", ids, section);
  participant.initialize();
  int window = 0;
  while (participant.isCouplingOngoing()) {
    participant.requiresWritingCheckpoint();     // asked, as preCICE wants
    const double dt = participant.getMaxTimeStepSize();
    participant.readData("Solid-Nodes", "Pressure", ids, dt, pressure);
    if (window == 2) {
      if (what == "values") participant.writeData("Solid-Nodes", "CrossSectionLength", ids, {section.data(), n - 1});
      if (what == "read-time") participant.readData("Solid-Nodes", "Pressure", ids, 2 * dt, pressure);
      if (what == "crash") std::abort();
      if (what == "hang") std::this_thread::sleep_for(std::chrono::hours(1));
      if (what == "exit") std::exit(0);
      if (what == "caught") {
        try {
          participant.advance(-1.0);
        } catch (const precice::Error &) {       // caught, the misuse still stops the run, as preCICE's errors do
        }
      }
    }
    for (int i = 0; i < n; ++i) section[i] = 1.0 + 1e-4 * pressure[i];
    participant.writeData("Solid-Nodes", "CrossSectionLength", ids, section);
    participant.advance(dt);
    participant.requiresReadingCheckpoint();
    if (participant.isTimeWindowComplete()) ++window;
  }
  if (what != "no-finalize") participant.finalize();     // else the destructor finalizes, as preCICE's
  return 0;
}
