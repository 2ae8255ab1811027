#include "fatal.hpp"

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>

#include "connection.hpp"

namespace cosim {

void exit_on_error(const std::string &message)
{
  std::cout.flush();
  std::fflush(nullptr);
  std::cerr << "precice: error: " << message << std::endl;
  close_all_connections();      // the error told to the coupler leaves before the process does
  std::exit(2);
}

namespace {

std::terminate_handler previous = nullptr;

[[noreturn]] void on_terminate()
{
  std::exception_ptr current = std::current_exception();
  if (current) {
    try {
      std::rethrow_exception(current);
    } catch (const ::precice::Error &error) {
      exit_on_error(error.what());
    } catch (...) {
    }
  }
  if (previous) previous();
  std::abort();
}

struct InstallHandler {
  InstallHandler() { previous = std::set_terminate(on_terminate); }
} install;

} // namespace

} // namespace cosim
