#include "connection.hpp"

#include <zmq.h>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>
#include <thread>

extern char **environ;

namespace cosim {

namespace {

const int    SLICE_MS     = 500;
const double FIND_SECONDS = 60.0;

std::set<Connection *> &open_connections()
{
  static std::set<Connection *> connections;
  return connections;
}

std::string read_file(const std::string &path)
{
  std::ifstream     stream(path, std::ios::binary);
  std::stringstream text;
  text << stream.rdbuf();
  return text.str();
}

// /proc/<pid>/<what> ('' where there is none), NULs as spaces
std::string proc(const std::string &pid, const std::string &what)
{
  std::string text = read_file("/proc/" + pid + "/" + what);
  for (char &c : text)
    if (c == '\0') c = ' ';
  return text;
}

// The string and integer members of a flat JSON object ({"endpoint": "...", "token": "...", "pid": 123}).
std::map<std::string, std::string> flat_json(const std::string &text)
{
  std::map<std::string, std::string> members;
  std::size_t                        i = text.find('{');
  if (i == std::string::npos) return members;
  auto skip = [&]() { while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i; };
  auto quoted = [&](std::string &out) {
    if (i >= text.size() || text[i] != '"') return false;
    for (++i; i < text.size() && text[i] != '"'; ++i) {
      if (text[i] == '\\' && i + 1 < text.size()) ++i;
      out += text[i];
    }
    return i++ < text.size();
  };
  ++i;
  while (true) {
    skip();
    std::string key, value;
    if (!quoted(key)) break;
    skip();
    if (i >= text.size() || text[i] != ':') break;
    ++i;
    skip();
    if (i < text.size() && text[i] == '"') {
      if (!quoted(value)) break;
    } else {
      while (i < text.size() && text[i] != ',' && text[i] != '}' && !std::isspace(static_cast<unsigned char>(text[i])))
        value += text[i++];
    }
    members[key] = value;
    skip();
    if (i < text.size() && text[i] == ',') {
      ++i;
      continue;
    }
    break;
  }
  return members;
}

// Whether process `pid` listens at the TCP endpoint (tcp://host:port), from /proc; true where /proc cannot tell.
bool listens(int pid, const std::string &endpoint)
{
  std::size_t colon = endpoint.rfind(':');
  if (endpoint.compare(0, 6, "tcp://") != 0 || colon == std::string::npos) return false;
  std::string port_text = endpoint.substr(colon + 1);
  if (port_text.empty() || port_text.find_first_not_of("0123456789") != std::string::npos) return false;
  long                  port   = std::strtol(port_text.c_str(), nullptr, 10);
  std::string           tables = proc("self", "net/tcp") + proc("self", "net/tcp6");
  if (tables.empty()) return true;
  std::set<std::string> inodes;
  std::istringstream    lines(tables);
  std::string           line;
  while (std::getline(lines, line)) {
    std::istringstream       fields(line);
    std::vector<std::string> f;
    std::string              field;
    while (fields >> field) f.push_back(field);
    if (f.size() <= 9 || f[3] != "0A") continue;
    std::size_t sep = f[1].rfind(':');
    if (sep == std::string::npos) continue;
    if (std::strtol(f[1].substr(sep + 1).c_str(), nullptr, 16) == port) inodes.insert(f[9]);
  }
  std::string folder = "/proc/" + std::to_string(pid) + "/fd";
  for (int fd = 0; fd < 4096; ++fd) {
    char        link[256];
    std::string entry = folder + "/" + std::to_string(fd);
    ssize_t     n     = readlink(entry.c_str(), link, sizeof(link) - 1);
    if (n < 0) {
      if (errno == EACCES) return true;     // another user's process: its sockets cannot be read here
      continue;
    }
    link[n] = '\0';
    for (const std::string &inode : inodes)
      if (std::string(link) == "socket:[" + inode + "]") return true;
  }
  return false;
}

// The live coupler the rendezvous file names, or false (no file, or a stale one). A file another user could have
// written is not trusted: Failure says so.
bool running(const std::string &path, Coupler &found)
{
  struct stat status;
  if (lstat(path.c_str(), &status) != 0) return false;
  if (!S_ISREG(status.st_mode) || status.st_uid != getuid() || (status.st_mode & 022))
    throw Failure(path + " is not trusted: it " +
                  (!S_ISREG(status.st_mode) ? "is not a regular file"
                   : status.st_uid != getuid() ? "belongs to another user"
                                               : "can be written by others") +
                  ", so it may name another's coupler; remove it, or run in a folder of your own");
  std::map<std::string, std::string> members = flat_json(read_file(path));
  if (!members.count("pid")) return false;
  char *end = nullptr;
  long  pid = std::strtol(members["pid"].c_str(), &end, 10);
  if (end == members["pid"].c_str() || pid <= 0) return false;
  std::string command = proc(std::to_string(pid), "cmdline");
  if (!alive(static_cast<int>(pid)) || (!command.empty() && command.find("cosim") == std::string::npos)) return false;
  if (!listens(static_cast<int>(pid), members["endpoint"])) return false;
  found = Coupler{members["endpoint"], members["token"], static_cast<int>(pid)};
  return true;
}

std::string parent_of(const std::string &path)
{
  std::size_t slash = path.rfind('/');
  return slash == std::string::npos ? std::string(".") : slash == 0 ? std::string("/") : path.substr(0, slash);
}

// `cosim run CONFIG --out cosim-run/runs/<time>-<pid> --quiet` in a session of its own, its output in cosim-run's log.
pid_t start_coupler(const std::string &config, const std::string &folder)
{
  const char *given = std::getenv("COSIM");
  std::string cosim = given && *given ? given : "";
  if (cosim.empty()) {
    const char        *path = std::getenv("PATH");
    std::istringstream entries(path ? path : "");
    std::string        entry;
    while (std::getline(entries, entry, ':')) {
      std::string candidate = (entry.empty() ? "." : entry) + "/cosim";
      if (access(candidate.c_str(), X_OK) == 0) {
        cosim = candidate;
        break;
      }
    }
  }
  if (cosim.empty())
    throw Failure("no cosim coupler runs for " + config + ", and no `cosim` command starts one: put cosim on PATH or "
                  "set COSIM=/path/to/cosim, or start `cosim run " + config + "` first");
  char        stamp[32];
  std::time_t now = std::time(nullptr);
  std::strftime(stamp, sizeof(stamp), "%Y%m%d-%H%M%S", std::localtime(&now));
  std::string out = folder + "/runs/" + stamp + "-" + std::to_string(getpid());
  std::string log = folder + "/coupler.log";

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0600);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETSID);
  std::vector<std::string> words = {cosim, "run", config, "--out", out, "--quiet"};
  std::vector<char *>      argv;
  for (std::string &word : words) argv.push_back(&word[0]);
  argv.push_back(nullptr);
  pid_t child;
  int   failed = posix_spawn(&child, cosim.c_str(), &actions, &attributes, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  if (failed) throw Failure("could not start " + cosim + " for " + config + ": " + std::strerror(failed));
  std::string name = config.substr(config.rfind('/') + 1);
  std::cerr << "cosim: started the coupler for " << name << "; its run goes to " << out << std::endl;
  return child;
}

// The last line a log holds (the coupler's error when it stopped at start-up).
std::string last_line(const std::string &path)
{
  std::ifstream in(path);
  std::string   line, last;
  while (std::getline(in, line))
    if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
  return last.empty() ? "(nothing in " + path + ")" : last;
}

} // namespace

bool alive(int pid)
{
  if (pid <= 0) return false;
  if (kill(pid, 0) != 0 && errno == ESRCH) return false;
  std::string stat = proc(std::to_string(pid), "stat");
  std::size_t paren = stat.rfind(')');
  return paren == std::string::npos || paren + 2 >= stat.size() || stat[paren + 2] != 'Z';
}

Coupler find_coupler(const std::string &config)
{
  const char *endpoint = std::getenv("COSIM_PARTICIPANT_ENDPOINT");
  if (endpoint && *endpoint) {
    const char *token = std::getenv("COSIM_PARTICIPANT_TOKEN");
    const char *pid   = std::getenv("COSIM_COUPLER_PID");
    return Coupler{endpoint, token ? token : "", pid && *pid ? std::atoi(pid) : static_cast<int>(getppid())};
  }
  std::string folder     = parent_of(config) + "/cosim-run";
  std::string rendezvous = folder + "/coupler.json";
  Coupler     found;
  if (running(rendezvous, found)) return found;
  mkdir(folder.c_str(), 0700);
  std::string lock_path = folder + "/.lock";
  int         lock      = open(lock_path.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0600);   // not the coupler's
  if (lock < 0) throw Failure("cannot open " + lock_path + ": " + std::strerror(errno));
  flock(lock, LOCK_EX);      // one participant starts the coupler; the other waits for it
  try {
    bool  ready   = running(rendezvous, found);
    pid_t started = ready ? 0 : start_coupler(config, folder);
    auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(FIND_SECONDS);
    while (!ready) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      ready = running(rendezvous, found);
      int status = 0;
      if (!ready && started > 0 && waitpid(started, &status, WNOHANG) == started)
        throw Failure("the coupler started for " + config + " stopped (exit code " +
                      std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ") before it listened: " +
                      last_line(folder + "/coupler.log"));
      if (!ready && std::chrono::steady_clock::now() > deadline)
        throw Failure("the coupler started for " + config + " did not answer within 60 s (its log: " + folder +
                      "/coupler.log)");
    }
  } catch (...) {
    close(lock);
    throw;
  }
  close(lock);
  return found;
}

Connection::Connection(const Coupler &coupler) : token_(coupler.token), coupler_pid_(coupler.pid)
{
  context_ = zmq_ctx_new();
  socket_  = zmq_socket(context_, ZMQ_DEALER);
  int linger = 1000, timeout = SLICE_MS;
  zmq_setsockopt(socket_, ZMQ_LINGER, &linger, sizeof(linger));
  zmq_setsockopt(socket_, ZMQ_RCVTIMEO, &timeout, sizeof(timeout));
  if (zmq_connect(socket_, coupler.endpoint.c_str()) != 0) {
    std::string why = zmq_strerror(zmq_errno());
    zmq_close(socket_);
    zmq_ctx_term(context_);
    socket_ = context_ = nullptr;
    throw Failure("cannot connect to the cosim coupler at '" + coupler.endpoint + "': " + why);
  }
  open_connections().insert(this);
}

Connection::~Connection() { close(); }

void Connection::send(const std::vector<std::string> &frames, int flags)
{
  for (std::size_t i = 0; i < frames.size(); ++i) {
    int more = i + 1 < frames.size() ? ZMQ_SNDMORE : 0;
    while (zmq_send(socket_, frames[i].data(), frames[i].size(), more | flags) < 0) {
      if (zmq_errno() == EINTR) continue;
      if (flags & ZMQ_DONTWAIT) return;
      throw Failure(std::string("cannot send to the cosim coupler: ") + zmq_strerror(zmq_errno()));
    }
  }
}

std::pair<Value, std::map<std::string, Array>> Connection::request(const std::string &op, Value args,
                                                                   const std::vector<OutArray> &arrays)
{
  if (!socket_) throw Failure(op + ": the connection to the cosim coupler is closed");
  long long id = ++ids_;
  args.set("token", Value::of(token_));
  Value header = Value::map();
  header.set("op", Value::of(op));
  header.set("id", Value::of(id));
  header.set("args", std::move(args));
  send(encode(std::move(header), arrays), 0);
  while (true) {
    std::vector<std::string> frames;
    int                      more = 1;
    bool                     gave_up = false;
    while (more) {
      zmq_msg_t message;
      zmq_msg_init(&message);
      if (zmq_msg_recv(&message, socket_, 0) < 0) {
        int error = zmq_errno();
        zmq_msg_close(&message);
        if (error == EINTR) continue;
        if (error == EAGAIN && frames.empty()) {
          gave_up = true;
          break;
        }
        if (error == EAGAIN) continue;
        throw Failure(op + ": receiving from the cosim coupler failed: " + zmq_strerror(error));
      }
      frames.emplace_back(static_cast<const char *>(zmq_msg_data(&message)), zmq_msg_size(&message));
      more = zmq_msg_more(&message);
      zmq_msg_close(&message);
    }
    if (gave_up) {
      if (!alive(coupler_pid_))
        throw Failure(op + ": the cosim coupler (pid " + std::to_string(coupler_pid_) + ") is gone; the coupling stopped");
      continue;
    }
    std::pair<Value, std::map<std::string, Array>> reply;
    try {
      reply = decode(frames);
    } catch (const std::exception &error) {
      throw Failure(op + ": the coupler's reply: " + error.what());
    }
    if (reply.first.whole_of("id", -1) != id) continue;     // a late reply to a request given up on
    if (!reply.first.flag_of("ok")) {
      const Value *error   = reply.first.get("error");
      std::string  message = error ? error->string_of("message") : "";
      throw Failure(message.empty() ? "the coupler refused " + op : message);
    }
    Value        result;
    const Value *given = reply.first.get("result");
    result             = given && given->kind == Value::Map ? *given : Value::map();
    return {std::move(result), std::move(reply.second)};
  }
}

void Connection::tell(const std::string &op, Value args)
{
  if (!socket_) return;
  long long id = ++ids_;
  args.set("token", Value::of(token_));
  Value header = Value::map();
  header.set("op", Value::of(op));
  header.set("id", Value::of(id));
  header.set("args", std::move(args));
  send(encode(std::move(header), {}), ZMQ_DONTWAIT);
}

void Connection::close()
{
  open_connections().erase(this);
  if (socket_) {
    zmq_close(socket_);
    zmq_ctx_term(context_);
    socket_ = context_ = nullptr;
  }
}

void close_all_connections()
{
  std::set<Connection *> connections = open_connections();
  for (Connection *connection : connections) connection->close();
}

} // namespace cosim
