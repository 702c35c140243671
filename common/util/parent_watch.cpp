#include "util/parent_watch.h"

#include <sys/prctl.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <system_error>

namespace pd {

void exit_with_parent(pid_t expected_parent, int signal) {
  if (prctl(PR_SET_PDEATHSIG, signal) != 0)
    throw std::system_error(errno, std::generic_category(), "prctl(PR_SET_PDEATHSIG)");
  if (getppid() != expected_parent) std::raise(signal);
}

}  // namespace pd
