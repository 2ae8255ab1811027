#pragma once
// preCICE v3's API types.

namespace precice {

// The id of a vertex on one mesh, as setMeshVertex/setMeshVertices give it (cosim: 0, 1, 2, ... in the order the
// vertices were set, per rank).
using VertexID = int;

} // namespace precice
