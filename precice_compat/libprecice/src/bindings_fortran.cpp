// preCICE v3's Fortran API (precicef_*) on the core: every argument by reference, each string's length after the
// others, names trimmed of trailing blanks. A misuse ends the program with its line and exit code 2 (fatal.hpp).

#include "precice/preciceFortran.hpp"

#include <algorithm>
#include <cstring>
#include <string>

#include "core.hpp"
#include "fatal.hpp"
#include "the_participant.hpp"

using precice::impl::Core;

namespace {

// a Fortran string: its characters up to the trailing blanks (and any NUL)
std::string trimmed(const char *text, int length)
{
  if (!text || length <= 0) return "";
  std::size_t n = static_cast<std::size_t>(length);
  const char *nul = static_cast<const char *>(std::memchr(text, '\0', n));
  if (nul) n = static_cast<std::size_t>(nul - text);
  while (n > 0 && (text[n - 1] == ' ' || text[n - 1] == '\t')) --n;
  return std::string(text, n);
}

template <typename Body>
void with(const char *call, Body &&body)
{
  cosim::guarded([&]() { body(cosim::the_participant(call)); });
}

std::size_t count_of(const char *call, const int *size)
{
  if (!size || *size < 0) cosim::exit_on_error(std::string(call) + ": the size is negative or missing");
  return static_cast<std::size_t>(*size);
}

void connect(const char *call, const char *meshName, int meshNameLength, const int *ids, std::size_t count,
             int per_element, bool quad)
{
  with(call, [&](Core &core) { core.connect(call, trimmed(meshName, meshNameLength), ids, count, per_element, quad); });
}

} // namespace

extern "C" {

void precicef_create_(const char *participantName, const char *configFileName, const int *solverProcessIndex,
                      const int *solverProcessSize, int participantNameLength, int configFileNameLength)
{
  const char *call = "precicef_create";
  std::string name = trimmed(participantName, participantNameLength);
  std::string config = trimmed(configFileName, configFileNameLength);
  cosim::guarded([&]() { cosim::create_the_participant(call, name, config, *solverProcessIndex, *solverProcessSize); });
}

void precicef_create_with_communicator_(const char *participantName, const char *configFileName,
                                        const int *solverProcessIndex, const int *solverProcessSize, const int *,
                                        int participantNameLength, int configFileNameLength)
{
  precicef_create_(participantName, configFileName, solverProcessIndex, solverProcessSize, participantNameLength,
                   configFileNameLength);
}

void precicef_initialize_(void)
{
  with("precicef_initialize", [](Core &core) { core.initialize("precicef_initialize"); });
}

void precicef_advance_(const double *timeStepSize)
{
  with("precicef_advance", [&](Core &core) { core.advance("precicef_advance", *timeStepSize); });
}

void precicef_finalize_(void)
{
  with("precicef_finalize", [](Core &core) { core.finalize("precicef_finalize"); });
  cosim::destroy_the_participant();
}

void precicef_requires_reading_checkpoint_(int *isRequired)
{
  with("precicef_requires_reading_checkpoint", [&](Core &core) { *isRequired = core.read_checkpoint() ? 1 : 0; });
}

void precicef_requires_writing_checkpoint_(int *isRequired)
{
  with("precicef_requires_writing_checkpoint", [&](Core &core) { *isRequired = core.write_checkpoint() ? 1 : 0; });
}

void precicef_get_mesh_dimensions_(const char *meshName, int *dimensions, int meshNameLength)
{
  const char *call = "precicef_get_mesh_dimensions";
  with(call, [&](Core &core) { *dimensions = core.mesh_dimensions(call, trimmed(meshName, meshNameLength)); });
}

void precicef_get_data_dimensions_(const char *meshName, const char *dataName, int *dimensions, int meshNameLength,
                                   int dataNameLength)
{
  const char *call = "precicef_get_data_dimensions";
  with(call, [&](Core &core) {
    *dimensions = core.data_dimensions(call, trimmed(meshName, meshNameLength), trimmed(dataName, dataNameLength));
  });
}

void precicef_is_coupling_ongoing_(int *isOngoing)
{
  with("precicef_is_coupling_ongoing", [&](Core &core) { *isOngoing = core.ongoing() ? 1 : 0; });
}

void precicef_is_time_window_complete_(int *isComplete)
{
  with("precicef_is_time_window_complete", [&](Core &core) { *isComplete = core.window_complete() ? 1 : 0; });
}

void precicef_get_max_time_step_size_(double *maxTimeStepSize)
{
  with("precicef_get_max_time_step_size", [&](Core &core) { *maxTimeStepSize = core.remaining(); });
}

void precicef_requires_mesh_connectivity_for_(const char *meshName, int *required, int meshNameLength)
{
  const char *call = "precicef_requires_mesh_connectivity_for";
  with(call, [&](Core &core) { *required = core.requires_connectivity(call, trimmed(meshName, meshNameLength)) ? 1 : 0; });
}

void precicef_reset_mesh_(const char *meshName, int meshNameLength)
{
  const char *call = "precicef_reset_mesh";
  with(call, [&](Core &core) { core.reset_mesh(call, trimmed(meshName, meshNameLength)); });
}

void precicef_set_mesh_vertex_(const char *meshName, const double *coordinates, int *id, int meshNameLength)
{
  const char *call = "precicef_set_mesh_vertex";
  with(call, [&](Core &core) {
    std::string mesh = trimmed(meshName, meshNameLength);
    *id = core.add_vertices(call, mesh, coordinates, static_cast<std::size_t>(core.mesh_dimensions(call, mesh)), nullptr);
  });
}

void precicef_set_vertex_(const char *meshName, const double *coordinates, int *id, int meshNameLength)
{
  precicef_set_mesh_vertex_(meshName, coordinates, id, meshNameLength);
}

void precicef_get_mesh_vertex_size_(const char *meshName, int *meshSize, int meshNameLength)
{
  const char *call = "precicef_get_mesh_vertex_size";
  with(call, [&](Core &core) { *meshSize = core.mesh_vertex_size(call, trimmed(meshName, meshNameLength)); });
}

void precicef_set_mesh_vertices_(const char *meshName, const int *size, double *coordinates, int *ids,
                                 int meshNameLength)
{
  const char *call = "precicef_set_mesh_vertices";
  with(call, [&](Core &core) {
    std::string mesh = trimmed(meshName, meshNameLength);
    core.add_vertices(call, mesh, coordinates, count_of(call, size) * core.mesh_dimensions(call, mesh), ids);
  });
}

void precicef_set_vertices_(const char *meshName, const int *size, double *coordinates, int *ids, int meshNameLength)
{
  precicef_set_mesh_vertices_(meshName, size, coordinates, ids, meshNameLength);
}

void precicef_set_mesh_edge_(const char *meshName, const int *firstVertexID, const int *secondVertexID,
                             int meshNameLength)
{
  const int ids[] = {*firstVertexID, *secondVertexID};
  connect("precicef_set_mesh_edge", meshName, meshNameLength, ids, 2, 2, false);
}

void precicef_set_edge_(const char *meshName, const int *firstVertexID, const int *secondVertexID, int meshNameLength)
{
  precicef_set_mesh_edge_(meshName, firstVertexID, secondVertexID, meshNameLength);
}

void precicef_set_mesh_edges_(const char *meshName, const int *size, const int *ids, int meshNameLength)
{
  const char *call = "precicef_set_mesh_edges";
  connect(call, meshName, meshNameLength, ids, 2 * count_of(call, size), 2, false);
}

void precicef_set_mesh_triangle_(const char *meshName, const int *firstVertexID, const int *secondVertexID,
                                 const int *thirdVertexID, int meshNameLength)
{
  const int ids[] = {*firstVertexID, *secondVertexID, *thirdVertexID};
  connect("precicef_set_mesh_triangle", meshName, meshNameLength, ids, 3, 3, false);
}

void precicef_set_triangle_(const char *meshName, const int *firstVertexID, const int *secondVertexID,
                            const int *thirdVertexID, int meshNameLength)
{
  precicef_set_mesh_triangle_(meshName, firstVertexID, secondVertexID, thirdVertexID, meshNameLength);
}

void precicef_set_mesh_triangles_(const char *meshName, const int *size, const int *ids, int meshNameLength)
{
  const char *call = "precicef_set_mesh_triangles";
  connect(call, meshName, meshNameLength, ids, 3 * count_of(call, size), 3, false);
}

void precicef_set_mesh_quad_(const char *meshName, const int *firstVertexID, const int *secondVertexID,
                             const int *thirdVertexID, const int *fourthVertexID, int meshNameLength)
{
  const int ids[] = {*firstVertexID, *secondVertexID, *thirdVertexID, *fourthVertexID};
  connect("precicef_set_mesh_quad", meshName, meshNameLength, ids, 4, 4, true);
}

void precicef_set_quad_(const char *meshName, const int *firstVertexID, const int *secondVertexID,
                        const int *thirdVertexID, const int *fourthVertexID, int meshNameLength)
{
  precicef_set_mesh_quad_(meshName, firstVertexID, secondVertexID, thirdVertexID, fourthVertexID, meshNameLength);
}

void precicef_set_mesh_quads_(const char *meshName, const int *size, const int *ids, int meshNameLength)
{
  const char *call = "precicef_set_mesh_quads";
  connect(call, meshName, meshNameLength, ids, 4 * count_of(call, size), 4, true);
}

void precicef_set_mesh_tetrahedron_(const char *meshName, const int *firstVertexID, const int *secondVertexID,
                                    const int *thirdVertexID, const int *fourthVertexID, int meshNameLength)
{
  const int ids[] = {*firstVertexID, *secondVertexID, *thirdVertexID, *fourthVertexID};
  connect("precicef_set_mesh_tetrahedron", meshName, meshNameLength, ids, 4, 4, false);
}

void precicef_set_tetrahedron_(const char *meshName, const int *firstVertexID, const int *secondVertexID,
                               const int *thirdVertexID, const int *fourthVertexID, int meshNameLength)
{
  precicef_set_mesh_tetrahedron_(meshName, firstVertexID, secondVertexID, thirdVertexID, fourthVertexID,
                                 meshNameLength);
}

void precicef_set_tetrahedron(const char *meshName, const int *firstVertexID, const int *secondVertexID,
                              const int *thirdVertexID, const int *fourthVertexID, int meshNameLength)
{
  precicef_set_mesh_tetrahedron_(meshName, firstVertexID, secondVertexID, thirdVertexID, fourthVertexID,
                                 meshNameLength);
}

void precicef_set_mesh_tetrahedra_(const char *meshName, const int *size, const int *ids, int meshNameLength)
{
  const char *call = "precicef_set_mesh_tetrahedra";
  connect(call, meshName, meshNameLength, ids, 4 * count_of(call, size), 4, false);
}

void precicef_requires_initial_data_(int *isRequired)
{
  with("precicef_requires_initial_data", [&](Core &core) { *isRequired = core.requires_initial_data() ? 1 : 0; });
}

void precicef_write_data_(const char *meshName, const char *dataName, const int *size, int *ids, double *values,
                          int meshNameLength, int dataNameLength)
{
  const char *call = "precicef_write_data";
  with(call, [&](Core &core) {
    std::string mesh = trimmed(meshName, meshNameLength), data = trimmed(dataName, dataNameLength);
    std::size_t n = count_of(call, size);
    core.write_values(call, mesh, data, ids, n, values, n * core.data_dimensions(call, mesh, data));
  });
}

void precicef_read_data_(const char *meshName, const char *dataName, const int *size, int *ids,
                         const double *relativeReadTime, double *values, int meshNameLength, int dataNameLength)
{
  const char *call = "precicef_read_data";
  with(call, [&](Core &core) {
    std::string mesh = trimmed(meshName, meshNameLength), data = trimmed(dataName, dataNameLength);
    std::size_t n = count_of(call, size);
    core.read_values(call, mesh, data, ids, n, *relativeReadTime, values, n * core.data_dimensions(call, mesh, data));
  });
}

void precicef_write_and_map_data_(const char *meshName, const char *dataName, const int *size, double *coordinates,
                                  double *values, int meshNameLength, int dataNameLength)
{
  const char *call = "precicef_write_and_map_data";
  with(call, [&](Core &core) {
    std::string mesh = trimmed(meshName, meshNameLength), data = trimmed(dataName, dataNameLength);
    std::size_t n = count_of(call, size);
    core.write_and_map(call, mesh, data, coordinates, n * core.mesh_dimensions(call, mesh), values,
                       n * core.data_dimensions(call, mesh, data));
  });
}

void precicef_map_and_read_data_(const char *meshName, const char *dataName, const int *size, double *coordinates,
                                 const double *relativeReadTime, double *values, int meshNameLength,
                                 int dataNameLength)
{
  const char *call = "precicef_map_and_read_data";
  with(call, [&](Core &core) {
    std::string mesh = trimmed(meshName, meshNameLength), data = trimmed(dataName, dataNameLength);
    std::size_t n = count_of(call, size);
    core.map_and_read(call, mesh, data, coordinates, n * core.mesh_dimensions(call, mesh), *relativeReadTime, values,
                      n * core.data_dimensions(call, mesh, data));
  });
}

void precicef_set_mesh_access_region_(const char *meshName, const double *boundingBox, int meshNameLength)
{
  const char *call = "precicef_set_mesh_access_region";
  with(call, [&](Core &core) {
    std::string mesh = trimmed(meshName, meshNameLength);
    core.set_access_region(call, mesh, boundingBox, 2 * static_cast<std::size_t>(core.mesh_dimensions(call, mesh)));
  });
}

void precicef_get_mesh_vertex_ids_and_coordinates_(const char *meshName, const int *size, int *ids,
                                                   double *coordinates, int meshNameLength)
{
  const char *call = "precicef_get_mesh_vertex_ids_and_coordinates";
  with(call, [&](Core &core) {
    core.region_vertices(call, trimmed(meshName, meshNameLength), ids, coordinates, count_of(call, size), true);
  });
}

void precicef_requires_gradient_data_for_(const char *meshName, const char *dataName, int *required,
                                          int meshNameLength, int dataNameLength)
{
  const char *call = "precicef_requires_gradient_data_for";
  with(call, [&](Core &core) {
    *required = core.requires_gradient(call, trimmed(meshName, meshNameLength), trimmed(dataName, dataNameLength)) ? 1 : 0;
  });
}

void precicef_write_gradient_data_(const char *meshName, const char *dataName, const int *size, const int *ids,
                                   const double *gradients, int meshNameLength, int dataNameLength)
{
  const char *call = "precicef_write_gradient_data";
  with(call, [&](Core &core) {
    std::string mesh = trimmed(meshName, meshNameLength), data = trimmed(dataName, dataNameLength);
    std::size_t n = count_of(call, size);
    core.write_gradients(call, mesh, data, ids, n, gradients,
                         n * core.mesh_dimensions(call, mesh) * core.data_dimensions(call, mesh, data));
  });
}

void precicef_start_profiling_section_(const char *, int) {}

void precicef_stop_last_profiling_section_(void) {}

void precicef_get_version_information_(char *versionInfo, int lengthVersionInfo)
{
  if (!versionInfo || lengthVersionInfo <= 0) return;
  const std::string text   = cosim::version_information();
  const std::size_t length = static_cast<std::size_t>(lengthVersionInfo);
  const std::size_t n      = std::min(text.size(), length);
  std::memcpy(versionInfo, text.data(), n);
  std::memset(versionInfo + n, ' ', length - n);
}

} // extern "C"
