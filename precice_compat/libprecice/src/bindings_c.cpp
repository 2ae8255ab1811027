// preCICE v3's C API (precicec_*) on the core: one participant per process. A misuse ends the program with its line
// and exit code 2 (fatal.hpp).

#include "precice/preciceC.h"

#include <memory>
#include <string>

#include "core.hpp"
#include "fatal.hpp"
#include "the_participant.hpp"

using precice::impl::Core;

namespace {

std::string name_of(const char *call, const char *text)
{
  if (!text) cosim::exit_on_error(std::string(call) + ": a name is a null pointer");
  return text;
}

template <typename Body>
auto with(const char *call, Body &&body) -> decltype(body(*static_cast<Core *>(nullptr)))
{
  return cosim::guarded([&]() -> decltype(body(*static_cast<Core *>(nullptr))) { return body(cosim::the_participant(call)); });
}

std::size_t count_of(const char *call, int size)
{
  if (size < 0) cosim::exit_on_error(std::string(call) + ": a size of " + std::to_string(size) + " is negative");
  return static_cast<std::size_t>(size);
}

} // namespace

extern "C" {

void precicec_createParticipant(const char *participantName, const char *configFileName, int solverProcessIndex,
                                int solverProcessSize)
{
  const char *call = "precicec_createParticipant";
  std::string name = name_of(call, participantName), config = name_of(call, configFileName);
  cosim::guarded([&]() { cosim::create_the_participant(call, name, config, solverProcessIndex, solverProcessSize); });
}

void precicec_createParticipant_withCommunicator(const char *participantName, const char *configFileName,
                                                 int solverProcessIndex, int solverProcessSize, void *)
{
  precicec_createParticipant(participantName, configFileName, solverProcessIndex, solverProcessSize);
}

void precicec_initialize(void)
{
  with("precicec_initialize", [](Core &core) { core.initialize("precicec_initialize"); });
}

void precicec_advance(double computedTimeStepSize)
{
  with("precicec_advance", [&](Core &core) { core.advance("precicec_advance", computedTimeStepSize); });
}

void precicec_finalize(void)
{
  with("precicec_finalize", [](Core &core) { core.finalize("precicec_finalize"); });
  cosim::destroy_the_participant();
}

int precicec_requiresWritingCheckpoint(void)
{
  return with("precicec_requiresWritingCheckpoint", [](Core &core) { return core.write_checkpoint() ? 1 : 0; });
}

int precicec_requiresReadingCheckpoint(void)
{
  return with("precicec_requiresReadingCheckpoint", [](Core &core) { return core.read_checkpoint() ? 1 : 0; });
}

int precicec_getMeshDimensions(const char *meshName)
{
  const char *call = "precicec_getMeshDimensions";
  return with(call, [&](Core &core) { return core.mesh_dimensions(call, name_of(call, meshName)); });
}

int precicec_getDataDimensions(const char *meshName, const char *dataName)
{
  const char *call = "precicec_getDataDimensions";
  return with(call, [&](Core &core) { return core.data_dimensions(call, name_of(call, meshName), name_of(call, dataName)); });
}

int precicec_isCouplingOngoing(void)
{
  return with("precicec_isCouplingOngoing", [](Core &core) { return core.ongoing() ? 1 : 0; });
}

int precicec_isTimeWindowComplete(void)
{
  return with("precicec_isTimeWindowComplete", [](Core &core) { return core.window_complete() ? 1 : 0; });
}

double precicec_getMaxTimeStepSize(void)
{
  return with("precicec_getMaxTimeStepSize", [](Core &core) { return core.remaining(); });
}

int precicec_requiresMeshConnectivityFor(const char *meshName)
{
  const char *call = "precicec_requiresMeshConnectivityFor";
  return with(call, [&](Core &core) { return core.requires_connectivity(call, name_of(call, meshName)) ? 1 : 0; });
}

void precicec_resetMesh(const char *meshName)
{
  const char *call = "precicec_resetMesh";
  with(call, [&](Core &core) { core.reset_mesh(call, name_of(call, meshName)); });
}

int precicec_setMeshVertex(const char *meshName, const double *coordinates)
{
  const char *call = "precicec_setMeshVertex";
  return with(call, [&](Core &core) {
    std::string mesh = name_of(call, meshName);
    int         dimensions = core.mesh_dimensions(call, mesh);
    return core.add_vertices(call, mesh, coordinates, static_cast<std::size_t>(dimensions), nullptr);
  });
}

int precicec_getMeshVertexSize(const char *meshName)
{
  const char *call = "precicec_getMeshVertexSize";
  return with(call, [&](Core &core) { return core.mesh_vertex_size(call, name_of(call, meshName)); });
}

void precicec_setMeshVertices(const char *meshName, int size, const double *coordinates, int *ids)
{
  const char *call = "precicec_setMeshVertices";
  with(call, [&](Core &core) {
    std::string mesh = name_of(call, meshName);
    std::size_t dimensions = static_cast<std::size_t>(core.mesh_dimensions(call, mesh));
    core.add_vertices(call, mesh, coordinates, count_of(call, size) * dimensions, ids);
  });
}

void precicec_setMeshEdge(const char *meshName, int firstVertexID, int secondVertexID)
{
  const char *call  = "precicec_setMeshEdge";
  const int   ids[] = {firstVertexID, secondVertexID};
  with(call, [&](Core &core) { core.connect(call, name_of(call, meshName), ids, 2, 2, false); });
}

void precicec_setMeshEdges(const char *meshName, int size, const int *ids)
{
  const char *call = "precicec_setMeshEdges";
  with(call, [&](Core &core) { core.connect(call, name_of(call, meshName), ids, 2 * count_of(call, size), 2, false); });
}

void precicec_setMeshTriangle(const char *meshName, int firstVertexID, int secondVertexID, int thirdVertexID)
{
  const char *call  = "precicec_setMeshTriangle";
  const int   ids[] = {firstVertexID, secondVertexID, thirdVertexID};
  with(call, [&](Core &core) { core.connect(call, name_of(call, meshName), ids, 3, 3, false); });
}

void precicec_setMeshTriangles(const char *meshName, int size, const int *ids)
{
  const char *call = "precicec_setMeshTriangles";
  with(call, [&](Core &core) { core.connect(call, name_of(call, meshName), ids, 3 * count_of(call, size), 3, false); });
}

void precicec_setMeshQuad(const char *meshName, int firstVertexID, int secondVertexID, int thirdVertexID,
                          int fourthVertexID)
{
  const char *call  = "precicec_setMeshQuad";
  const int   ids[] = {firstVertexID, secondVertexID, thirdVertexID, fourthVertexID};
  with(call, [&](Core &core) { core.connect(call, name_of(call, meshName), ids, 4, 4, true); });
}

void precicec_setMeshQuads(const char *meshName, int size, const int *ids)
{
  const char *call = "precicec_setMeshQuads";
  with(call, [&](Core &core) { core.connect(call, name_of(call, meshName), ids, 4 * count_of(call, size), 4, true); });
}

void precicec_setMeshTetrahedron(const char *meshName, int firstVertexID, int secondVertexID, int thirdVertexID,
                                 int fourthVertexID)
{
  const char *call  = "precicec_setMeshTetrahedron";
  const int   ids[] = {firstVertexID, secondVertexID, thirdVertexID, fourthVertexID};
  with(call, [&](Core &core) { core.connect(call, name_of(call, meshName), ids, 4, 4, false); });
}

void precicec_setMeshTetrahedra(const char *meshName, int size, const int *ids)
{
  const char *call = "precicec_setMeshTetrahedra";
  with(call, [&](Core &core) { core.connect(call, name_of(call, meshName), ids, 4 * count_of(call, size), 4, false); });
}

int precicec_requiresInitialData(void)
{
  return with("precicec_requiresInitialData", [](Core &core) { return core.requires_initial_data() ? 1 : 0; });
}

void precicec_writeData(const char *meshName, const char *dataName, int size, const int *valueIndices,
                        const double *values)
{
  const char *call = "precicec_writeData";
  with(call, [&](Core &core) {
    std::string mesh = name_of(call, meshName), data = name_of(call, dataName);
    std::size_t n = count_of(call, size);
    core.write_values(call, mesh, data, valueIndices, n, values, n * core.data_dimensions(call, mesh, data));
  });
}

void precicec_readData(const char *meshName, const char *dataName, int size, const int *valueIndices,
                       double relativeReadTime, double *values)
{
  const char *call = "precicec_readData";
  with(call, [&](Core &core) {
    std::string mesh = name_of(call, meshName), data = name_of(call, dataName);
    std::size_t n = count_of(call, size);
    core.read_values(call, mesh, data, valueIndices, n, relativeReadTime, values,
                     n * core.data_dimensions(call, mesh, data));
  });
}

void precicec_writeAndMapData(const char *meshName, const char *dataName, int size, const double *coordinates,
                              const double *values)
{
  const char *call = "precicec_writeAndMapData";
  with(call, [&](Core &core) {
    std::string mesh = name_of(call, meshName), data = name_of(call, dataName);
    std::size_t n = count_of(call, size);
    core.write_and_map(call, mesh, data, coordinates, n * core.mesh_dimensions(call, mesh), values,
                       n * core.data_dimensions(call, mesh, data));
  });
}

void precicec_mapAndReadData(const char *meshName, const char *dataName, int size, const double *coordinates,
                             double relativeReadTime, double *values)
{
  const char *call = "precicec_mapAndReadData";
  with(call, [&](Core &core) {
    std::string mesh = name_of(call, meshName), data = name_of(call, dataName);
    std::size_t n = count_of(call, size);
    core.map_and_read(call, mesh, data, coordinates, n * core.mesh_dimensions(call, mesh), relativeReadTime, values,
                      n * core.data_dimensions(call, mesh, data));
  });
}

void precicec_setMeshAccessRegion(const char *meshName, const double *boundingBox)
{
  const char *call = "precicec_setMeshAccessRegion";
  with(call, [&](Core &core) {
    std::string mesh = name_of(call, meshName);
    core.set_access_region(call, mesh, boundingBox, 2 * static_cast<std::size_t>(core.mesh_dimensions(call, mesh)));
  });
}

void precicec_getMeshVertexIDsAndCoordinates(const char *meshName, const int size, int *ids, double *coordinates)
{
  const char *call = "precicec_getMeshVertexIDsAndCoordinates";
  with(call, [&](Core &core) { core.region_vertices(call, name_of(call, meshName), ids, coordinates, count_of(call, size), true); });
}

int precicec_requiresGradientDataFor(const char *meshName, const char *dataName)
{
  const char *call = "precicec_requiresGradientDataFor";
  return with(call, [&](Core &core) {
    return core.requires_gradient(call, name_of(call, meshName), name_of(call, dataName)) ? 1 : 0;
  });
}

void precicec_writeGradientData(const char *meshName, const char *dataName, int size, const int *valueIndices,
                                const double *gradients)
{
  const char *call = "precicec_writeGradientData";
  with(call, [&](Core &core) {
    std::string mesh = name_of(call, meshName), data = name_of(call, dataName);
    std::size_t n = count_of(call, size);
    core.write_gradients(call, mesh, data, valueIndices, n, gradients,
                         n * core.mesh_dimensions(call, mesh) * core.data_dimensions(call, mesh, data));
  });
}

void precicec_startProfilingSection(const char *) {}

void precicec_stopLastProfilingSection(void) {}

const char *precicec_getVersionInformation(void) { return cosim::version_information(); }

} // extern "C"
