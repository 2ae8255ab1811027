#pragma once
/* preCICE v3's C API, served by cosim's coupler: one participant per process, created by
 * precicec_createParticipant. Arrays are flat (coordinates and vector data interleaved per vertex), booleans are ints
 * (1 or 0). A misuse prints one line naming the call and why ("precice: error: ...") and ends the program with exit
 * code 2; the coupler's run stops with the same line. */

#include "precice/Version.h"
#include "precice/export.h"

#ifdef __cplusplus
extern "C" {
#endif

PRECICE_API void precicec_createParticipant(const char *participantName, const char *configFileName,
                                            int solverProcessIndex, int solverProcessSize);
/* the communicator is accepted and not used */
PRECICE_API void precicec_createParticipant_withCommunicator(const char *participantName, const char *configFileName,
                                                             int solverProcessIndex, int solverProcessSize,
                                                             void *communicator);

PRECICE_API void precicec_initialize(void);
PRECICE_API void precicec_advance(double computedTimeStepSize);
PRECICE_API void precicec_finalize(void);

PRECICE_API int precicec_requiresWritingCheckpoint(void);
PRECICE_API int precicec_requiresReadingCheckpoint(void);

PRECICE_API int    precicec_getMeshDimensions(const char *meshName);
PRECICE_API int    precicec_getDataDimensions(const char *meshName, const char *dataName);
PRECICE_API int    precicec_isCouplingOngoing(void);
PRECICE_API int    precicec_isTimeWindowComplete(void);
PRECICE_API double precicec_getMaxTimeStepSize(void);

PRECICE_API int  precicec_requiresMeshConnectivityFor(const char *meshName);
PRECICE_API void precicec_resetMesh(const char *meshName);
PRECICE_API int  precicec_setMeshVertex(const char *meshName, const double *coordinates);
PRECICE_API int  precicec_getMeshVertexSize(const char *meshName);
PRECICE_API void precicec_setMeshVertices(const char *meshName, int size, const double *coordinates, int *ids);
PRECICE_API void precicec_setMeshEdge(const char *meshName, int firstVertexID, int secondVertexID);
PRECICE_API void precicec_setMeshEdges(const char *meshName, int size, const int *ids);
PRECICE_API void precicec_setMeshTriangle(const char *meshName, int firstVertexID, int secondVertexID,
                                          int thirdVertexID);
PRECICE_API void precicec_setMeshTriangles(const char *meshName, int size, const int *ids);
PRECICE_API void precicec_setMeshQuad(const char *meshName, int firstVertexID, int secondVertexID, int thirdVertexID,
                                      int fourthVertexID);
PRECICE_API void precicec_setMeshQuads(const char *meshName, int size, const int *ids);
PRECICE_API void precicec_setMeshTetrahedron(const char *meshName, int firstVertexID, int secondVertexID,
                                             int thirdVertexID, int fourthVertexID);
PRECICE_API void precicec_setMeshTetrahedra(const char *meshName, int size, const int *ids);

PRECICE_API int  precicec_requiresInitialData(void);
PRECICE_API void precicec_writeData(const char *meshName, const char *dataName, int size, const int *valueIndices,
                                    const double *values);
PRECICE_API void precicec_readData(const char *meshName, const char *dataName, int size, const int *valueIndices,
                                   double relativeReadTime, double *values);

PRECICE_API void precicec_writeAndMapData(const char *meshName, const char *dataName, int size,
                                          const double *coordinates, const double *values);
PRECICE_API void precicec_mapAndReadData(const char *meshName, const char *dataName, int size,
                                         const double *coordinates, double relativeReadTime, double *values);

PRECICE_API void precicec_setMeshAccessRegion(const char *meshName, const double *boundingBox);
PRECICE_API void precicec_getMeshVertexIDsAndCoordinates(const char *meshName, const int size, int *ids,
                                                         double *coordinates);

PRECICE_API int  precicec_requiresGradientDataFor(const char *meshName, const char *dataName);
PRECICE_API void precicec_writeGradientData(const char *meshName, const char *dataName, int size,
                                            const int *valueIndices, const double *gradients);

PRECICE_API void precicec_startProfilingSection(const char *sectionName);
PRECICE_API void precicec_stopLastProfilingSection(void);

/* "3.4.1;served by cosim ...": the API version first */
PRECICE_API const char *precicec_getVersionInformation(void);

#ifdef __cplusplus
}
#endif
