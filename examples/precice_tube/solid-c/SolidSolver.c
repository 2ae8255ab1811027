/* The tube's wall as a preCICE v3 participant in C (preCICE's C API), built with pkg-config against cosim's libprecice
 * (or preCICE itself): the same quasi-static wall as solid_component/tube.py, in the same arithmetic.
 *
 *   cc -O2 -ffp-contract=off -o SolidSolver SolidSolver.c $(pkg-config --cflags --libs libprecice) -lm
 *   ./SolidSolver ../precice-config.xml
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include <precice/preciceC.h>

#define CELLS 100
#define N (CELLS + 1)

static const double LENGTH = 10.0, A0 = 1.0, E_SMALL = 12500.0, E_LARGE = 2500.0, S0 = 20.0, EPS0 = 2e-3;

/* hoop equilibrium p r = sigma((r - r0) / r0): the piecewise-linear law's exact root, as a section */
static double section_of(double p)
{
  const double r0 = sqrt(A0 / M_PI), pr0 = p * r0;
  const double r_small = r0 * E_SMALL / (E_SMALL - pr0);
  const double r_up = r0 * (E_LARGE - S0) / (E_LARGE - pr0), r_down = r0 * (E_LARGE + S0) / (E_LARGE - pr0);
  const double eps_small = r_small / r0 - 1.0;
  const double r = fabs(eps_small) < EPS0 ? r_small : eps_small > 0 ? r_up : r_down;
  return M_PI * (r * r);
}

int main(int argc, char **argv)
{
  double coordinates[2 * N], pressure[N], section[N];
  int    ids[N], i;
  if (argc < 2) {
    fprintf(stderr, "usage: SolidSolver PRECICE-CONFIG\n");
    return 2;
  }
  for (i = 0; i < N; ++i) {
    coordinates[2 * i]     = i * (LENGTH / CELLS);
    coordinates[2 * i + 1] = 0.0;
    section[i]             = A0;
  }
  coordinates[2 * (N - 1)] = LENGTH;
  precicec_createParticipant("Solid", argv[1], 0, 1);
  precicec_setMeshVertices("Solid-Nodes", N, coordinates, ids);
  if (precicec_requiresInitialData()) precicec_writeData("Solid-Nodes", "CrossSectionLength", N, ids, section);
  precicec_initialize();
  while (precicec_isCouplingOngoing()) {
    double dt;
    precicec_requiresWritingCheckpoint(); /* quasi-static: no state to save */
    dt = precicec_getMaxTimeStepSize();
    precicec_readData("Solid-Nodes", "Pressure", N, ids, dt, pressure);
    for (i = 0; i < N; ++i) section[i] = section_of(pressure[i]);
    precicec_writeData("Solid-Nodes", "CrossSectionLength", N, ids, section);
    precicec_advance(dt);
    precicec_requiresReadingCheckpoint();
  }
  precicec_finalize();
  return 0;
}
