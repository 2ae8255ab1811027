#pragma once
// A participant's connection to cosim's coupler: one request at a time, each waiting for its reply.
//
// `cosim run` starts a participant with COSIM_PARTICIPANT_ENDPOINT (the coupler's loopback address),
// COSIM_PARTICIPANT_TOKEN (its token) and COSIM_COUPLER_PID in its environment. A participant started by hand finds
// them in cosim-run/coupler.json next to its configuration, which the coupler writes; the first participant started by
// hand starts that coupler (`cosim run CONFIG`) if none runs. While it waits, the participant checks every half
// second that the coupler still runs, and stops if it is gone.

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "wire.hpp"

namespace cosim {

// A misuse of the API or the coupling stopped (the library turns it into precice::Error).
struct Failure : std::runtime_error {
  explicit Failure(const std::string &message) : std::runtime_error(message) {}
};

struct Coupler {
  std::string endpoint;
  std::string token;
  int         pid;
};

// Where the coupler of `config` (an absolute path) listens: from the environment, else its rendezvous file,
// starting the coupler first if none runs.
Coupler find_coupler(const std::string &config);

// Whether `pid` runs (a zombie does not).
bool alive(int pid);

class Connection {
public:
  explicit Connection(const Coupler &coupler);
  ~Connection();
  Connection(const Connection &)            = delete;
  Connection &operator=(const Connection &) = delete;

  // Sends `op` and waits for its reply while the coupler lives; a refusal throws Failure with the coupler's message.
  std::pair<Value, std::map<std::string, Array>> request(const std::string &op, Value args,
                                                         const std::vector<OutArray> &arrays = {});
  // A message that wants no reply (the participant's own error, before it raises).
  void tell(const std::string &op, Value args);
  // Closes the socket, its queued messages sent first (at most a second).
  void close();

private:
  void send(const std::vector<std::string> &frames, int flags);

  void       *context_;
  void       *socket_;
  std::string token_;
  int         coupler_pid_;
  long long   ids_ = 0;
};

// Closes every open connection (their messages sent first): before the process exits on an error.
void close_all_connections();

} // namespace cosim
