// The tube's wall as a preCICE v3 participant in C++, built against cosim's libprecice (or preCICE itself): the same
// quasi-static wall as solid_component/tube.py, in the same arithmetic, so that it gives the native run's bits.
//
//   cmake -S . -B build && cmake --build build      (find_package(precice 3 CONFIG): `cosim libprecice env`)
//   ./build/SolidSolver ../precice-config.xml
#include <cmath>
#include <iostream>
#include <vector>

#include <precice/precice.hpp>

namespace {

// the wall: hoop equilibrium p r = sigma((r - r0) / r0) at every node, the piecewise-linear law's exact root
struct Wall {
  double length = 10.0, a0 = 1.0, E_small = 12500.0, E_large = 2500.0, s0 = 20.0, eps0 = 2e-3;
  int    cells = 100;

  double section(double p) const
  {
    const double r0 = std::sqrt(a0 / M_PI), pr0 = p * r0;
    const double r_small = r0 * E_small / (E_small - pr0);
    const double r_up = r0 * (E_large - s0) / (E_large - pr0), r_down = r0 * (E_large + s0) / (E_large - pr0);
    const double eps_small = r_small / r0 - 1.0;
    const double r = std::abs(eps_small) < eps0 ? r_small : eps_small > 0 ? r_up : r_down;
    return M_PI * (r * r);
  }
};

} // namespace

int main(int argc, char **argv)
{
  if (argc < 2) {
    std::cerr << "usage: SolidSolver PRECICE-CONFIG" << std::endl;
    return 2;
  }
  const Wall          wall;
  const int           n = wall.cells + 1;
  precice::Participant participant("Solid", argv[1], 0, 1);
  std::vector<double> coordinates(2 * n, 0.0);
  for (int i = 0; i < n; ++i) coordinates[2 * i] = i * (wall.length / wall.cells);
  coordinates[2 * (n - 1)] = wall.length;
  std::vector<int>    ids(n);
  participant.setMeshVertices("Solid-Nodes", coordinates, ids);
  std::vector<double> pressure(n, 0.0), section(n, wall.a0);
  if (participant.requiresInitialData()) participant.writeData("Solid-Nodes", "CrossSectionLength", ids, section);
  participant.initialize();
  while (participant.isCouplingOngoing()) {
    participant.requiresWritingCheckpoint();      // quasi-static: the wall keeps no state to save
    const double dt = participant.getMaxTimeStepSize();
    participant.readData("Solid-Nodes", "Pressure", ids, dt, pressure);
    for (int i = 0; i < n; ++i) section[i] = wall.section(pressure[i]);
    participant.writeData("Solid-Nodes", "CrossSectionLength", ids, section);
    participant.advance(dt);
    participant.requiresReadingCheckpoint();
  }
  participant.finalize();
  return 0;
}
