#pragma once
// What preCICE's C++, C and Fortran APIs do, against cosim's coupler: meshes, data buffers, time within a window,
// the checkpoint protocol. The same state machine as the Python participant's (precice/_core.py):
//
// The coupler drives a participant as it drives any component: a coupling iteration hands the participant its read
// data and takes its write data. Here that is the reply to the participant's initialize or window-ending advance (the
// read data, and whether the window is new, repeated, or the last), and the participant's next window-ending advance
// (its write data). Steps shorter than the window stay local. A read inside the window evaluates the data's waveform
// there: the window-end value (waveform-degree 0), else the B-spline the coupler sent through the window's samples.
// With substeps, the data written at each step inside the window is kept as a sample, and all go with the window's
// end.
//
// Every method takes `call`, the API's name of the call (Participant::writeData, precicec_writeData, ...), which its
// errors name.

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "connection.hpp"

namespace precice {
namespace impl {

struct MeshInfo {
  int                      dimensions = 0;
  bool                     provided = false, connectivity = false, direct_access = false;
  std::string              from;
  std::vector<std::string> data;             // the mesh's <use-data> order
  std::vector<std::string> just_in_time;     // "read" and/or "write": just-in-time mappings onto it
};

struct DataSpec {
  std::string mesh, data;
  int         dimensions = 1;
  bool        substeps = false, gradient = false;
  int         degree = 0;
};

// A read data item's B-spline across the window's normalised time [0, 1]: knots, and per basis function one row of
// coefficients (one value per vertex and component).
struct Waveform {
  std::vector<double> knots;
  std::vector<double> coefficients;     // rows x width
  std::size_t         rows = 0, width = 0;
  void                evaluate(double x, std::vector<double> &out) const;
};

struct MeshState {
  MeshInfo                                           info;
  std::vector<double>                                coordinates;   // provided: the vertices set, interleaved
  std::size_t                                        count = 0;
  std::map<std::string, std::vector<std::int64_t>>  elements;      // edges, triangles, tetrahedra: flat rows of ids
  std::vector<double>                                received;      // a received mesh accessed directly
  std::size_t                                        received_count = 0;
  bool                                               has_region = false;
  std::vector<double>                                region;        // (dimensions, 2): min and max
};

class Core {
public:
  Core(const std::string &name, const std::string &config, int rank, int size, const std::string &api);
  ~Core();

  // errors: the line told to the coupler first (its run stops with it), then thrown as precice::Error
  [[noreturn]] void fail(const std::string &call, const std::string &why);

  // meshes
  const MeshInfo &mesh(const std::string &call, const std::string &mesh, bool provided = false);
  int             add_vertices(const std::string &call, const std::string &mesh, const double *positions,
                               std::size_t values, int *ids);
  void            connect(const std::string &call, const std::string &mesh, const int *ids, std::size_t count,
                          int per_element, bool quad);
  std::size_t     vertex_count(const std::string &mesh) const;
  int             mesh_vertex_size(const std::string &call, const std::string &mesh);
  void            reset_mesh(const std::string &call, const std::string &mesh);

  // direct access to a received mesh
  void        set_access_region(const std::string &call, const std::string &mesh, const double *box, std::size_t n);
  std::size_t region_vertices(const std::string &call, const std::string &mesh, int *ids, double *coordinates,
                              std::size_t capacity, bool check_capacity);

  // data
  int  data_dimensions(const std::string &call, const std::string &mesh, const std::string &data);
  void write_values(const std::string &call, const std::string &mesh, const std::string &data, const int *ids,
                    std::size_t count, const double *values, std::size_t values_size);
  void read_values(const std::string &call, const std::string &mesh, const std::string &data, const int *ids,
                   std::size_t count, double relative_read_time, double *values, std::size_t values_size);
  bool requires_gradient(const std::string &call, const std::string &mesh, const std::string &data);
  void write_gradients(const std::string &call, const std::string &mesh, const std::string &data, const int *ids,
                       std::size_t count, const double *gradients, std::size_t size);
  void write_and_map(const std::string &call, const std::string &mesh, const std::string &data,
                     const double *coordinates, std::size_t coordinates_size, const double *values,
                     std::size_t values_size);
  void map_and_read(const std::string &call, const std::string &mesh, const std::string &data,
                    const double *coordinates, std::size_t coordinates_size, double relative_read_time,
                    double *values, std::size_t values_size);

  // time and the coupling
  void   initialize(const std::string &call);
  void   advance(const std::string &call, double dt);
  void   finalize(const std::string &call);
  // what preCICE's destructor does for a participant that did not finalize; never throws
  void   release();
  double remaining() const;

  bool ongoing() const { return ongoing_; }
  bool window_complete() const { return window_complete_; }
  // asked by the participant (requiresWritingCheckpoint, requiresReadingCheckpoint): advance checks that it was
  bool write_checkpoint() { asked_write_ = true; return write_checkpoint_; }
  bool read_checkpoint() { asked_read_ = true; return read_checkpoint_; }
  bool requires_initial_data() const { return !initial_.empty(); }
  bool requires_connectivity(const std::string &call, const std::string &mesh_name);
  int  mesh_dimensions(const std::string &call, const std::string &mesh_name);

private:
  enum class State { Constructed, Initialized, Finalized };

  std::vector<std::int64_t> checked_ids(const std::string &call, const std::string &mesh, const int *ids,
                                        std::size_t count);
  const DataSpec           *write_spec(const std::string &mesh, const std::string &data) const;
  const DataSpec           *read_spec(const std::string &mesh, const std::string &data) const;
  std::vector<double>      &buffer(const DataSpec &spec);
  void                      exchange(const std::string &op, cosim::Value args, const std::vector<cosim::OutArray> &arrays);
  MeshState                &direct(const std::string &call, const std::string &mesh);
  std::vector<std::int64_t> just_in_time(const std::string &call, const std::string &mesh, const std::string &direction,
                                         const double *coordinates, std::size_t size);
  void                      gradient_arrays(std::vector<cosim::OutArray> &arrays);

  std::string                                name_;
  std::string                                config_;
  int                                        rank_, size_;
  std::unique_ptr<cosim::Connection>         connection_;
  std::map<std::string, MeshState>           meshes_;
  std::vector<DataSpec>                      write_, read_;
  std::vector<std::string>                   initial_;
  bool                                       implicit_ = false, experimental_ = false;
  std::map<std::string, std::vector<double>> written_;        // data -> its values on its mesh's vertices
  std::map<std::string, std::vector<double>> gradients_;      // data -> vertices x (dim * components)
  std::map<std::string, std::vector<double>> received_;
  std::map<std::string, Waveform>            waveforms_;
  std::map<std::string, std::vector<double>> starts_;         // each read data item's value at the window's start
  std::vector<std::string>                   accumulated_;    // data written just in time this window
  std::vector<std::string>                   substep_data_;
  std::vector<double>                        sample_times_;   // normalised times of the steps inside the window
  std::map<std::string, std::vector<double>> samples_;        // data -> its values at each of them, stacked
  double                                     window_ = 0.0, window_start_ = 0.0, elapsed_ = 0.0;
  std::chrono::steady_clock::time_point      computing_since_;
  double                                     cpu_since_ = 0.0;
  State                                      state_ = State::Constructed;
  bool ongoing_ = true, window_complete_ = false, write_checkpoint_ = false, read_checkpoint_ = false;
  bool asked_write_ = false, asked_read_ = false;     // since the last exchange
};

} // namespace impl
} // namespace precice
