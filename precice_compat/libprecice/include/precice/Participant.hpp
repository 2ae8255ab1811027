#pragma once
// preCICE v3's participant, served by cosim's coupler (cosim's libprecice).
//
// A solver couples in preCICE's order: define its meshes (vertices, connectivity, access regions), write any initial
// data, initialize(), then, while isCouplingOngoing(): compute, writeData(), advance(), readData(); and finalize().
// Arrays are flat: coordinates and vector data interleaved per vertex (x0 y0 x1 y1 ...). Every misuse throws
// precice::Error, whose what() is one line naming the call and why; the coupler's run stops with the same line. An
// uncaught precice::Error ends the program with that line on stderr ("precice: error: ...") and exit code 2.
//
// Where cosim differs from preCICE: the participant connects to cosim's coupler (`cosim run` tells a participant it
// starts where; one started by hand finds it in cosim-run/coupler.json next to the configuration, and the first one
// started by hand starts it), and no MPI is used (each rank connects on its own, and the coupler joins them).

#include <memory>

#include "precice/Exceptions.hpp"
#include "precice/Types.hpp"
#include "precice/Version.h"
#include "precice/export.h"
#include "precice/span.hpp"

namespace precice {

namespace impl {
class Core;
}

using string_view = ::precice::span<const char>;

class PRECICE_API Participant {
public:
  // Connects to the coupler and receives the participant's meshes, data and time window. The rank goes from 0 to
  // size - 1.
  Participant(::precice::string_view participantName, ::precice::string_view configurationFileName,
              int solverProcessIndex, int solverProcessSize);
  // The communicator is accepted and not used.
  Participant(::precice::string_view participantName, ::precice::string_view configurationFileName,
              int solverProcessIndex, int solverProcessSize, void *communicator);
  // Finalizes a participant whose coupling is over; any other has its connection closed (the coupler names it).
  ~Participant();

  Participant(const Participant &copy)              = delete;
  Participant &operator=(const Participant &assign) = delete;

  // --- steering
  // Sends the meshes and initial data, and receives the first window's data.
  void initialize();
  // Advances by the step just computed; a step that ends the time window exchanges the data.
  void advance(double computedTimeStepSize);
  // Ends the coupling (once isCouplingOngoing() is false) and closes the connection.
  void finalize();

  // --- implicit coupling
  // True when an implicit window starts: save the solver's state.
  bool requiresWritingCheckpoint();
  // True after an advance that ended a window whose iterations go on: restore the state saved.
  bool requiresReadingCheckpoint();

  // --- status
  int    getMeshDimensions(::precice::string_view meshName) const;
  int    getDataDimensions(::precice::string_view meshName, ::precice::string_view dataName) const;
  bool   isCouplingOngoing() const;
  bool   isTimeWindowComplete() const;
  // What is left of the current time window.
  double getMaxTimeStepSize() const;

  // --- meshes
  bool     requiresMeshConnectivityFor(::precice::string_view meshName) const;
  // Refused: cosim keeps a mesh's vertices of initialize for the whole run.
  void     resetMesh(::precice::string_view meshName);
  VertexID setMeshVertex(::precice::string_view meshName, ::precice::span<const double> position);
  int      getMeshVertexSize(::precice::string_view meshName) const;
  void     setMeshVertices(::precice::string_view meshName, ::precice::span<const double> coordinates,
                           ::precice::span<VertexID> ids);
  void     setMeshEdge(::precice::string_view meshName, VertexID first, VertexID second);
  void     setMeshEdges(::precice::string_view meshName, ::precice::span<const VertexID> ids);
  void     setMeshTriangle(::precice::string_view meshName, VertexID first, VertexID second, VertexID third);
  void     setMeshTriangles(::precice::string_view meshName, ::precice::span<const VertexID> ids);
  void     setMeshQuad(::precice::string_view meshName, VertexID first, VertexID second, VertexID third,
                       VertexID fourth);
  void     setMeshQuads(::precice::string_view meshName, ::precice::span<const VertexID> ids);
  void     setMeshTetrahedron(::precice::string_view meshName, VertexID first, VertexID second, VertexID third,
                              VertexID fourth);
  void     setMeshTetrahedra(::precice::string_view meshName, ::precice::span<const VertexID> ids);

  // --- data
  // True when an exchange this participant writes has initialize="true": write it before initialize().
  bool requiresInitialData();
  void writeData(::precice::string_view meshName, ::precice::string_view dataName,
                 ::precice::span<const VertexID> ids, ::precice::span<const double> values);
  // The data at relativeReadTime (0 to getMaxTimeStepSize()) into the step: its waveform inside the window.
  void readData(::precice::string_view meshName, ::precice::string_view dataName,
                ::precice::span<const VertexID> ids, double relativeReadTime, ::precice::span<double> values) const;

  // --- just-in-time mapping (nearest-neighbor, on a received mesh accessed directly)
  void writeAndMapData(::precice::string_view meshName, ::precice::string_view dataName,
                       ::precice::span<const double> coordinates, ::precice::span<const double> values);
  void mapAndReadData(::precice::string_view meshName, ::precice::string_view dataName,
                      ::precice::span<const double> coordinates, double relativeReadTime,
                      ::precice::span<double> values) const;

  // --- direct access to a received mesh
  void setMeshAccessRegion(::precice::string_view meshName, ::precice::span<const double> boundingBox) const;
  void getMeshVertexIDsAndCoordinates(::precice::string_view meshName, ::precice::span<VertexID> ids,
                                      ::precice::span<double> coordinates) const;

  // --- gradient data (experimental in preCICE: <precice-configuration experimental="true">)
  bool requiresGradientDataFor(::precice::string_view meshName, ::precice::string_view dataName) const;
  void writeGradientData(::precice::string_view meshName, ::precice::string_view dataName,
                         ::precice::span<const VertexID> ids, ::precice::span<const double> gradients);

  // --- profiling: accepted (cosim times every call itself)
  void startProfilingSection(::precice::string_view sectionName);
  void stopLastProfilingSection();

private:
  std::unique_ptr<impl::Core> _impl;
};

} // namespace precice
