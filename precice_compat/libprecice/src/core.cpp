#include "core.hpp"

#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <iostream>
#include <set>

#include "precice/Exceptions.hpp"

namespace precice {
namespace impl {

namespace {

const double EPSILON = 1e-9;     // relative tolerance of times: a step that reaches the window's end to this ends it

using cosim::OutArray;
using cosim::Value;

std::string shown(double value)
{
  char text[64];
  std::snprintf(text, sizeof(text), "%g", value);
  return text;
}

// a and b as short as they read apart (%g, or every digit where %g shows them equal)
std::pair<std::string, std::string> distinct(double a, double b)
{
  std::pair<std::string, std::string> brief(shown(a), shown(b));
  if (brief.first != brief.second || a == b) return brief;
  char first[64], second[64];
  std::snprintf(first, sizeof(first), "%.17g", a);
  std::snprintf(second, sizeof(second), "%.17g", b);
  return {first, second};
}

double process_seconds()
{
  timespec now;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) + 1e-9 * static_cast<double>(now.tv_nsec);
}

std::string absolute(const std::string &path)
{
  char resolved[PATH_MAX];
  if (realpath(path.c_str(), resolved)) return resolved;
  if (!path.empty() && path[0] == '/') return path;
  char here[PATH_MAX];
  return std::string(getcwd(here, sizeof(here)) ? here : ".") + "/" + path;
}

bool is_file(const std::string &path)
{
  FILE *stream = std::fopen(path.c_str(), "r");
  if (!stream) return false;
  std::fclose(stream);
  return true;
}

std::vector<std::string> strings(const Value *list)
{
  std::vector<std::string> out;
  if (list && list->kind == Value::List)
    for (const Value &item : list->items) out.push_back(item.string());
  return out;
}

bool contains(const std::vector<std::string> &names, const std::string &name)
{
  return std::find(names.begin(), names.end(), name) != names.end();
}

// rows of `width` ids: each sorted, then the rows sorted and each kept once (as numpy's unique(sort(., 1), axis=0))
std::vector<std::int64_t> unique_rows(const std::vector<std::int64_t> &flat, std::size_t width)
{
  std::vector<std::vector<std::int64_t>> rows(flat.size() / width);
  for (std::size_t r = 0; r < rows.size(); ++r) {
    rows[r].assign(flat.begin() + r * width, flat.begin() + (r + 1) * width);
    std::sort(rows[r].begin(), rows[r].end());
  }
  std::sort(rows.begin(), rows.end());
  rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
  std::vector<std::int64_t> out;
  out.reserve(rows.size() * width);
  for (const auto &row : rows) out.insert(out.end(), row.begin(), row.end());
  return out;
}

std::size_t width_of(const std::string &kind) { return kind == "edges" ? 2 : kind == "triangles" ? 3 : 4; }

} // namespace

// --- the waveform: de Boor's algorithm, in the arithmetic order of the Python participant's -----------------------
void Waveform::evaluate(double x, std::vector<double> &out) const
{
  const std::size_t n = rows;
  const int         k = static_cast<int>(knots.size()) - static_cast<int>(n) - 1;
  long span = static_cast<long>(std::upper_bound(knots.begin(), knots.end(), x) - knots.begin()) - 1;
  span      = std::min(std::max(span, static_cast<long>(k)), static_cast<long>(n) - 1);   // x = 1: the last span
  std::vector<std::vector<double>> d(k + 1);
  for (int j = 0; j <= k; ++j) {
    const double *row = coefficients.data() + (span - k + j) * width;
    d[j].assign(row, row + width);
  }
  for (int r = 1; r <= k; ++r) {
    for (int j = k; j >= r; --j) {
      const double left = knots[span - k + j], right = knots[span + 1 + j - r];
      const double alpha = (x - left) / (right - left);
      for (std::size_t i = 0; i < width; ++i) d[j][i] = (1.0 - alpha) * d[j - 1][i] + alpha * d[j][i];
    }
  }
  out.swap(d[k]);
}

// --- construction ---------------------------------------------------------------------------------------------------
Core::Core(const std::string &name, const std::string &config, int rank, int size, const std::string &api)
    : name_(name), config_(absolute(config)), rank_(rank), size_(size)
{
  const std::string call = api;
  try {
    connection_.reset(new cosim::Connection(cosim::find_coupler(config_)));
  } catch (const cosim::Failure &failure) {
    throw ::precice::Error(call + ": " + failure.what());
  }
  if (name.empty()) fail(call, "the participant's name must be a non-empty string");
  if (size < 1 || rank < 0 || rank >= size)
    fail(call, "rank " + std::to_string(rank) + " of size " + std::to_string(size) + ": the rank goes from 0 to size - 1");
  if (!is_file(config_)) fail(call, "the configuration '" + config + "' does not exist");
  Value hello = Value::map();
  hello.set("participant", Value::of(name));
  hello.set("config", Value::of(config_));
  hello.set("api", Value::of("C++/C/Fortran (cosim's libprecice)"));
  hello.set("pid", Value::of(static_cast<long long>(getpid())));
  hello.set("rank", Value::of(rank));
  hello.set("size", Value::of(size));
  Value setup;
  try {
    setup = connection_->request("hello", hello).first;
  } catch (const cosim::Failure &failure) {
    throw ::precice::Error(call + ": " + failure.what());
  }
  const Value *meshes = setup.get("meshes");
  if (meshes && meshes->kind == Value::Map) {
    for (const auto &entry : meshes->entries) {
      MeshState state;
      state.info.dimensions    = static_cast<int>(entry.second.whole_of("dimensions", 2));
      state.info.provided      = entry.second.flag_of("provided");
      state.info.connectivity  = entry.second.flag_of("connectivity");
      state.info.direct_access = entry.second.flag_of("direct_access");
      state.info.from          = entry.second.string_of("from");
      state.info.data          = strings(entry.second.get("data"));
      state.info.just_in_time  = strings(entry.second.get("just_in_time"));
      meshes_[entry.first]     = state;
    }
  }
  for (int pass = 0; pass < 2; ++pass) {
    const Value *list = setup.get(pass == 0 ? "write" : "read");
    if (!list || list->kind != Value::List) continue;
    for (const Value &item : list->items) {
      DataSpec spec;
      spec.mesh       = item.string_of("mesh");
      spec.data       = item.string_of("data");
      spec.dimensions = static_cast<int>(item.whole_of("dimensions", 1));
      spec.substeps   = item.flag_of("substeps");
      spec.gradient   = item.flag_of("gradient");
      spec.degree     = static_cast<int>(item.whole_of("degree", 0));
      (pass == 0 ? write_ : read_).push_back(spec);
      if (pass == 0 && spec.substeps) substep_data_.push_back(spec.data);
    }
  }
  std::sort(substep_data_.begin(), substep_data_.end());
  initial_      = strings(setup.get("initial"));
  implicit_     = setup.flag_of("implicit");
  experimental_ = setup.flag_of("experimental");
  window_       = setup.number_of("window");
  window_start_ = setup.number_of("start");
  const Value *exports = setup.get("exports");
  if (exports && exports->truthy() && rank_ == 0)
    std::cerr << "cosim: participant '" << name_ << "': cosim's libprecice writes no <export:...> files; the run's "
              << "results.h5 and run.xdmf hold its meshes and data" << std::endl;
  computing_since_ = std::chrono::steady_clock::now();
  cpu_since_       = process_seconds();
}

Core::~Core() { release(); }

void Core::fail(const std::string &call, const std::string &why)
{
  std::string message = call + ": " + why;
  if (connection_) {
    Value args = Value::map();
    args.set("message", Value::of(message));
    args.set("participant", Value::of(name_));
    connection_->tell("error", args);
  }
  throw ::precice::Error(message);
}

// --- meshes ---------------------------------------------------------------------------------------------------------
const MeshInfo &Core::mesh(const std::string &call, const std::string &mesh, bool provided)
{
  auto found = meshes_.find(mesh);
  if (found == meshes_.end()) {
    std::string known;
    for (const auto &entry : meshes_) known += (known.empty() ? "" : ", ") + entry.first;
    fail(call, "participant '" + name_ + "' uses no mesh '" + mesh + "' (its meshes: " + (known.empty() ? "none" : known) + ")");
  }
  if (provided && !found->second.info.provided)
    fail(call, "mesh '" + mesh + "' is received from another participant, not provided by '" + name_ + "'");
  return found->second.info;
}

int Core::mesh_dimensions(const std::string &call, const std::string &mesh_name) { return mesh(call, mesh_name).dimensions; }

bool Core::requires_connectivity(const std::string &call, const std::string &mesh_name)
{
  return mesh(call, mesh_name).connectivity;
}

int Core::add_vertices(const std::string &call, const std::string &mesh_name, const double *positions,
                       std::size_t values, int *ids)
{
  const MeshInfo &info = mesh(call, mesh_name, true);
  if (state_ != State::Constructed) fail(call, "vertices are set before initialize, not after");
  const std::size_t dimensions = static_cast<std::size_t>(info.dimensions);
  if (values % dimensions)
    fail(call, std::to_string(values) + " coordinates on mesh '" + mesh_name + "' of " + std::to_string(dimensions) +
                   " dimensions; expected " + std::to_string(dimensions) + " per vertex");
  for (std::size_t i = 0; i < values; ++i)
    if (!std::isfinite(positions[i])) fail(call, "positions on mesh '" + mesh_name + "' are not finite");
  MeshState  &state = meshes_[mesh_name];
  std::size_t first = state.count;
  state.coordinates.insert(state.coordinates.end(), positions, positions + values);
  state.count += values / dimensions;
  if (ids)
    for (std::size_t i = 0; i < values / dimensions; ++i) ids[i] = static_cast<int>(first + i);
  return static_cast<int>(first);
}

void Core::connect(const std::string &call, const std::string &mesh_name, const int *ids, std::size_t count,
                   int per_element, bool quad)
{
  mesh(call, mesh_name, true);
  if (state_ != State::Constructed) fail(call, "connectivity is set before initialize, not after");
  if (count % per_element)
    fail(call, std::to_string(count) + " vertex ids do not make elements of " + std::to_string(per_element));
  std::vector<std::int64_t> rows = checked_ids(call, mesh_name, ids, count);
  const std::size_t         width = static_cast<std::size_t>(per_element);
  for (std::size_t r = 0; r < rows.size() / width; ++r) {
    std::vector<std::int64_t> row(rows.begin() + r * width, rows.begin() + (r + 1) * width);
    std::sort(row.begin(), row.end());
    if (std::adjacent_find(row.begin(), row.end()) != row.end()) fail(call, "an element repeats a vertex");
  }
  auto &kinds = meshes_[mesh_name].elements;
  auto  add   = [&](const std::string &kind, const std::vector<int> &pattern) {
    std::vector<std::int64_t> &out = kinds[kind];
    for (std::size_t r = 0; r < rows.size() / width; ++r)
      for (int column : pattern) out.push_back(rows[r * width + column]);
  };
  if (quad) {
    add("edges", {0, 1, 1, 2, 2, 3, 3, 0});
    add("triangles", {0, 1, 2, 0, 2, 3});
    return;
  }
  std::vector<int> pairs;
  for (int i = 0; i < per_element; ++i)
    for (int j = i + 1; j < per_element; ++j) {
      pairs.push_back(i);
      pairs.push_back(j);
    }
  add("edges", pairs);
  if (per_element == 3) add("triangles", {0, 1, 2});
  if (per_element == 4) add("tetrahedra", {0, 1, 2, 3});
}

std::size_t Core::vertex_count(const std::string &mesh_name) const
{
  const MeshState &state = meshes_.at(mesh_name);
  return state.info.provided ? state.count : state.received_count;
}

int Core::mesh_vertex_size(const std::string &call, const std::string &mesh_name)
{
  const MeshInfo &info = mesh(call, mesh_name);
  if (!info.provided) {      // a received mesh: its vertices in the access region, once initialized
    if (state_ != State::Initialized || !meshes_[mesh_name].has_region) return 0;
    return static_cast<int>(region_vertices(call, mesh_name, nullptr, nullptr, 0, false));
  }
  return static_cast<int>(vertex_count(mesh_name));
}

void Core::reset_mesh(const std::string &call, const std::string &mesh_name)
{
  mesh(call, mesh_name);
  fail(call, "remeshing is not supported by cosim: mesh '" + mesh_name + "' keeps the vertices it had at initialize "
             "for the whole run");
}

// --- direct access to a received mesh -------------------------------------------------------------------------------
MeshState &Core::direct(const std::string &call, const std::string &mesh_name)
{
  const MeshInfo &info = mesh(call, mesh_name);
  if (info.provided || !info.direct_access)
    fail(call, "mesh '" + mesh_name + "' is not a received mesh with direct access (give its <receive-mesh> "
               "api-access=\"true\")");
  if (size_ > 1)
    fail(call, "direct access from a parallel participant (" + std::to_string(size_) + " ranks) is not supported by cosim");
  return meshes_[mesh_name];
}

void Core::set_access_region(const std::string &call, const std::string &mesh_name, const double *box, std::size_t n)
{
  MeshState &state = direct(call, mesh_name);
  if (state_ != State::Constructed) fail(call, "the access region is set before initialize");
  const std::size_t dimensions = static_cast<std::size_t>(state.info.dimensions);
  bool              finite     = true;
  for (std::size_t i = 0; i < n; ++i) finite = finite && std::isfinite(box[i]);
  if (n != 2 * dimensions || !finite)
    fail(call, "the bounding box has " + std::to_string(n) + " values; expected " + std::to_string(2 * dimensions) +
                   " finite ones (min and max of each coordinate)");
  for (std::size_t d = 0; d < dimensions; ++d)
    if (box[2 * d] > box[2 * d + 1]) fail(call, "the bounding box has a minimum above its maximum");
  state.region.assign(box, box + n);
  state.has_region = true;
}

std::size_t Core::region_vertices(const std::string &call, const std::string &mesh_name, int *ids, double *coordinates,
                                  std::size_t capacity, bool check_capacity)
{
  MeshState &state = direct(call, mesh_name);
  if (state_ != State::Initialized) fail(call, "a received mesh's vertices are known after initialize");
  if (!state.has_region)
    fail(call, "no access region is set on mesh '" + mesh_name + "' (set the access region before initialize)");
  const std::size_t   dimensions = static_cast<std::size_t>(state.info.dimensions);
  std::vector<std::size_t> inside;
  for (std::size_t v = 0; v < state.received_count; ++v) {
    bool in = true;
    for (std::size_t d = 0; d < dimensions && in; ++d) {
      const double x = state.received[v * dimensions + d];
      in             = x >= state.region[2 * d] && x <= state.region[2 * d + 1];
    }
    if (in) inside.push_back(v);
  }
  if (check_capacity && capacity != inside.size())
    fail(call, "ids for " + std::to_string(capacity) + " vertices, where the access region of mesh '" + mesh_name +
                   "' holds " + std::to_string(inside.size()) + " (getMeshVertexSize)");
  for (std::size_t i = 0; ids && i < inside.size(); ++i) {
    ids[i] = static_cast<int>(inside[i]);
    if (coordinates)
      for (std::size_t d = 0; d < dimensions; ++d) coordinates[i * dimensions + d] = state.received[inside[i] * dimensions + d];
  }
  return inside.size();
}

std::vector<std::int64_t> Core::just_in_time(const std::string &call, const std::string &mesh_name,
                                             const std::string &direction, const double *coordinates, std::size_t size)
{
  MeshState &state = direct(call, mesh_name);
  if (!contains(state.info.just_in_time, direction))
    fail(call, "no just-in-time " + direction + " mapping is configured on mesh '" + mesh_name +
                   "' (a <mapping:nearest-neighbor direction=\"" + direction + "\"> with " +
                   (direction == "read" ? "from" : "to") + "=\"" + mesh_name + "\" alone)");
  const std::size_t dimensions = static_cast<std::size_t>(state.info.dimensions);
  bool              finite     = true;
  for (std::size_t i = 0; i < size; ++i) finite = finite && std::isfinite(coordinates[i]);
  if (size % dimensions || !finite)
    fail(call, std::to_string(size) + " coordinates on mesh '" + mesh_name + "' of " + std::to_string(dimensions) +
                   " dimensions; expected finite ones, " + std::to_string(dimensions) + " per point");
  std::vector<int> ids(state.received_count);
  std::size_t      inside = region_vertices(call, mesh_name, ids.data(), nullptr, 0, false);
  if (!inside) fail(call, "the access region of mesh '" + mesh_name + "' holds no vertex to map to");
  std::vector<std::int64_t> nearest(size / dimensions);
  for (std::size_t p = 0; p < nearest.size(); ++p) {
    double best = INFINITY;
    for (std::size_t v = 0; v < inside; ++v) {
      double distance = 0.0;
      for (std::size_t d = 0; d < dimensions; ++d) {
        const double delta = coordinates[p * dimensions + d] - state.received[ids[v] * dimensions + d];
        distance += delta * delta;
      }
      if (distance < best) {
        best       = distance;
        nearest[p] = ids[v];
      }
    }
  }
  return nearest;
}

void Core::map_and_read(const std::string &call, const std::string &mesh_name, const std::string &data,
                        const double *coordinates, std::size_t coordinates_size, double relative_read_time,
                        double *values, std::size_t values_size)
{
  std::vector<std::int64_t> nearest = just_in_time(call, mesh_name, "read", coordinates, coordinates_size);
  std::vector<int>          ids(nearest.begin(), nearest.end());
  read_values(call, mesh_name, data, ids.data(), ids.size(), relative_read_time, values, values_size);
}

void Core::write_and_map(const std::string &call, const std::string &mesh_name, const std::string &data,
                         const double *coordinates, std::size_t coordinates_size, const double *values,
                         std::size_t values_size)
{
  std::vector<std::int64_t> nearest = just_in_time(call, mesh_name, "write", coordinates, coordinates_size);
  const DataSpec           *spec    = write_spec(mesh_name, data);
  if (!spec) fail(call, "participant '" + name_ + "' writes no data '" + data + "' on mesh '" + mesh_name + "'");
  const std::size_t width = static_cast<std::size_t>(spec->dimensions);
  bool              finite = true;
  for (std::size_t i = 0; i < values_size; ++i) finite = finite && std::isfinite(values[i]);
  if (values_size != nearest.size() * width || !finite)
    fail(call, std::to_string(values_size) + " values for " + std::to_string(nearest.size()) + " points; expected " +
                   std::to_string(nearest.size() * width) + " finite ones");
  std::vector<double> &target = buffer(*spec);
  if (!contains(accumulated_, data)) {
    std::fill(target.begin(), target.end(), 0.0);
    accumulated_.push_back(data);
  }
  for (std::size_t p = 0; p < nearest.size(); ++p)
    for (std::size_t c = 0; c < width; ++c) target[nearest[p] * width + c] += values[p * width + c];
}

// --- data -----------------------------------------------------------------------------------------------------------
const DataSpec *Core::write_spec(const std::string &mesh_name, const std::string &data) const
{
  for (const DataSpec &spec : write_)
    if (spec.mesh == mesh_name && spec.data == data) return &spec;
  return nullptr;
}

const DataSpec *Core::read_spec(const std::string &mesh_name, const std::string &data) const
{
  for (const DataSpec &spec : read_)
    if (spec.mesh == mesh_name && spec.data == data) return &spec;
  return nullptr;
}

int Core::data_dimensions(const std::string &call, const std::string &mesh_name, const std::string &data)
{
  mesh(call, mesh_name);
  const DataSpec *spec = write_spec(mesh_name, data);
  if (!spec) spec = read_spec(mesh_name, data);
  if (!spec) {
    std::string uses;
    for (const DataSpec &s : write_) uses += (uses.empty() ? "" : ", ") + s.data + " on " + s.mesh;
    for (const DataSpec &s : read_) uses += (uses.empty() ? "" : ", ") + s.data + " on " + s.mesh;
    fail(call, "participant '" + name_ + "' uses no data '" + data + "' on mesh '" + mesh_name + "' (it uses: " +
                   (uses.empty() ? "none" : uses) + ")");
  }
  return spec->dimensions;
}

std::vector<std::int64_t> Core::checked_ids(const std::string &call, const std::string &mesh_name, const int *ids,
                                            std::size_t count)
{
  const std::size_t         vertices = vertex_count(mesh_name);
  std::vector<std::int64_t> out(ids, ids + count);
  for (std::int64_t id : out)
    if (id < 0 || static_cast<std::size_t>(id) >= vertices)
      fail(call, "vertex id " + std::to_string(id) + " is not on mesh '" + mesh_name + "' (" + std::to_string(vertices) +
                     " vertices: ids 0 to " + std::to_string(static_cast<long long>(vertices) - 1) + ")");
  return out;
}

std::vector<double> &Core::buffer(const DataSpec &spec)
{
  std::vector<double> &values = written_[spec.data];
  const std::size_t    size   = vertex_count(spec.mesh) * static_cast<std::size_t>(spec.dimensions);
  if (values.size() != size) values.assign(size, 0.0);
  return values;
}

void Core::write_values(const std::string &call, const std::string &mesh_name, const std::string &data, const int *ids,
                        std::size_t count, const double *values, std::size_t values_size)
{
  const MeshInfo &info = mesh(call, mesh_name);
  const DataSpec *spec = write_spec(mesh_name, data);
  if (!spec) {
    std::string writes;
    for (const DataSpec &s : write_) writes += (writes.empty() ? "" : ", ") + s.data + " on " + s.mesh;
    fail(call, "participant '" + name_ + "' writes no data '" + data + "' on mesh '" + mesh_name + "' (it writes: " +
                   (writes.empty() ? "none" : writes) + ")");
  }
  if (state_ == State::Constructed && !info.provided)
    fail(call, "data on the received mesh '" + mesh_name + "' is written after initialize (its vertices come with it)");
  if (state_ == State::Constructed && !contains(initial_, data))
    fail(call, "'" + data + "' is written before initialize only as initial data, and the exchange of '" + data +
                   "' has no initialize=\"true\"");
  if (state_ == State::Finalized) fail(call, "the participant was finalized");
  std::vector<std::int64_t> vertex_ids = checked_ids(call, mesh_name, ids, count);
  const std::size_t         width      = static_cast<std::size_t>(spec->dimensions);
  if (values_size != count * width)
    fail(call, std::to_string(values_size) + " values for " + std::to_string(count) + " vertices of " +
                   (width == 1 ? "scalar" : "vector") + " data '" + data + "'; expected " +
                   std::to_string(count * width) + (width == 1 ? "" : " (" + std::to_string(width) + " per vertex)"));
  for (std::size_t i = 0; i < values_size; ++i)
    if (!std::isfinite(values[i])) fail(call, "values of '" + data + "' are not finite");
  std::vector<double> &target = buffer(*spec);
  for (std::size_t i = 0; i < count; ++i)
    for (std::size_t c = 0; c < width; ++c) target[vertex_ids[i] * width + c] = values[i * width + c];
}

bool Core::requires_gradient(const std::string &call, const std::string &mesh_name, const std::string &data)
{
  mesh(call, mesh_name);
  const DataSpec *spec = write_spec(mesh_name, data);
  return spec && spec->gradient;
}

void Core::write_gradients(const std::string &call, const std::string &mesh_name, const std::string &data,
                           const int *ids, std::size_t count, const double *gradients, std::size_t size)
{
  if (!experimental_)
    fail(call, "gradient data is preCICE's experimental API: unlock it with <precice-configuration "
               "experimental=\"true\"> in the configuration");
  const MeshInfo &info = mesh(call, mesh_name);
  const DataSpec *spec = write_spec(mesh_name, data);
  if (!spec || !spec->gradient)
    fail(call, "'" + data + "' on mesh '" + mesh_name + "' takes no gradients: no nearest-neighbor-gradient mapping "
               "maps it (requiresGradientDataFor is false)");
  if (state_ == State::Finalized) fail(call, "the participant was finalized");
  std::vector<std::int64_t> vertex_ids = checked_ids(call, mesh_name, ids, count);
  const std::size_t         columns    = static_cast<std::size_t>(info.dimensions * spec->dimensions);
  if (size != count * columns)
    fail(call, std::to_string(size) + " gradient values for " + std::to_string(count) + " vertices of '" + data +
                   "'; expected " + std::to_string(count * columns) + ": each component's d/dx, d/dy...");
  for (std::size_t i = 0; i < size; ++i)
    if (!std::isfinite(gradients[i])) fail(call, "gradients of '" + data + "' are not finite");
  std::vector<double> &target = gradients_[data];
  if (target.size() != vertex_count(mesh_name) * columns) target.assign(vertex_count(mesh_name) * columns, 0.0);
  for (std::size_t i = 0; i < count; ++i)
    for (std::size_t c = 0; c < columns; ++c) target[vertex_ids[i] * columns + c] = gradients[i * columns + c];
}

void Core::read_values(const std::string &call, const std::string &mesh_name, const std::string &data, const int *ids,
                       std::size_t count, double relative_read_time, double *values, std::size_t values_size)
{
  mesh(call, mesh_name);
  const DataSpec *spec = read_spec(mesh_name, data);
  if (!spec) {
    std::string reads;
    for (const DataSpec &s : read_) reads += (reads.empty() ? "" : ", ") + s.data + " on " + s.mesh;
    fail(call, "participant '" + name_ + "' reads no data '" + data + "' on mesh '" + mesh_name + "' (it reads: " +
                   (reads.empty() ? "none" : reads) + ")");
  }
  if (state_ != State::Initialized)
    fail(call, state_ == State::Constructed ? "data is read after initialize" : "the participant was finalized");
  std::vector<std::int64_t> vertex_ids = checked_ids(call, mesh_name, ids, count);
  const std::size_t         width      = static_cast<std::size_t>(spec->dimensions);
  if (values_size != count * width)
    fail(call, "room for " + std::to_string(values_size) + " values for " + std::to_string(count) + " vertices of " +
                   (width == 1 ? "scalar" : "vector") + " data '" + data + "'; expected " + std::to_string(count * width));
  const double left = remaining();
  if (!std::isfinite(relative_read_time) || relative_read_time < 0 ||
      relative_read_time > left * (1 + EPSILON) + EPSILON * window_) {
    std::pair<std::string, std::string> text = distinct(relative_read_time, left);
    fail(call, "relativeReadTime " + text.first + " is outside the step (0 to " + text.second +
                   ", what is left of the window)");
  }
  const double moment = (elapsed_ + relative_read_time) / window_;
  auto         found  = waveforms_.find(data);
  if (found != waveforms_.end() && moment < 1.0 - EPSILON) {
    std::vector<double> at;
    found->second.evaluate(moment, at);
    for (std::size_t i = 0; i < count; ++i)
      for (std::size_t c = 0; c < width; ++c) values[i * width + c] = at[vertex_ids[i] * width + c];
    return;
  }
  auto given = received_.find(data);
  for (std::size_t i = 0; i < count; ++i)
    for (std::size_t c = 0; c < width; ++c)
      values[i * width + c] = given == received_.end() ? 0.0 : given->second[vertex_ids[i] * width + c];
}

// --- time and the coupling ------------------------------------------------------------------------------------------
double Core::remaining() const { return std::max(window_ - elapsed_, 0.0); }

void Core::gradient_arrays(std::vector<OutArray> &arrays)
{
  for (const DataSpec &spec : write_) {
    auto found = gradients_.find(spec.data);
    if (found == gradients_.end()) continue;
    const std::size_t vertices = vertex_count(spec.mesh);
    if (!vertices || found->second.size() % vertices) continue;
    arrays.push_back(OutArray::of("gradient:" + spec.data, found->second, {vertices, found->second.size() / vertices}));
  }
}

void Core::initialize(const std::string &call)
{
  if (state_ != State::Constructed)
    fail(call, state_ == State::Initialized ? "initialize is called once" : "the participant was finalized");
  for (const auto &entry : meshes_)
    if (entry.second.info.provided && !entry.second.count)
      fail(call, "mesh '" + entry.first + "' has no vertices: set them before initialize");
  std::vector<OutArray>                         arrays;
  std::vector<std::unique_ptr<std::vector<std::int64_t>>> rows;     // the element arrays' storage until the send
  for (const auto &entry : meshes_) {
    const MeshState &state = entry.second;
    if (state.info.provided)
      arrays.push_back(OutArray::of("mesh:" + entry.first, state.coordinates,
                                    {state.count, static_cast<std::size_t>(state.info.dimensions)}));
  }
  for (const auto &entry : meshes_) {
    for (const auto &kind : entry.second.elements) {
      const std::size_t width = width_of(kind.first);
      rows.emplace_back(new std::vector<std::int64_t>(unique_rows(kind.second, width)));
      arrays.push_back(OutArray::of(kind.first + ":" + entry.first, *rows.back(), {rows.back()->size() / width, width}));
    }
  }
  for (const DataSpec &spec : write_) {
    if (!contains(initial_, spec.data)) continue;
    std::vector<double> &values = buffer(spec);
    arrays.push_back(spec.dimensions == 1
                         ? OutArray::of("data:" + spec.data, values, {vertex_count(spec.mesh)})
                         : OutArray::of("data:" + spec.data, values,
                                        {vertex_count(spec.mesh), static_cast<std::size_t>(spec.dimensions)}));
  }
  gradient_arrays(arrays);
  state_ = State::Initialized;
  exchange("initialize", Value::map(), arrays);
}

void Core::exchange(const std::string &op, Value args, const std::vector<OutArray> &arrays)
{
  std::pair<Value, std::map<std::string, cosim::Array>> reply;
  try {
    reply = connection_->request(op, std::move(args), arrays);
  } catch (const cosim::Failure &failure) {
    throw ::precice::Error(failure.what());
  }
  Value                                  &result   = reply.first;
  std::map<std::string, cosim::Array>   &received = reply.second;
  std::map<std::string, std::vector<double>> data;
  for (const auto &entry : received) {
    const std::string &key = entry.first;
    if (key.compare(0, 5, "mesh:") == 0) {     // a received mesh this participant accesses directly
      MeshState &state    = meshes_[key.substr(5)];
      state.received      = entry.second.doubles();
      state.received_count = entry.second.shape.empty() ? 0 : entry.second.shape[0];
    } else if (key.compare(0, 5, "data:") == 0) {
      data[key.substr(5)] = entry.second.doubles();
    }
  }
  const bool going = result.flag_of("ongoing");
  waveforms_.clear();
  if (!data.empty() || going) {
    received_ = data;
    const Value *knots = result.get("knots");
    if (knots && knots->kind == Value::Map) {
      for (const auto &entry : knots->entries) {
        auto coefficients = received.find("coefficients:" + entry.first);
        if (coefficients == received.end()) continue;
        Waveform waveform;
        for (const Value &knot : entry.second.items) waveform.knots.push_back(knot.number());
        waveform.coefficients = coefficients->second.doubles();
        waveform.rows         = coefficients->second.shape.empty() ? 0 : coefficients->second.shape[0];
        waveform.width        = waveform.rows ? waveform.coefficients.size() / waveform.rows : 0;
        waveforms_[entry.first] = waveform;
      }
    }
    for (const std::string &name : strings(result.get("lines"))) {   // the line from the window's start to its end
      auto start = received.find("start:" + name);
      if (start != received.end()) starts_[name] = start->second.doubles();
      const std::vector<double> &end = received_[name];
      const std::vector<double> &from = starts_.count(name) ? starts_[name] : end;
      Waveform                   line;
      line.knots = {0.0, 0.0, 1.0, 1.0};
      line.rows  = 2;
      line.width = end.size();
      line.coefficients = from;
      line.coefficients.insert(line.coefficients.end(), end.begin(), end.end());
      waveforms_[name] = line;
    }
  }       // else the end: reads give the last window's end values, as preCICE's do
  sample_times_.clear();
  samples_.clear();
  ongoing_          = going;
  window_complete_  = result.flag_of("window_complete");
  write_checkpoint_ = result.flag_of("write_checkpoint");
  read_checkpoint_  = result.flag_of("read_checkpoint");
  asked_write_ = asked_read_ = false;
  window_start_     = result.number_of("window_start", window_start_);
  window_           = result.number_of("window", window_);
  elapsed_          = 0.0;
  computing_since_  = std::chrono::steady_clock::now();
  cpu_since_        = process_seconds();
}

void Core::advance(const std::string &call, double dt)
{
  if (state_ != State::Initialized)
    fail(call, state_ == State::Constructed ? "advance before initialize" : "the participant was finalized");
  if (!ongoing_) fail(call, "the coupling is over (isCouplingOngoing() is false): call finalize");
  const double left = remaining();
  if (!std::isfinite(dt) || dt <= 0) fail(call, "the step " + shown(dt) + " must be positive");
  if (dt > left * (1 + EPSILON) + EPSILON * window_) {
    std::pair<std::string, std::string> text = distinct(dt, left);
    fail(call, "the step " + text.first + " is longer than what is left of the window, " + text.second +
                   " (getMaxTimeStepSize())");
  }
  // as preCICE: an implicit coupling's checkpoint is asked for before the window goes on
  if (write_checkpoint_ && !asked_write_)
    fail(call, "the iteration checkpoint was not written: the implicit coupling asks for one here, and "
               "requiresWritingCheckpoint() was not called since the last advance");
  if (read_checkpoint_ && !asked_read_)
    fail(call, "the iteration checkpoint was not read: the implicit coupling asks for one here, and "
               "requiresReadingCheckpoint() was not called since the last advance");
  elapsed_ += dt;
  write_checkpoint_ = read_checkpoint_ = window_complete_ = false;
  if (remaining() > EPSILON * window_) {
    if (!substep_data_.empty()) {      // a step inside the window: its data is a sample, sent with the window's end
      sample_times_.push_back(elapsed_ / window_);
      for (const DataSpec &spec : write_) {
        if (!contains(substep_data_, spec.data)) continue;
        std::vector<double> &values = buffer(spec);
        std::vector<double> &stack  = samples_[spec.data];
        stack.insert(stack.end(), values.begin(), values.end());
      }
    }
    return;
  }
  std::vector<OutArray> arrays;
  for (const DataSpec &spec : write_) {
    std::vector<double> &values   = buffer(spec);
    const std::size_t    vertices = vertex_count(spec.mesh);
    arrays.push_back(spec.dimensions == 1
                         ? OutArray::of("data:" + spec.data, values, {vertices})
                         : OutArray::of("data:" + spec.data, values, {vertices, static_cast<std::size_t>(spec.dimensions)}));
  }
  gradient_arrays(arrays);
  Value        args    = Value::map();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - computing_since_).count();
  args.set("compute_seconds", Value::of(seconds));
  args.set("cpu_seconds", Value::of(process_seconds() - cpu_since_));
  if (!sample_times_.empty()) {
    Value times = Value::list();
    for (double moment : sample_times_) times.push(Value::of(moment));
    args.set("times", times);
    for (const DataSpec &spec : write_) {
      auto stack = samples_.find(spec.data);
      if (stack == samples_.end()) continue;
      std::vector<std::size_t> shape = {sample_times_.size(), vertex_count(spec.mesh)};
      if (spec.dimensions > 1) shape.push_back(static_cast<std::size_t>(spec.dimensions));
      arrays.push_back(OutArray::of("substeps:" + spec.data, stack->second, shape));
    }
  }
  exchange("advance", args, arrays);
  for (const std::string &data : accumulated_) written_.erase(data);     // a just-in-time write gathers from zero
  accumulated_.clear();
}

void Core::finalize(const std::string &call)
{
  if (state_ == State::Finalized) return;
  if (state_ == State::Initialized && ongoing_)
    fail(call, "finalize while the coupling goes on: advance until isCouplingOngoing() is false");
  state_ = State::Finalized;
  try {
    connection_->request("finalize", Value::map());
  } catch (const cosim::Failure &failure) {
    connection_->close();
    throw ::precice::Error(call + ": " + failure.what());
  }
  connection_->close();
}

void Core::release()
{
  if (state_ == State::Finalized) return;
  try {
    if (state_ == State::Initialized && !ongoing_) {
      finalize("finalize");
    } else {
      state_ = State::Finalized;
      if (connection_) connection_->close();
    }
  } catch (...) {
  }
}

} // namespace impl
} // namespace precice
