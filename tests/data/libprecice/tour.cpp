// A tour of preCICE's C++ API through cosim's libprecice: each part (argv[2]) is one of the Python participants of
// tests/test_precice.py written again in C++, against the same partner and configuration (argv[1]), so that the
// run must be the Python one's. What the participant reads goes to seen.txt (one line a read, %.17g); a check that
// fails ends the program with exit code 3.
//   subcycling  A of SUBCYCLING_CONFIG: checkpoints, four steps a window, reads inside the window
//   direct      Accessor of DIRECT_CONFIG: the access region, the received vertices, writes on them
//   jit         B of JIT_CONFIG: mapAndReadData and writeAndMapData at coordinates
//   gradient    A of GRADIENT_CONFIG: requiresGradientDataFor and writeGradientData
//   quads, triangles, edges, tetrahedra  Source of FIELD_CONFIG (tetrahedra: in 3-D): connectivity
//   partner     B of SUBCYCLING_CONFIG (the partner of subcycling, as tests/test_libprecice.py gives it)
//   reset       resetMesh, which cosim refuses
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <precice/precice.hpp>

namespace {

std::FILE *seen = nullptr;

void check(bool holds, const char *what)
{
  if (!holds) {
    std::fprintf(stderr, "tour: check failed: %s\n", what);
    std::exit(3);
  }
}

void record(const std::vector<double> &values)
{
  for (std::size_t i = 0; i < values.size(); ++i) std::fprintf(seen, i ? " %.17g" : "%.17g", values[i]);
  std::fprintf(seen, "\n");
}

void subcycling(precice::Participant &participant)
{
  const std::string mesh = "A-Mesh";
  check(participant.getMeshDimensions(mesh) == 2 && participant.getDataDimensions(mesh, "X") == 1, "dimensions");
  check(!participant.requiresMeshConnectivityFor(mesh), "no connectivity asked");
  std::vector<double> first = {0.0, 0.0}, second = {1.0, 0.0};
  std::vector<int>    ids(2);
  ids[0] = participant.setMeshVertex(mesh, first);
  participant.setMeshVertices(mesh, second, {ids.data() + 1, 1});
  check(ids[0] == 0 && ids[1] == 1 && participant.getMeshVertexSize(mesh) == 2, "vertex ids");
  check(!participant.requiresInitialData(), "no initial data");
  std::vector<double> x = {1.0, 2.0}, saved, b(2);
  bool                complete = false;
  participant.initialize();
  while (participant.isCouplingOngoing()) {
    if (participant.requiresWritingCheckpoint()) saved = x;
    for (int step = 0; step < 4; ++step) {
      participant.startProfilingSection("step");
      double dt = participant.getMaxTimeStepSize() / (4 - step);
      participant.readData(mesh, "B", ids, dt, b);
      record(b);
      for (int i = 0; i < 2; ++i) x[i] = x[i] + dt * (b[i] - x[i]);
      participant.writeData(mesh, "X", ids, x);
      participant.stopLastProfilingSection();
      participant.advance(dt);
      participant.requiresReadingCheckpoint();
      complete = participant.isTimeWindowComplete();
      check(step == 3 || !complete, "a step inside the window completes none");
    }
    bool repeat = participant.requiresReadingCheckpoint();
    check(complete != repeat, "the window completes unless it is repeated");
    if (repeat) x = saved;
  }
}

void partner(precice::Participant &participant)
{
  std::vector<double> grid = {0.0, 0.0, 1.0, 0.0}, x(2), b(2);
  std::vector<int>    ids(2);
  participant.setMeshVertices("B-Mesh", grid, ids);
  participant.initialize();
  double t = 0.0;
  while (participant.isCouplingOngoing()) {
    participant.requiresWritingCheckpoint();     // asked, as preCICE wants
    double dt = participant.getMaxTimeStepSize();
    participant.readData("B-Mesh", "X", ids, dt, x);
    for (int i = 0; i < 2; ++i) b[i] = 0.5 * x[i] + std::sin(t + dt);
    participant.writeData("B-Mesh", "B", ids, b);
    participant.advance(dt);
    if (!participant.requiresReadingCheckpoint()) t += dt;
  }
}

void direct(precice::Participant &participant)
{
  std::vector<double> origin = {0.0, 0.0}, box = {0.25, 0.75, -1.0, 1.0};
  participant.setMeshVertex("Accessor-Mesh", origin);
  participant.setMeshAccessRegion("Provider-Mesh", box);
  participant.initialize();
  int                 size = participant.getMeshVertexSize("Provider-Mesh");
  std::vector<int>    ids(size);
  std::vector<double> coordinates(2 * size), values(size);
  participant.getMeshVertexIDsAndCoordinates("Provider-Mesh", ids, coordinates);
  record(std::vector<double>(ids.begin(), ids.end()));
  record(coordinates);
  double t = 0.0;
  while (participant.isCouplingOngoing()) {
    participant.requiresWritingCheckpoint();     // asked, as preCICE wants
    double dt = participant.getMaxTimeStepSize();
    t += dt;
    for (int i = 0; i < size; ++i) values[i] = t + coordinates[2 * i] * coordinates[2 * i];
    participant.writeData("Provider-Mesh", "D", ids, values);
    participant.advance(dt);
    participant.requiresReadingCheckpoint();
  }
}

void jit(precice::Participant &participant)
{
  std::vector<double> box = {-1, 2, -1, 1}, points = {0.12, 0.0, 0.5, 0.1, 0.93, 0.0}, forces = {1.0, 2.0, 3.0};
  std::vector<double> values(3), single = {5.0};
  participant.setMeshAccessRegion("A-Mesh", box);
  participant.initialize();
  while (participant.isCouplingOngoing()) {
    participant.requiresWritingCheckpoint();     // asked, as preCICE wants
    double dt = participant.getMaxTimeStepSize();
    participant.mapAndReadData("A-Mesh", "V", points, dt, values);
    record(values);
    participant.writeAndMapData("A-Mesh", "F", points, forces);
    participant.writeAndMapData("A-Mesh", "F", {points.data(), 2}, single);
    participant.advance(dt);
    participant.requiresReadingCheckpoint();
  }
}

void gradient(precice::Participant &participant)
{
  std::vector<double> grid;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 3; ++j) grid.insert(grid.end(), {i * (1.0 / 3.0), j * 0.5});   // NumPy's linspace
  std::vector<int> ids(12);
  participant.setMeshVertices("A-Mesh", grid, ids);
  participant.initialize();
  bool asked[2] = {participant.requiresGradientDataFor("A-Mesh", "S"),
                   participant.requiresGradientDataFor("A-Mesh", "V")};
  record({double(asked[0]), double(asked[1])});
  std::vector<double> s(12), v(24), ds(24), dv(48);
  double              t = 0.0;
  while (participant.isCouplingOngoing()) {
    participant.requiresWritingCheckpoint();     // asked, as preCICE wants
    double dt = participant.getMaxTimeStepSize();
    t += dt;
    for (int k = 0; k < 12; ++k) {
      double x = grid[2 * k], y = grid[2 * k + 1];
      s[k]         = t + 2 * x - y;
      v[2 * k]     = x + 2 * y;
      v[2 * k + 1] = t * (3 * x - y);
      ds[2 * k]     = 2.0;
      ds[2 * k + 1] = -1.0;
      double row[4] = {1.0, 3.0 * t, 2.0, -t};
      for (int c = 0; c < 4; ++c) dv[4 * k + c] = row[c];
    }
    participant.writeData("A-Mesh", "S", ids, s);
    participant.writeData("A-Mesh", "V", ids, v);
    if (asked[0]) participant.writeGradientData("A-Mesh", "S", ids, ds);
    if (asked[1]) participant.writeGradientData("A-Mesh", "V", ids, dv);
    participant.advance(dt);
    participant.requiresReadingCheckpoint();
  }
}

void field(precice::Participant &participant, const std::string &part)
{
  const std::string mesh = "Source-Mesh";
  std::vector<double> grid;
  int                 n;
  if (part == "tetrahedra") {       // the unit cube's corners, vertex x + 2y + 4z
    for (int k = 0; k < 8; ++k) grid.insert(grid.end(), {double(k & 1), double((k >> 1) & 1), double((k >> 2) & 1)});
    n = 8;
  } else {                          // a 5 x 4 grid on the unit square, row by row
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 5; ++i) grid.insert(grid.end(), {i * 0.25, j * (1.0 / 3.0)});
    n = 20;
  }
  int              dimensions = participant.getMeshDimensions(mesh);
  std::vector<int> ids(n);
  participant.setMeshVertices(mesh, grid, ids);
  check(participant.requiresMeshConnectivityFor(mesh), "the mapping asks for connectivity");
  std::vector<int> cells;
  if (part == "quads") {
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 4; ++i) cells.insert(cells.end(), {5 * j + i, 5 * j + i + 1, 5 * j + i + 6, 5 * j + i + 5});
    participant.setMeshQuads(mesh, {cells.data(), cells.size() - 4});
    participant.setMeshQuad(mesh, cells[44], cells[45], cells[46], cells[47]);
  } else if (part == "triangles") {
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 4; ++i) {
        int c = 5 * j + i;
        cells.insert(cells.end(), {c, c + 1, c + 6, c, c + 6, c + 5});
      }
    participant.setMeshTriangles(mesh, {cells.data(), cells.size() - 3});
    participant.setMeshTriangle(mesh, cells[69], cells[70], cells[71]);
  } else if (part == "edges") {     // along the top row
    cells = {15, 16, 16, 17, 17, 18};
    participant.setMeshEdges(mesh, cells);
    participant.setMeshEdge(mesh, 18, 19);
  } else {                          // Kuhn's six tetrahedra around the diagonal 0-7
    int axes[6][2] = {{1, 2}, {1, 4}, {2, 1}, {2, 4}, {4, 1}, {4, 2}};
    for (auto &a : axes) cells.insert(cells.end(), {0, a[0], a[0] + a[1], 7});
    participant.setMeshTetrahedra(mesh, {cells.data(), 20});
    participant.setMeshTetrahedron(mesh, cells[20], cells[21], cells[22], cells[23]);
  }
  participant.initialize();
  std::vector<double> values(n);
  double              t = 0.0;
  while (participant.isCouplingOngoing()) {
    participant.requiresWritingCheckpoint();     // asked, as preCICE wants
    double dt = participant.getMaxTimeStepSize();
    t += dt;
    for (int k = 0; k < n; ++k) {
      const double *p = &grid[dimensions * k];
      values[k]       = dimensions == 3 ? t + 2.0 * p[0] + 3.0 * p[1] - p[2] : t + 2.0 * p[0] + 3.0 * p[1] * p[1];
    }
    participant.writeData(mesh, "T", ids, values);
    participant.advance(dt);
    participant.requiresReadingCheckpoint();
  }
}

} // namespace

int main(int argc, char **argv)
{
  if (argc != 4) {
    std::fprintf(stderr, "usage: tour CONFIG PART PARTICIPANT\n");
    return 2;
  }
  const std::string part = argv[2];
  std::cout << "preCICE " << precice::getVersionInformation() << std::endl;
  seen = std::fopen("seen.txt", "w");
  int  communicator = 0;     // the gradient part takes the constructor with one (cosim serves one rank: unused)
  auto made = part == "gradient" ? std::make_unique<precice::Participant>(argv[3], argv[1], 0, 1, &communicator)
                                 : std::make_unique<precice::Participant>(argv[3], argv[1], 0, 1);
  precice::Participant &participant = *made;
  if (part == "subcycling") subcycling(participant);
  else if (part == "partner") partner(participant);
  else if (part == "direct") direct(participant);
  else if (part == "jit") jit(participant);
  else if (part == "gradient") gradient(participant);
  else if (part == "reset") {
    std::vector<double> origin = {0.0, 0.0};
    participant.setMeshVertex("A-Mesh", origin);
    participant.initialize();
    participant.resetMesh("A-Mesh");
  } else field(participant, part);
  participant.finalize();
  std::fclose(seen);
  return 0;
}
