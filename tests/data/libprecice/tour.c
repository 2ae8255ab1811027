/* A tour of preCICE's C API through cosim's libprecice: tour.cpp's parts (argv[2]), the same calls in C, against
 * the same partners and configuration (argv[1]); what the participant reads goes to seen.txt, a failed check ends
 * it with exit code 3. The participant is created with a communicator in the gradient part (cosim serves a
 * participant of one rank; the communicator is not used). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <precice/preciceC.h>

static FILE *seen;

static void check(int holds, const char *what)
{
  if (!holds) {
    fprintf(stderr, "tour: check failed: %s\n", what);
    exit(3);
  }
}

static void record(const double *values, int n)
{
  for (int i = 0; i < n; ++i) fprintf(seen, i ? " %.17g" : "%.17g", values[i]);
  fprintf(seen, "\n");
}

static void subcycling(void)
{
  const char *mesh = "A-Mesh";
  double      first[2] = {0.0, 0.0}, second[2] = {1.0, 0.0}, x[2] = {1.0, 2.0}, saved[2], b[2];
  int         ids[2], complete = 0;
  check(precicec_getMeshDimensions(mesh) == 2 && precicec_getDataDimensions(mesh, "X") == 1, "dimensions");
  check(!precicec_requiresMeshConnectivityFor(mesh), "no connectivity asked");
  ids[0] = precicec_setMeshVertex(mesh, first);
  precicec_setMeshVertices(mesh, 1, second, ids + 1);
  check(ids[0] == 0 && ids[1] == 1 && precicec_getMeshVertexSize(mesh) == 2, "vertex ids");
  check(!precicec_requiresInitialData(), "no initial data");
  precicec_initialize();
  while (precicec_isCouplingOngoing()) {
    if (precicec_requiresWritingCheckpoint()) memcpy(saved, x, sizeof x);
    for (int step = 0; step < 4; ++step) {
      precicec_startProfilingSection("step");
      double dt = precicec_getMaxTimeStepSize() / (4 - step);
      precicec_readData(mesh, "B", 2, ids, dt, b);
      record(b, 2);
      for (int i = 0; i < 2; ++i) x[i] = x[i] + dt * (b[i] - x[i]);
      precicec_writeData(mesh, "X", 2, ids, x);
      precicec_stopLastProfilingSection();
      precicec_advance(dt);
      (void)precicec_requiresReadingCheckpoint();
      complete = precicec_isTimeWindowComplete();
      check(step == 3 || !complete, "a step inside the window completes none");
    }
    int repeat = precicec_requiresReadingCheckpoint();
    check(complete != repeat, "the window completes unless it is repeated");
    if (repeat) memcpy(x, saved, sizeof x);
  }
}

static void partner(void)
{
  double grid[4] = {0.0, 0.0, 1.0, 0.0}, x[2], b[2], t = 0.0;
  int    ids[2];
  precicec_setMeshVertices("B-Mesh", 2, grid, ids);
  precicec_initialize();
  while (precicec_isCouplingOngoing()) {
    (void)precicec_requiresWritingCheckpoint();     /* asked, as preCICE wants */
    double dt = precicec_getMaxTimeStepSize();
    precicec_readData("B-Mesh", "X", 2, ids, dt, x);
    for (int i = 0; i < 2; ++i) b[i] = 0.5 * x[i] + sin(t + dt);
    precicec_writeData("B-Mesh", "B", 2, ids, b);
    precicec_advance(dt);
    if (!precicec_requiresReadingCheckpoint()) t += dt;
  }
}

static void direct(void)
{
  double origin[2] = {0.0, 0.0}, box[4] = {0.25, 0.75, -1.0, 1.0}, t = 0.0;
  precicec_setMeshVertex("Accessor-Mesh", origin);
  precicec_setMeshAccessRegion("Provider-Mesh", box);
  precicec_initialize();
  int     size        = precicec_getMeshVertexSize("Provider-Mesh");
  int    *ids         = malloc(size * sizeof(int));
  double *coordinates = malloc(2 * size * sizeof(double)), *values = malloc(size * sizeof(double));
  precicec_getMeshVertexIDsAndCoordinates("Provider-Mesh", size, ids, coordinates);
  for (int i = 0; i < size; ++i) values[i] = ids[i];
  record(values, size);
  record(coordinates, 2 * size);
  while (precicec_isCouplingOngoing()) {
    (void)precicec_requiresWritingCheckpoint();     /* asked, as preCICE wants */
    double dt = precicec_getMaxTimeStepSize();
    t += dt;
    for (int i = 0; i < size; ++i) values[i] = t + coordinates[2 * i] * coordinates[2 * i];
    precicec_writeData("Provider-Mesh", "D", size, ids, values);
    precicec_advance(dt);
    (void)precicec_requiresReadingCheckpoint();
  }
  free(ids);
  free(coordinates);
  free(values);
}

static void jit(void)
{
  double box[4] = {-1, 2, -1, 1}, points[6] = {0.12, 0.0, 0.5, 0.1, 0.93, 0.0}, forces[3] = {1.0, 2.0, 3.0};
  double values[3], single = 5.0;
  precicec_setMeshAccessRegion("A-Mesh", box);
  precicec_initialize();
  while (precicec_isCouplingOngoing()) {
    (void)precicec_requiresWritingCheckpoint();     /* asked, as preCICE wants */
    double dt = precicec_getMaxTimeStepSize();
    precicec_mapAndReadData("A-Mesh", "V", 3, points, dt, values);
    record(values, 3);
    precicec_writeAndMapData("A-Mesh", "F", 3, points, forces);
    precicec_writeAndMapData("A-Mesh", "F", 1, points, &single);
    precicec_advance(dt);
    (void)precicec_requiresReadingCheckpoint();
  }
}

static void gradient(void)
{
  double grid[24], s[12], v[24], ds[24], dv[48], asked[2], t = 0.0;
  int    ids[12];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 3; ++j) {
      grid[2 * (3 * i + j)]     = i * (1.0 / 3.0);     /* NumPy's linspace */
      grid[2 * (3 * i + j) + 1] = j * 0.5;
    }
  precicec_setMeshVertices("A-Mesh", 12, grid, ids);
  precicec_initialize();
  asked[0] = precicec_requiresGradientDataFor("A-Mesh", "S");
  asked[1] = precicec_requiresGradientDataFor("A-Mesh", "V");
  record(asked, 2);
  while (precicec_isCouplingOngoing()) {
    (void)precicec_requiresWritingCheckpoint();     /* asked, as preCICE wants */
    double dt = precicec_getMaxTimeStepSize();
    t += dt;
    for (int k = 0; k < 12; ++k) {
      double x = grid[2 * k], y = grid[2 * k + 1];
      s[k]          = t + 2 * x - y;
      v[2 * k]      = x + 2 * y;
      v[2 * k + 1]  = t * (3 * x - y);
      ds[2 * k]     = 2.0;
      ds[2 * k + 1] = -1.0;
      dv[4 * k]     = 1.0;
      dv[4 * k + 1] = 3.0 * t;
      dv[4 * k + 2] = 2.0;
      dv[4 * k + 3] = -t;
    }
    precicec_writeData("A-Mesh", "S", 12, ids, s);
    precicec_writeData("A-Mesh", "V", 12, ids, v);
    if (asked[0]) precicec_writeGradientData("A-Mesh", "S", 12, ids, ds);
    if (asked[1]) precicec_writeGradientData("A-Mesh", "V", 12, ids, dv);
    precicec_advance(dt);
    (void)precicec_requiresReadingCheckpoint();
  }
}

static void field(const char *part)
{
  const char *mesh = "Source-Mesh";
  double      grid[60], values[20], t = 0.0;
  int         ids[20], cells[72], n = 0, c = 0;
  int         volume = strcmp(part, "tetrahedra") == 0;
  if (volume) { /* the unit cube's corners, vertex x + 2y + 4z */
    for (int k = 0; k < 8; ++k) {
      grid[3 * k]     = k & 1;
      grid[3 * k + 1] = (k >> 1) & 1;
      grid[3 * k + 2] = (k >> 2) & 1;
    }
    n = 8;
  } else {      /* a 5 x 4 grid on the unit square, row by row */
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 5; ++i, ++n) {
        grid[2 * n]     = i * 0.25;
        grid[2 * n + 1] = j * (1.0 / 3.0);
      }
  }
  int dimensions = precicec_getMeshDimensions(mesh);
  precicec_setMeshVertices(mesh, n, grid, ids);
  check(precicec_requiresMeshConnectivityFor(mesh), "the mapping asks for connectivity");
  if (strcmp(part, "quads") == 0) {
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 4; ++i, c += 4) {
        int corner = 5 * j + i, quad[4] = {corner, corner + 1, corner + 6, corner + 5};
        memcpy(cells + c, quad, sizeof quad);
      }
    precicec_setMeshQuads(mesh, 11, cells);
    precicec_setMeshQuad(mesh, cells[44], cells[45], cells[46], cells[47]);
  } else if (strcmp(part, "triangles") == 0) {
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 4; ++i, c += 6) {
        int corner = 5 * j + i, pair[6] = {corner, corner + 1, corner + 6, corner, corner + 6, corner + 5};
        memcpy(cells + c, pair, sizeof pair);
      }
    precicec_setMeshTriangles(mesh, 23, cells);
    precicec_setMeshTriangle(mesh, cells[69], cells[70], cells[71]);
  } else if (strcmp(part, "edges") == 0) { /* along the top row */
    int top[6] = {15, 16, 16, 17, 17, 18};
    precicec_setMeshEdges(mesh, 3, top);
    precicec_setMeshEdge(mesh, 18, 19);
  } else {      /* Kuhn's six tetrahedra around the diagonal 0-7 */
    int axes[6][2] = {{1, 2}, {1, 4}, {2, 1}, {2, 4}, {4, 1}, {4, 2}};
    for (int k = 0; k < 6; ++k, c += 4) {
      int tetrahedron[4] = {0, axes[k][0], axes[k][0] + axes[k][1], 7};
      memcpy(cells + c, tetrahedron, sizeof tetrahedron);
    }
    precicec_setMeshTetrahedra(mesh, 5, cells);
    precicec_setMeshTetrahedron(mesh, cells[20], cells[21], cells[22], cells[23]);
  }
  precicec_initialize();
  while (precicec_isCouplingOngoing()) {
    (void)precicec_requiresWritingCheckpoint();     /* asked, as preCICE wants */
    double dt = precicec_getMaxTimeStepSize();
    t += dt;
    for (int k = 0; k < n; ++k) {
      const double *p = grid + dimensions * k;
      values[k]       = dimensions == 3 ? t + 2.0 * p[0] + 3.0 * p[1] - p[2] : t + 2.0 * p[0] + 3.0 * p[1] * p[1];
    }
    precicec_writeData(mesh, "T", n, ids, values);
    precicec_advance(dt);
    (void)precicec_requiresReadingCheckpoint();
  }
}

int main(int argc, char **argv)
{
  if (argc != 4) {
    fprintf(stderr, "usage: tour CONFIG PART PARTICIPANT\n");
    return 2;
  }
  const char *part = argv[2];
  printf("preCICE %s\n", precicec_getVersionInformation());
  fflush(stdout);
  seen = fopen("seen.txt", "w");
  if (strcmp(part, "gradient") == 0) {
    int communicator = 0;
    precicec_createParticipant_withCommunicator(argv[3], argv[1], 0, 1, &communicator);
  } else {
    precicec_createParticipant(argv[3], argv[1], 0, 1);
  }
  if (strcmp(part, "subcycling") == 0) subcycling();
  else if (strcmp(part, "partner") == 0) partner();
  else if (strcmp(part, "direct") == 0) direct();
  else if (strcmp(part, "jit") == 0) jit();
  else if (strcmp(part, "gradient") == 0) gradient();
  else if (strcmp(part, "reset") == 0) {
    double origin[2] = {0.0, 0.0};
    precicec_setMeshVertex("A-Mesh", origin);
    precicec_initialize();
    precicec_resetMesh("A-Mesh");
  } else field(part);
  precicec_finalize();
  fclose(seen);
  return 0;
}
