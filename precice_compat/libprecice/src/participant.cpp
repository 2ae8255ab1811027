// preCICE v3's C++ API (precice::Participant) on the core.

#include "precice/Participant.hpp"

#include <string>

#include "core.hpp"

namespace precice {

namespace {

std::string text(::precice::string_view view) { return std::string(view.data(), view.size()); }

} // namespace

Participant::Participant(::precice::string_view participantName, ::precice::string_view configurationFileName,
                         int solverProcessIndex, int solverProcessSize)
    : _impl(new impl::Core(text(participantName), text(configurationFileName), solverProcessIndex, solverProcessSize,
                           "Participant::Participant"))
{
}

Participant::Participant(::precice::string_view participantName, ::precice::string_view configurationFileName,
                         int solverProcessIndex, int solverProcessSize, void *)
    : Participant(participantName, configurationFileName, solverProcessIndex, solverProcessSize)
{
}

Participant::~Participant() = default;

void Participant::initialize() { _impl->initialize("Participant::initialize"); }

void Participant::advance(double computedTimeStepSize) { _impl->advance("Participant::advance", computedTimeStepSize); }

void Participant::finalize() { _impl->finalize("Participant::finalize"); }

bool Participant::requiresWritingCheckpoint() { return _impl->write_checkpoint(); }

bool Participant::requiresReadingCheckpoint() { return _impl->read_checkpoint(); }

int Participant::getMeshDimensions(::precice::string_view meshName) const
{
  return _impl->mesh_dimensions("Participant::getMeshDimensions", text(meshName));
}

int Participant::getDataDimensions(::precice::string_view meshName, ::precice::string_view dataName) const
{
  return _impl->data_dimensions("Participant::getDataDimensions", text(meshName), text(dataName));
}

bool Participant::isCouplingOngoing() const { return _impl->ongoing(); }

bool Participant::isTimeWindowComplete() const { return _impl->window_complete(); }

double Participant::getMaxTimeStepSize() const { return _impl->remaining(); }

bool Participant::requiresMeshConnectivityFor(::precice::string_view meshName) const
{
  return _impl->requires_connectivity("Participant::requiresMeshConnectivityFor", text(meshName));
}

void Participant::resetMesh(::precice::string_view meshName) { _impl->reset_mesh("Participant::resetMesh", text(meshName)); }

VertexID Participant::setMeshVertex(::precice::string_view meshName, ::precice::span<const double> position)
{
  const std::string call = "Participant::setMeshVertex";
  const int         dimensions = _impl->mesh_dimensions(call, text(meshName));
  if (position.size() != static_cast<std::size_t>(dimensions))
    _impl->fail(call, "a position of " + std::to_string(position.size()) + " coordinates on mesh '" + text(meshName) +
                          "' of " + std::to_string(dimensions) + " dimensions");
  return _impl->add_vertices(call, text(meshName), position.data(), position.size(), nullptr);
}

int Participant::getMeshVertexSize(::precice::string_view meshName) const
{
  return _impl->mesh_vertex_size("Participant::getMeshVertexSize", text(meshName));
}

void Participant::setMeshVertices(::precice::string_view meshName, ::precice::span<const double> coordinates,
                                  ::precice::span<VertexID> ids)
{
  const std::string call       = "Participant::setMeshVertices";
  const std::size_t dimensions = static_cast<std::size_t>(_impl->mesh_dimensions(call, text(meshName)));
  if (coordinates.size() != ids.size() * dimensions)
    _impl->fail(call, std::to_string(coordinates.size()) + " coordinates for " + std::to_string(ids.size()) +
                          " ids on mesh '" + text(meshName) + "' of " + std::to_string(dimensions) +
                          " dimensions; expected " + std::to_string(ids.size() * dimensions));
  _impl->add_vertices(call, text(meshName), coordinates.data(), coordinates.size(), ids.data());
}

void Participant::setMeshEdge(::precice::string_view meshName, VertexID first, VertexID second)
{
  const int ids[] = {first, second};
  _impl->connect("Participant::setMeshEdge", text(meshName), ids, 2, 2, false);
}

void Participant::setMeshEdges(::precice::string_view meshName, ::precice::span<const VertexID> ids)
{
  _impl->connect("Participant::setMeshEdges", text(meshName), ids.data(), ids.size(), 2, false);
}

void Participant::setMeshTriangle(::precice::string_view meshName, VertexID first, VertexID second, VertexID third)
{
  const int ids[] = {first, second, third};
  _impl->connect("Participant::setMeshTriangle", text(meshName), ids, 3, 3, false);
}

void Participant::setMeshTriangles(::precice::string_view meshName, ::precice::span<const VertexID> ids)
{
  _impl->connect("Participant::setMeshTriangles", text(meshName), ids.data(), ids.size(), 3, false);
}

void Participant::setMeshQuad(::precice::string_view meshName, VertexID first, VertexID second, VertexID third,
                              VertexID fourth)
{
  const int ids[] = {first, second, third, fourth};
  _impl->connect("Participant::setMeshQuad", text(meshName), ids, 4, 4, true);
}

void Participant::setMeshQuads(::precice::string_view meshName, ::precice::span<const VertexID> ids)
{
  _impl->connect("Participant::setMeshQuads", text(meshName), ids.data(), ids.size(), 4, true);
}

void Participant::setMeshTetrahedron(::precice::string_view meshName, VertexID first, VertexID second, VertexID third,
                                     VertexID fourth)
{
  const int ids[] = {first, second, third, fourth};
  _impl->connect("Participant::setMeshTetrahedron", text(meshName), ids, 4, 4, false);
}

void Participant::setMeshTetrahedra(::precice::string_view meshName, ::precice::span<const VertexID> ids)
{
  _impl->connect("Participant::setMeshTetrahedra", text(meshName), ids.data(), ids.size(), 4, false);
}

bool Participant::requiresInitialData() { return _impl->requires_initial_data(); }

void Participant::writeData(::precice::string_view meshName, ::precice::string_view dataName,
                            ::precice::span<const VertexID> ids, ::precice::span<const double> values)
{
  _impl->write_values("Participant::writeData", text(meshName), text(dataName), ids.data(), ids.size(), values.data(),
                      values.size());
}

void Participant::readData(::precice::string_view meshName, ::precice::string_view dataName,
                           ::precice::span<const VertexID> ids, double relativeReadTime,
                           ::precice::span<double> values) const
{
  _impl->read_values("Participant::readData", text(meshName), text(dataName), ids.data(), ids.size(), relativeReadTime,
                     values.data(), values.size());
}

void Participant::writeAndMapData(::precice::string_view meshName, ::precice::string_view dataName,
                                  ::precice::span<const double> coordinates, ::precice::span<const double> values)
{
  _impl->write_and_map("Participant::writeAndMapData", text(meshName), text(dataName), coordinates.data(),
                       coordinates.size(), values.data(), values.size());
}

void Participant::mapAndReadData(::precice::string_view meshName, ::precice::string_view dataName,
                                 ::precice::span<const double> coordinates, double relativeReadTime,
                                 ::precice::span<double> values) const
{
  _impl->map_and_read("Participant::mapAndReadData", text(meshName), text(dataName), coordinates.data(),
                      coordinates.size(), relativeReadTime, values.data(), values.size());
}

void Participant::setMeshAccessRegion(::precice::string_view meshName, ::precice::span<const double> boundingBox) const
{
  _impl->set_access_region("Participant::setMeshAccessRegion", text(meshName), boundingBox.data(), boundingBox.size());
}

void Participant::getMeshVertexIDsAndCoordinates(::precice::string_view meshName, ::precice::span<VertexID> ids,
                                                 ::precice::span<double> coordinates) const
{
  const std::string call       = "Participant::getMeshVertexIDsAndCoordinates";
  const std::size_t dimensions = static_cast<std::size_t>(_impl->mesh_dimensions(call, text(meshName)));
  if (coordinates.size() != ids.size() * dimensions)
    _impl->fail(call, "room for " + std::to_string(coordinates.size()) + " coordinates of " +
                          std::to_string(ids.size()) + " vertices of " + std::to_string(dimensions) + " dimensions");
  _impl->region_vertices(call, text(meshName), ids.data(), coordinates.data(), ids.size(), true);
}

bool Participant::requiresGradientDataFor(::precice::string_view meshName, ::precice::string_view dataName) const
{
  return _impl->requires_gradient("Participant::requiresGradientDataFor", text(meshName), text(dataName));
}

void Participant::writeGradientData(::precice::string_view meshName, ::precice::string_view dataName,
                                    ::precice::span<const VertexID> ids, ::precice::span<const double> gradients)
{
  _impl->write_gradients("Participant::writeGradientData", text(meshName), text(dataName), ids.data(), ids.size(),
                         gradients.data(), gradients.size());
}

void Participant::startProfilingSection(::precice::string_view) {}

void Participant::stopLastProfilingSection() {}

} // namespace precice
